"""The live viewer's adaptive history and TAA image after an orbit step (headless Chromium through
ssskit.view.browser; skipped without it): reprojected through the page's motion vectors (the previous
view-projection and the G-buffer's linear depth), each agrees with one converged afresh at the new view where the
validity test kept it, and the pixels it refused start over (Xie 2020 Eqs. 16-17; the TAA from this frame)."""
import base64
import math

import numpy as np
import pytest

from ssskit.view.browser import browser_available, headless_page
from tests.view.pages import read_target, static_bust

ok, why = browser_available()
pytestmark = pytest.mark.skipif(not ok, reason=why)

W, H = 192, 144
#: frames to converge a history (the EMA's weight on the first frame after 24 at alpha 0.2: 0.8^24 = 0.5 %)
FRAMES = 24
#: the orbit step (radians about the camera's up axis): up to ~3.5 pixels of motion on the bust at this size
STEP = 0.1


def _read(pg, name):
    return read_target(pg, name, W, H)


def _frames(pg, n):
    pg.evaluate(f"() => {{ for (let i = 0; i < {n}; ++i) window.ssskit.render(); }}")


@pytest.fixture(scope="module")
def histories(tmp_path_factory):
    """The bust's adaptive history converged at view A, then one frame after an orbit step to view B (reprojected),
    and a history converged afresh at B; the validity image and counts of the step's frame."""
    out = static_bust(tmp_path_factory)
    with headless_page(width=W + 320, height=max(H, 500)) as (pg, log):
        pg.goto((out / "index.html").as_uri() + f"?w={W}&h={H}")
        pg.wait_for_function("() => window.ssskit && window.ssskit.frames() > 0", timeout=30_000)
        pg.evaluate("() => window.ssskit.set({pass: 'adaptive', auto: false, transmission: false})")
        _frames(pg, FRAMES - 1)
        frame_a = pg.evaluate("() => window.ssskit.render()")
        src_a = _read(pg, "src")
        h_a = _read(pg, "history").copy()
        taa_a = _read(pg, "taa").copy()
        pg.evaluate(f"() => window.ssskit.orbit({STEP}, 0)")
        frame_b = pg.evaluate("() => window.ssskit.render()")
        src_b = _read(pg, "src")
        assert pg.evaluate("() => window.ssskit.reprojected()") == 1
        h_b1 = _read(pg, "history").copy()
        taa_b1 = _read(pg, "taa").copy()
        result_b1 = _read(pg, "result").copy()
        motion = _read(pg, "motion")[..., :2].copy()
        raw = base64.b64decode(pg.evaluate("() => window.ssskit.readValid()"))
        valid = np.frombuffer(raw, np.uint32).reshape(H, W)[::-1] > 0
        raw = base64.b64decode(pg.evaluate("() => window.ssskit.readCounts('used')"))
        counts = np.frombuffer(raw, np.int32).reshape(H, W)[::-1].copy()
        # a fresh history at B: a change of seed starts one (and back to seed 0, another)
        pg.evaluate("() => window.ssskit.set({seed: 1})")
        _frames(pg, 1)
        pg.evaluate("() => window.ssskit.set({seed: 0})")
        _frames(pg, FRAMES)
        assert pg.evaluate("() => window.ssskit.reprojected()") == 0
        h_fresh = _read(pg, "history").copy()
        taa_fresh = _read(pg, "taa").copy()
        # a second fresh TAA image with another seed: the converged images' own noise
        pg.evaluate("() => window.ssskit.set({seed: 2})")
        _frames(pg, FRAMES)
        taa_fresh2 = _read(pg, "taa").copy()
        log.check()
    return {"a": h_a, "b1": h_b1, "fresh": h_fresh, "motion": motion, "valid": valid, "counts": counts,
            "taa_a": taa_a, "taa_b1": taa_b1, "result_b1": result_b1, "taa_fresh": taa_fresh, "taa_fresh2": taa_fresh2,
            "src_a": src_a, "src_b": src_b, "frame_a": frame_a, "frame_b": frame_b}


def _noise_scale():
    """The spread of the difference of two converged histories' mu at one pixel: the adaptive sampler keeps a
    frame's variance of the gamma-corrected luminance at sigma0^2 (Xie 2020 Eqs. 13-15), the EMA of weight alpha
    (Eq. 6) has the stationary variance alpha / (2 - alpha) of its input's, and two independent ones differ by
    sqrt(2) of one: s = sqrt(2 sigma0^2 alpha / (2 - alpha))."""
    from ssskit.screenspace.adaptive import AdaptiveSettings

    st = AdaptiveSettings()
    return math.sqrt(2.0 * st.sigma0_sq * st.alpha / (2.0 - st.alpha))


def test_the_motion_is_the_orbit_step(histories):
    inside = histories["fresh"][..., 3] > 0
    mv = histories["motion"][inside]
    assert inside.mean() > 0.1
    # an orbit about the vertical axis moves the surface sideways: pixels of motion along u, far less along v
    assert np.abs(mv[:, 0]).max() > 2.0
    assert np.median(np.abs(mv[:, 0])) > 4 * np.median(np.abs(mv[:, 1]))


