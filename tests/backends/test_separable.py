"""The separable pass on every backend (the ``backend`` fixture): physical properties, and agreement with
the float64 numpy oracle within the (backend, dtype) tolerance of tests/conftest.py."""

import json
import subprocess
import sys

import numpy as np
import pytest

from ssskit.backends import build_separable_plan, get_backend
from ssskit.kernels import build_kernel, default_grid, parse_method_spec
from ssskit.profiles import profile_for_material
from ssskit.sampling.taps import SeparableTaps, make_taps
from ssskit.screenspace import Camera, GBuffer, filter_arrays, separable_sss
from tests.conftest import tolerance


def _taps(spec: str, material: str = "skin1", n: int = 7):
    prof = profile_for_material(material, "dipole")
    m, params, _ = parse_method_spec(spec)
    cell, size = default_grid(prof)
    return make_taps(build_kernel(m.name, prof, cell, size, **params), n)


def _three_materials(h=48, w=64, seed=1):
    """A G-buffer with three profile ids (two disks and a band), background without SSS, a tilted depth."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w]
    pid = np.zeros((h, w), np.uint32)
    pid[(xx - 20) ** 2 + (yy - 24) ** 2 < 15**2] = 1
    pid[(xx - 44) ** 2 + (yy - 24) ** 2 < 15**2] = 2
    pid[40:, :] = 3
    depth = (300 + 2 * xx + 3 * np.sin(yy / 3)).astype(np.float32)
    depth[pid == 0] = np.inf
    gb = GBuffer(diffuse=rng.random((h, w, 3)).astype(np.float32), albedo=np.full((h, w, 3), 0.5, np.float32),
                 depth=depth, profile_id=pid, camera=Camera(w, h, 400.0, 350.0, w / 2, h / 2))
    taps = {1: _taps("preintegrated", "skin1"), 2: _taps("svd:2", "marble", 5), 3: _taps("artist", "ketchup")}
    return gb, taps


# ---- physical properties ------------------------------------------------------------------------------

def test_constant_irradiance_unchanged(taps7, backend):
    h, w = 40, 50
    e = np.full((h, w, 3), 0.7, np.float32)
    tilted = (300 + 3.0 * np.arange(w)[None, :] + 0 * np.arange(h)[:, None]).astype(np.float32)
    for depth in (np.full((h, w), 400.0, np.float32), tilted):
        for mode in ("follow", "gaussian", "none"):
            out = filter_arrays(e, depth, 300.0, 300.0, taps7, jitter=0.3, depth_mode=mode, backend=backend)
            np.testing.assert_allclose(out, 0.7, rtol=1e-6)


def test_single_lit_pixel_returns_the_kernel(taps7, backend):
    n = 61
    e = np.zeros((n, n, 3), np.float32)
    e[n // 2, n // 2] = 1.0
    z, pixel_mm = 400.0, 1.0 / 3.0  # a pixel covers pixel_mm at depth z: f = z / pixel_mm
    f = z / pixel_mm
    out = filter_arrays(e, np.full((n, n), z, np.float32), f, f, taps7, jitter=0.0, depth_mode="none", backend=backend)
    k2d = taps7.to_kernel(pixel_mm, n).to_2d()
    np.testing.assert_allclose(out, k2d, atol=1e-6)
    np.testing.assert_allclose(out.sum(axis=(0, 1)), 1.0, rtol=1e-5)


def test_energy_conserved_inside_mask_and_no_bleed(taps7, backend, rng):
    h, w = 48, 64
    yy, xx = np.mgrid[0:h, 0:w]
    inside = (xx - 30) ** 2 + (yy - 22) ** 2 < 18**2
    depth = np.where(inside, 400.0, np.inf).astype(np.float32)
    e = rng.random((h, w, 3)).astype(np.float32)
    out = filter_arrays(e, depth, 200.0, 200.0, taps7, jitter=0.0, backend=backend)
    np.testing.assert_allclose(out[inside].sum(axis=0), e[inside].sum(axis=0), rtol=1e-5)
    np.testing.assert_array_equal(out[~inside], e[~inside])  # stencil: untouched
    # a bright surround does not leak in
    e2 = np.where(inside[..., None], 0.0, np.full(3, 100.0)).astype(np.float32)
    out2 = filter_arrays(e2, depth, 200.0, 200.0, taps7, jitter=0.3, backend=backend)
    assert np.all(out2[inside] == 0.0)


def test_no_bleed_between_profile_ids(backend):
    """Each material conserves its own energy and sees nothing of its neighbours (one pass, three ids)."""
    gb, taps = _three_materials()
    out = separable_sss(gb, taps, jitter=0.0, backend=backend)
    for i in (1, 2, 3):
        sel = gb.profile_id == i
        np.testing.assert_allclose(out[sel].sum(axis=0), gb.diffuse[sel].sum(axis=0), rtol=2e-5)
        dark = np.broadcast_to(np.where(sel[..., None], 0.0, 1e3), gb.diffuse.shape).astype(np.float32)
        only = separable_sss(gb.with_layers(diffuse=dark), taps,
                             jitter=0.3, backend=backend)
        assert np.all(only[sel] == 0.0), f"light of other ids reached id {i}"
    np.testing.assert_array_equal(out[gb.profile_id == 0], gb.diffuse[gb.profile_id == 0])


def test_depth_test_stops_bleeding_across_a_depth_step(taps7, backend):
    h, w = 16, 60
    e = np.zeros((h, w, 3), np.float32)
    e[:, :30] = 1.0
    depth = np.full((h, w), 400.0, np.float32)
    depth[:, 30:] = 500.0  # 100 mm behind: a different surface
    follow = filter_arrays(e, depth, 300.0, 300.0, taps7, jitter=0.0, depth_mode="follow", backend=backend)
    plain = filter_arrays(e, depth, 300.0, 300.0, taps7, jitter=0.0, depth_mode="none", backend=backend)
    assert np.all(follow[:, 30:] == 0.0)
    assert plain[:, 30:].max() > 0.05


def test_gaussian_depth_correction_factor(skin, backend):
    """Supplement E: a sample d_z away is weighted exp(-d_z^2 / (2 tau_max)); the rest stays at the centre."""
    cell, n = default_grid(skin)
    t = make_taps(build_kernel("artist", skin, cell, n), 3)
    assert t.tau_max_mm2 == pytest.approx(1.0)  # 'close fit' sigma_far red = 1.0 mm
    # three pixels in a row; taps at +-d land exactly on the neighbours; neighbours 0.8 mm deeper
    o = float(t.offsets_mm[0, 1])
    f = 100.0 / abs(o)  # 1 px per |o| at depth 100 mm
    depth = np.array([[100.8, 100.0, 100.8]], np.float32)
    e = np.array([[[1.0] * 3, [0.0] * 3, [1.0] * 3]], np.float32)
    out = filter_arrays(e, depth, f, 1.0, t, jitter=0.0, depth_mode="gaussian", backend=backend)
    side = t.weights[0][1:].sum(axis=0)
    np.testing.assert_allclose(out[0, 1], side * np.exp(-0.8**2 / 2.0), rtol=1e-5)  # depth stored as float32


def test_non_square_pixels_scale_each_axis(taps7, backend):
    n = 81
    e = np.zeros((n, n, 3), np.float32)
    e[n // 2, n // 2] = 1.0
    out = filter_arrays(e, np.full((n, n), 400.0, np.float32), 2000.0, 1000.0, taps7, jitter=0.0, backend=backend)
    c = np.arange(n) - n // 2
    var_x = (out[..., 0].sum(axis=0) * c**2).sum()
    var_y = (out[..., 0].sum(axis=1) * c**2).sum()
    assert var_x / var_y == pytest.approx(4.0, rel=0.05)  # twice the pixels per mm horizontally


def test_footprint_larger_than_the_image(taps7, backend, rng):
    """An extreme close-up: every tap but the centre lands off the image, so each pixel keeps its value."""
    e = rng.random((8, 10, 3)).astype(np.float32)
    for jitter in (0.0, 1.0):
        out = filter_arrays(e, np.full((8, 10), 1.0, np.float32), 1e5, 1e5, taps7, jitter=jitter, backend=backend)
        np.testing.assert_allclose(out, e, rtol=1e-6)


def test_results_never_alias(taps7, backend, rng):
    """A second frame must not overwrite the first frame's result (temporal history keeps it)."""
    depth = np.full((20, 30), 300.0, np.float32)
    a_in, b_in = rng.random((20, 30, 3)).astype(np.float32), rng.random((20, 30, 3)).astype(np.float32)
    a = filter_arrays(a_in, depth, 400.0, 400.0, taps7, backend=backend)
    keep = a.copy()
    b = filter_arrays(b_in, depth, 400.0, 400.0, taps7, backend=backend)
    assert not np.shares_memory(a, b)
    np.testing.assert_array_equal(a, keep)


# ---- agreement with the oracle ------------------------------------------------------------------------

@pytest.mark.parametrize("mode", ["follow", "gaussian", "none"])
@pytest.mark.parametrize("jitter", [0.0, 0.3, 1.0])
@pytest.mark.parametrize("method", ["preintegrated", "svd:2", "artist", "jimenez2012"])
def test_matches_the_numpy_oracle(mode, jitter, method, backend, rng):
    t = _taps(method, n=11 if method == "jimenez2012" else 7)
    h, w = 40, 56
    yy, xx = np.mgrid[0:h, 0:w]
    depth = (300 + 2 * xx + 5 * np.sin(yy / 3)).astype(np.float32)
    depth[10:20, 10:30] = np.inf
    depth[30:35, 40:50] += 30
    e = rng.random((h, w, 3)).astype(np.float32)
    a = filter_arrays(e, depth, 400.0, 300.0, t, jitter=jitter, depth_mode=mode, frame=3, seed=9, backend=backend)
    b = filter_arrays(e, depth, 400.0, 300.0, t, jitter=jitter, depth_mode=mode, frame=3, seed=9, backend="numpy")
    np.testing.assert_allclose(a, b, atol=tolerance(backend))


@pytest.mark.parametrize("rho", [0.8, 1.2, 1.7, 2.1, 2.5, 2.9, 3.5])
def test_every_jitter_window_matches_the_oracle(rho, backend, rng):
    """The jittered taps' footprint rho (pixels) picks the numba backend's window (rings of 8, 20, 24, 36,
    44, 48 texels up to rho = 1, sqrt 2, 2, sqrt 5, sqrt 8, 3; per-lane fetches past 3): each against the
    oracle, on a surface with a depth slope, a depth step and a hole."""
    t = _taps("preintegrated")
    assert t.jitter_count(0.1) == 3  # the centre and the +-0.58 mm pair
    h, w = 36, 52
    yy, xx = np.mgrid[0:h, 0:w]
    depth = (300 + 0.2 * xx + 2 * np.sin(yy / 4)).astype(np.float32)
    depth[12:16, 20:30] += 5
    depth[25:28, 5:12] = np.inf
    f = rho * 300.0 / float(np.abs(t.offsets_mm[0][1]))
    e = rng.random((h, w, 3)).astype(np.float32)
    for mode in ("follow", "gaussian"):
        a = filter_arrays(e, depth, f, 0.9 * f, t, jitter=0.1, depth_mode=mode, frame=4, seed=1, backend=backend)
        b = filter_arrays(e, depth, f, 0.9 * f, t, jitter=0.1, depth_mode=mode, frame=4, seed=1, backend="numpy")
        np.testing.assert_allclose(a, b, atol=tolerance(backend))