def test_reprojected_history_matches_a_fresh_converged_one_where_valid(histories):
    """Tolerance: mu (the EMA of the gamma-corrected luminance) of the history one frame after the step against a
    history converged at the new view, on the pixels the validity test kept: median |difference| below 0.674 s and
    95th percentile below 1.96 s (a normal difference of spread s, :func:`_noise_scale`). The history of view A
    used without reprojection exceeds that 95th percentile (the control: a page that ignored the motion fails)."""
    s = _noise_scale()
    b1, fresh, a = histories["b1"], histories["fresh"], histories["a"]
    keep = (b1[..., 3] > 0) & (fresh[..., 3] > 0) & histories["valid"]
    assert keep.sum() > 0.9 * (fresh[..., 3] > 0).sum()
    d = np.abs(b1[..., 1] - fresh[..., 1])[keep]
    assert np.median(d) < 0.674 * s, (np.median(d), s)
    assert np.percentile(d, 95) < 1.96 * s, (np.percentile(d, 95), s)
    d_static = np.abs(a[..., 1] - fresh[..., 1])[keep]
    assert np.percentile(d_static, 95) > 1.96 * s, (np.percentile(d_static, 95), s)


def test_disoccluded_pixels_restart_their_history(histories):
    """Pixels the validity test refused (the fetched pixel off the mesh, or its depth or normal another surface's)
    restart by Xie 2020 Eqs. 16-17: the variance is sigma0^2 (float32) and the mean count is this frame's count
    (alpha = 1). Some pixels must be refused: the step uncovers the bust's far side at its silhouette."""
    from ssskit.screenspace.adaptive import AdaptiveSettings

    b1 = histories["b1"]
    inside = b1[..., 3] > 0
    refused = inside & ~histories["valid"]
    assert refused.sum() > 10
    assert np.all(b1[..., 2][refused] == np.float32(AdaptiveSettings().sigma0_sq))
    assert np.all(b1[..., 0][refused] == histories["counts"][refused].astype(np.float32))
    # where the history was kept the variance is the EMA's (Eq. 9), not the restart value, nearly everywhere
    kept = inside & histories["valid"]
    assert np.mean(b1[..., 2][kept] == np.float32(AdaptiveSettings().sigma0_sq)) < 0.05


def _luminance(img):
    return img[..., :3].astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722])   # BT.709


def test_reprojected_taa_image_matches_a_fresh_converged_one_where_valid(histories):
    """Tolerance: the luminance of the TAA image one frame after the step against one converged at the new view, on
    the pixels the validity test kept: the 95th percentile of |difference| below 3 times that between two images
    converged at the new view with different seeds (the noise floor, measured here; the factor allows the bilinear
    fetch of the history, measured at 2.2 times on this scene). The image of view A used without reprojection
    exceeds that bound (measured 25 times the floor)."""
    b1, fresh, fresh2, a = histories["taa_b1"], histories["taa_fresh"], histories["taa_fresh2"], histories["taa_a"]
    keep = (b1[..., 3] > 0) & (fresh[..., 3] > 0) & histories["valid"]
    floor = np.percentile(np.abs(_luminance(fresh2) - _luminance(fresh))[keep], 95)
    assert floor > 0
    d = np.abs(_luminance(b1) - _luminance(fresh))[keep]
    assert np.percentile(d, 95) < 3 * floor, (np.percentile(d, 95), floor)
    d_static = np.abs(_luminance(a) - _luminance(fresh))[keep]
    assert np.percentile(d_static, 95) > 3 * floor, (np.percentile(d_static, 95), floor)


def test_taa_restarts_from_this_frame_where_refused(histories):
    b1, result = histories["taa_b1"], histories["result_b1"]
    refused = (b1[..., 3] > 0) & ~histories["valid"]
    assert refused.sum() > 10
    assert np.array_equal(b1[..., :3][refused], result[..., :3][refused])


def _camera(frame):
    """ssskit's Camera of a page frame: the page's GL view matrix (x right, y up, looking down -z) turned to
    ssskit's convention (x right, y down, looking down +z), its focal lengths, the principal point at the centre."""
    from ssskit.screenspace.camera import Camera

    view = np.array(frame["view"], dtype=np.float64).reshape(4, 4).T      # column-major
    return Camera(W, H, frame["fx"], frame["fy"], W / 2, H / 2, np.diag([1.0, -1.0, -1.0, 1.0]) @ view)


def test_validity_is_ssskits_depth_test_and_a_normal_test(histories):
    """The page's validity image against ssskit.screenspace.taa.reprojection_valid (default tolerance) on the
    page's own linear depth of both frames: every pixel the page keeps passes ssskit's test, but for pixels within
    float32 rounding of a pixel edge or the tolerance (at most 0.5 % of the mesh's); the page's normal test refuses
    a few more (at most 5 % of the mesh's)."""
    from ssskit.screenspace.taa import reprojection_valid

    def depth(src):
        return np.where(src[..., 3] > 0, src[..., 3], np.inf).astype(np.float64)

    z_b = depth(histories["src_b"])
    ref = reprojection_valid(z_b, _camera(histories["frame_b"]), depth(histories["src_a"]),
                             _camera(histories["frame_a"]))
    mesh = np.isfinite(z_b)
    page = histories["valid"]
    assert (page & ~ref)[mesh].mean() <= 0.005
    assert (ref & ~page)[mesh].mean() <= 0.05
    assert (~ref)[mesh].sum() > 10          # the step refuses some of the mesh's pixels