@pytest.mark.parametrize("mode", ["follow", "none"])
@pytest.mark.parametrize("jitter", [0.0, 0.3])
def test_three_profile_ids_match_the_oracle(mode, jitter, backend):
    """Blocks straddling two materials take each pixel's own taps (per-lane path on the CPU)."""
    gb, taps = _three_materials()
    a = separable_sss(gb, taps, jitter=jitter, depth_mode=mode, frame=2, seed=5, backend=backend)
    b = separable_sss(gb, taps, jitter=jitter, depth_mode=mode, frame=2, seed=5, backend="numpy")
    np.testing.assert_allclose(a, b, atol=tolerance(backend))


@pytest.mark.parametrize("jitter", [0.0, 0.5])
def test_unpaired_taps_match_the_oracle(jitter, backend, rng):
    """Asymmetric taps (a user's tap file) are single rows."""
    taps = SeparableTaps([[0.0, 0.7, -1.3, 2.2]], [[[0.4] * 3, [0.3, 0.2, 0.1], [0.2] * 3, [0.1, 0.3, 0.2]]],
                         [[1.0, 1.0, 1.0]], "custom", 2.2).normalised()
    e = rng.random((30, 40, 3)).astype(np.float32)
    depth = (300 + 3 * np.arange(40)[None, :] + 0 * np.arange(30)[:, None]).astype(np.float32)
    depth[5:9, 5:15] = np.inf
    a = filter_arrays(e, depth, 350.0, 420.0, taps, jitter=jitter, frame=1, backend=backend)
    b = filter_arrays(e, depth, 350.0, 420.0, taps, jitter=jitter, frame=1, backend="numpy")
    np.testing.assert_allclose(a, b, atol=tolerance(backend))


def test_jitter_seeded_and_thread_count_independent(taps7, rng, backend):
    import numba

    e = rng.random((64, 64, 3)).astype(np.float32)
    depth = np.full((64, 64), 300.0, np.float32)
    run = lambda **kw: filter_arrays(e, depth, 400.0, 400.0, taps7, jitter=0.3, backend=backend, **kw)  # noqa: E731
    a = run(frame=1, seed=2)
    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        b = run(frame=1, seed=2)
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, run(frame=2, seed=2))
    assert not np.array_equal(a, run(frame=1, seed=3))


def test_plan_holds_every_id_in_one_pass():
    gb, taps = _three_materials()
    plan = build_separable_plan(taps, 400.0, 350.0, jitter=0.1, depth_mode="follow")
    assert plan.ids == (1, 2, 3) and plan.slots == 4
    assert len(plan.terms) == 2  # the largest rank (svd:2)
    np.testing.assert_array_equal(plan.terms[1].n_rows, [0, 0, 2, 0])  # only id 2 has a second term
    np.testing.assert_array_equal(plan.slot_map(gb.profile_id)[gb.profile_id == 2], 2)


def test_numba_kernels_are_cached_on_disk(tmp_path):
    """A second process compiles nothing it compiled before (numba cache=True on every kernel)."""
    code = (
        "import json, numpy as np\n"
        "from ssskit.kernels import build_kernel\n"
        "from ssskit.sampling.taps import make_taps\n"
        "from ssskit.screenspace import filter_arrays\n"
        "from ssskit.backends import _numba_separable as m\n"
        "t = make_taps(build_kernel('jimenez2012', None, taps=11))\n"
        "e = np.ones((16, 24, 3), np.float32); d = np.full((16, 24), 300.0, np.float32)\n"
        "filter_arrays(e, d, 400.0, 400.0, t, jitter=0.1, depth_mode='follow', backend='numba')\n"
        "print(json.dumps({k: sum(getattr(f.stats, k).values()) for k in ('cache_hits', 'cache_misses')\n"
        "                  for f in (m.pass_follow,)}))\n")
    runs = [json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                      check=True).stdout) for _ in range(2)]
    assert runs[1]["cache_misses"] == 0 and runs[1]["cache_hits"] >= 1


def test_unknown_and_unavailable_backends():
    from ssskit.backends import BACKENDS, Backend, backend_status
    from ssskit.errors import BackendError

    with pytest.raises(BackendError, match="unknown backend 'cuda'"):
        get_backend("cuda")
    status = backend_status()
    assert set(status) == set(BACKENDS.names()) and all(s["available"] for s in status.values())

    class Missing(Backend):
        name = "missing"

        def availability(self):
            return False, "libmissing.so not found"

        def _separable(self, plan, diffuse, depth_mm, slots):
            raise AssertionError("never called")

    BACKENDS.register("missing-test", Missing)
    try:
        with pytest.raises(BackendError, match="not available: libmissing.so not found"):
            get_backend("missing-test")
    finally:
        BACKENDS._entries.pop("missing-test")


@pytest.mark.parametrize("width", [1, 5, 15, 16, 17, 33])
def test_narrow_images_unused_slots_and_empty_frames(width, backend, rng):
    """Images narrower than a block of lanes, a plan slot with no pixels, a frame with no SSS at all."""
    h = 12
    e = rng.random((h, width, 3)).astype(np.float32)
    depth = (300 + 2 * np.arange(width)[None, :] + 0 * np.arange(h)[:, None]).astype(np.float32)
    taps = {1: _taps("preintegrated"), 2: _taps("artist"), 3: _taps("svd:2")}
    plan = build_separable_plan(taps, 400.0, 400.0, jitter=0.3, depth_mode="follow", frame=1)
    slots = np.ones((h, width), np.int32)
    slots[:, width // 2:] = 3  # slot 2 has no pixels
    out = get_backend(backend).separable(plan, e, depth, slots)
    ref = get_backend("numpy").separable(plan, e, depth, slots)
    np.testing.assert_allclose(out, ref, atol=tolerance(backend))
    none = get_backend(backend).separable(plan, e, depth, np.zeros_like(slots))
    np.testing.assert_array_equal(none, e)


def test_bad_depths_colours_and_slots_are_refused(taps7, backend, rng):
    """A pixel with SSS needs a positive finite depth and a slot of the plan, on the first frame of a size and on
    later ones (the numba backend checks while it packs the frame, with or without the last frame's pad);
    a pixel without SSS may hold any depth and keeps its value. Every pixel needs a finite colour (with SSS or
    not: the pass reads its neighbours' colours); slots must be an integer image (float slots are refused,
    never truncated); a colour and depth given as nested lists are converted and give the arrays' result."""
    from ssskit.errors import PassError

    plan = build_separable_plan({1: taps7, 2: taps7}, 400.0, 400.0, jitter=0.1, depth_mode="follow")
    be = get_backend(backend)
    for h, w, warm in ((13, 21, False), (13, 22, True)):  # sizes no other test uses
        e = rng.random((h, w, 3)).astype(np.float32)
        slots = np.ones((h, w), np.int32)
        slots[:, 12:] = 2
        good = np.full((h, w), 300.0, np.float32)
        if warm:  # a good frame first: the frames below reuse its pad
            be.separable(plan, e, good, slots)
        for bad in (np.nan, -1.0, 0.0, np.inf):
            d = good.copy()
            d[5, 7] = bad
            with pytest.raises(PassError, match=r"depth must (be finite|lie in \(0, inf\) mm), got .* pixels with SSS"):
                be.separable(plan, e, d, slots)
        for slot in (-1, 3):
            q = slots.copy()
            q[2, 3] = slot
            with pytest.raises(PassError, match=r"slots must lie in \[0, 2\], got"):
                be.separable(plan, e, good, q)
        q, d = slots.copy(), good.copy()
        q[4, 4], d[4, 4] = 0, np.nan
        out = be.separable(plan, e, d, q)
        np.testing.assert_array_equal(out[4, 4], e[4, 4])
        assert np.all(np.isfinite(out))
        for bad, pixel in ((np.nan, (5, 7, 0)), (np.inf, (0, 0, 2)), (-np.inf, (4, 4, 1))):  # (4, 4): no SSS in q
            f = e.copy()
            f[pixel] = bad
            with pytest.raises(PassError, match=r"diffuse must be finite, got NaN or inf in \d+ of \d+ colour values"):
                be.separable(plan, f, good, q)
        with pytest.raises(PassError, match=r"slots must be an integer array of shape \(\d+, \d+\), got shape \(\d+, \d+\) float32"):
            be.separable(plan, e, good, slots.astype(np.float32))
        if warm:
            np.testing.assert_array_equal(be.separable(plan, e.tolist(), good.tolist(), slots),
                                          be.separable(plan, e, good, slots))


def test_a_backend_is_named_by_a_string():
    """get_backend(3) is the registry's BackendError listing the backends, not an AttributeError."""
    from ssskit.errors import BackendError

    for wrong in (3, None, b"numba"):
        with pytest.raises(BackendError, match="a backend is named by a string, got .* \\(known: numba"):
            get_backend(wrong)


def test_backend_instances_are_keyed_by_name():
    from ssskit.backends import BACKENDS, Backend

    class A(Backend):
        def _separable(self, plan, diffuse, depth_mm, slots):
            return "a"

    class B(A):
        def _separable(self, plan, diffuse, depth_mm, slots):
            return "b"

    BACKENDS.register("test-a", lambda: A())
    BACKENDS.register("test-b", lambda: B())  # same factory __name__ ('<lambda>')
    try:
        assert get_backend("test-a")._separable(None, None, None, None) == "a"
        assert get_backend("test-b")._separable(None, None, None, None) == "b"
    finally:
        BACKENDS._entries.pop("test-a")
        BACKENDS._entries.pop("test-b")
