"""G-buffers, taps and the separable screen-space pass (separable-SSS paper section 6, supplement E)."""

import numpy as np
import pytest

from ssskit.kernels import build_kernel, default_grid
from ssskit.profiles import profile_for_material
from ssskit.sampling.taps import make_taps
from ssskit.errors import SamplingError
from ssskit.errors import GBufferError, PassError, SettingsError
from ssskit.screenspace import Camera, GBuffer, filter_arrays, load_gbuffer, motion_vectors

#: max |numba - numpy| per image dtype (numba computes in float32, numpy in float64)
PARITY_ATOL = {np.float32: 2e-5}


@pytest.fixture(scope="module")
def skin():
    return profile_for_material("skin1", "dipole")


@pytest.fixture(scope="module")
def taps7(skin):
    cell, n = default_grid(skin)
    return make_taps(build_kernel("preintegrated", skin, cell, n), 7)


def _gbuffer(h=24, w=32, depth=500.0, pid=None, diffuse=None, fx=400.0, fy=None):
    cam = Camera(w, h, fx, fx if fy is None else fy, w / 2, h / 2)
    rng = np.random.default_rng(1)
    return GBuffer(diffuse=rng.random((h, w, 3)).astype(np.float32) if diffuse is None else diffuse,
                   albedo=np.full((h, w, 3), 0.5, np.float32), depth=np.full((h, w), depth, np.float32),
                   profile_id=np.ones((h, w), np.uint32) if pid is None else pid, camera=cam,
                   specular=np.zeros((h, w, 3), np.float32), normal=np.zeros((h, w, 3), np.float32),
                   materials=("Skin1",), meta={"note": "test"})


# ---- G-buffers ------------------------------------------------------------------------------------

def test_gbuffer_exr_roundtrip_official_bindings(tmp_path):
    gb = _gbuffer()
    gb.depth[0, 0] = np.inf  # background: allowed where there is no SSS
    gb.profile_id[0, 0] = 0
    p = tmp_path / "g.exr"
    gb.save(p)
    assert p.read_bytes()[:4] == b"\x76\x2f\x31\x01"  # OpenEXR magic number, not TIFF
    back = load_gbuffer(p)
    for name in ("diffuse", "specular", "albedo", "depth", "normal", "profile_id"):
        np.testing.assert_array_equal(getattr(back, name), getattr(gb, name))
    assert back.camera.to_dict() == gb.camera.to_dict()
    assert back.materials == ("Skin1",) and back.meta == {"note": "test"}


@pytest.mark.parametrize("change, layer", [
    (dict(albedo=np.zeros((5, 5, 3), np.float32)), "albedo"),
    (dict(depth=np.full((24, 32), np.nan, np.float32)), "depth"),
    (dict(depth=np.full((24, 32), -1.0, np.float32)), "depth"),
    (dict(depth=np.full((24, 32), 5, np.int32)), "depth"),
    (dict(profile_id=np.ones((24, 32), np.float32)), "profile_id"),
    (dict(diffuse=np.full((24, 32, 3), np.nan, np.float32)), "diffuse"),
    (dict(specular=np.ones((24, 32), np.float32)), "specular"),
])
def test_gbuffer_errors_name_the_layer(change, layer):
    gb = _gbuffer()
    kw = dict(diffuse=gb.diffuse, albedo=gb.albedo, depth=gb.depth, profile_id=gb.profile_id, camera=gb.camera)
    kw.update(change)
    with pytest.raises(GBufferError, match=repr(layer)):
        GBuffer(**kw)


def test_gbuffer_file_missing_layer_named(tmp_path):
    import OpenEXR

    p = tmp_path / "partial.exr"
    with OpenEXR.File({"type": OpenEXR.scanlineimage}, {"diffuse": np.ones((4, 4, 3), np.float32)}) as f:
        f.write(str(p))
    with pytest.raises(GBufferError, match="'albedo'"):
        load_gbuffer(p)
    (tmp_path / "junk.exr").write_bytes(b"not an exr")
    with pytest.raises(GBufferError, match="not an OpenEXR"):
        load_gbuffer(tmp_path / "junk.exr")


def test_camera_unproject_project_and_motion_vectors():
    cam = Camera.from_fov(40, 30, 50.0)
    depth = np.full((30, 40), 200.0)
    uv, z = cam.project(cam.unproject(depth))
    v, u = np.mgrid[0:30, 0:40] + 0.5
    np.testing.assert_allclose(uv[..., 0], u, atol=1e-9)
    np.testing.assert_allclose(z, depth)
    np.testing.assert_allclose(motion_vectors(depth, cam, cam), 0.0, atol=1e-9)
    # previous camera 5 units to the left: points were fx * 5 / z pixels further right
    m = np.eye(4)
    m[0, 3] = 5.0
    prev = Camera(40, 30, cam.fx, cam.fy, cam.cx, cam.cy, m)
    mv = motion_vectors(depth, cam, prev)
    np.testing.assert_allclose(mv[..., 0], cam.fx * 5.0 / 200.0)
    np.testing.assert_allclose(mv[..., 1], 0.0, atol=1e-12)


# ---- taps -----------------------------------------------------------------------------------------

def test_importance_taps_equal_mass_of_dominant_channel(taps7):
    t = taps7
    assert t.taps == 7 and t.rank == 1
    np.testing.assert_allclose(t.total(), 1.0, rtol=1e-12)
    o = t.offsets_mm[0]
    assert o[0] == 0.0 and np.allclose(np.sort(o), -np.sort(o)[::-1])
    # red is the widest channel of skin: every cell holds 1/7 of its (normalised) 1D mass
    np.testing.assert_allclose(t.weights[0][:, 0], 1.0 / 7.0, rtol=1e-6)
    # narrower channels put more weight on the centre tap
    assert t.weights[0][0, 2] > t.weights[0][0, 1] > t.weights[0][0, 0]


def test_uniform_and_quadratic_spacing(skin):
    cell, n = default_grid(skin)
    k = build_kernel("preintegrated", skin, cell, n)
    u = np.sort(make_taps(k, 7, "uniform").offsets_mm[0])
    np.testing.assert_allclose(np.diff(u), np.diff(u)[0], rtol=1e-9)
    q = np.sort(make_taps(k, 7, "quadratic").offsets_mm[0])
    # o_i proportional to sign(t) t^2 at t = -3..3 (engine spacing): 9 : 4 : 1
    np.testing.assert_allclose(q[4:] / q[6], [1 / 9, 4 / 9, 1.0], rtol=1e-9)
    with pytest.raises(SamplingError, match="odd"):
        make_taps(k, 6)


# ---- the pass: physical properties ------------------------------------------------------------------

BACKENDS = ["numba", "numpy"]


@pytest.mark.parametrize("backend", BACKENDS)
def test_constant_irradiance_unchanged(taps7, backend):
    h, w = 40, 50
    e = np.full((h, w, 3), 0.7, np.float32)
    tilted = (300 + 3.0 * np.arange(w)[None, :] + 0 * np.arange(h)[:, None]).astype(np.float32)
    for depth in (np.full((h, w), 400.0, np.float32), tilted):
        for mode in ("follow", "gaussian", "none"):
            out = filter_arrays(e, depth, 300.0, 300.0, taps7, jitter=0.3, depth_mode=mode, backend=backend)
            np.testing.assert_allclose(out, 0.7, rtol=1e-6)


@pytest.mark.parametrize("backend", BACKENDS)
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


@pytest.mark.parametrize("backend", BACKENDS)
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


@pytest.mark.parametrize("backend", BACKENDS)
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


def test_gaussian_depth_correction_factor(skin):
    """Supplement E: a sample d_z away is weighted exp(-d_z^2 / (2 tau_max)); the rest stays at the centre."""
    cell, n = default_grid(skin)
    t = make_taps(build_kernel("artist", skin, cell, n), 3)
    assert t.tau_max_mm2 == pytest.approx(1.0)  # 'close fit' sigma_far red = 1.0 mm
    # three pixels in a row; taps at +-d land exactly on the neighbours; neighbours 0.8 mm deeper
    o = float(t.offsets_mm[0, 1])
    f = 100.0 / abs(o)  # 1 px per |o| at depth 100 mm
    depth = np.array([[100.8, 100.0, 100.8]], np.float32)
    e = np.array([[[1.0] * 3, [0.0] * 3, [1.0] * 3]], np.float32)
    out = filter_arrays(e, depth, f, 1.0, t, jitter=0.0, depth_mode="gaussian", backend="numpy")
    side = t.weights[0][1:].sum(axis=0)
    np.testing.assert_allclose(out[0, 1], side * np.exp(-0.8**2 / 2.0), rtol=1e-5)  # depth stored as float32


@pytest.mark.parametrize("backend", BACKENDS)
def test_non_square_pixels_scale_each_axis(taps7, backend):
    n = 81
    e = np.zeros((n, n, 3), np.float32)
    e[n // 2, n // 2] = 1.0
    out = filter_arrays(e, np.full((n, n), 400.0, np.float32), 2000.0, 1000.0, taps7, jitter=0.0, backend=backend)
    c = np.arange(n) - n // 2
    var_x = (out[..., 0].sum(axis=0) * c**2).sum()
    var_y = (out[..., 0].sum(axis=1) * c**2).sum()
    assert var_x / var_y == pytest.approx(4.0, rel=0.05)  # twice the pixels per mm horizontally


@pytest.mark.parametrize("mode", ["follow", "gaussian", "none"])
@pytest.mark.parametrize("jitter", [0.0, 0.3])
@pytest.mark.parametrize("method", ["preintegrated", "svd:2", "artist"])
def test_numba_matches_numpy_reference(skin, mode, jitter, method, rng):
    from ssskit.kernels import parse_method_spec

    m, params, _ = parse_method_spec(method)
    cell, n = default_grid(skin)
    t = make_taps(build_kernel(m.name, skin, cell, n, **params), 7)
    h, w = 40, 56
    yy, xx = np.mgrid[0:h, 0:w]
    depth = (300 + 2 * xx + 5 * np.sin(yy / 3)).astype(np.float32)
    depth[10:20, 10:30] = np.inf
    depth[30:35, 40:50] += 30
    e = rng.random((h, w, 3)).astype(np.float32)
    a = filter_arrays(e, depth, 400.0, 300.0, t, jitter=jitter, depth_mode=mode, frame=3, seed=9)
    b = filter_arrays(e, depth, 400.0, 300.0, t, jitter=jitter, depth_mode=mode, frame=3, seed=9, backend="numpy")
    np.testing.assert_allclose(a, b, atol=PARITY_ATOL[np.float32])


def test_jitter_seeded_and_thread_count_independent(taps7, rng):
    import numba

    e = rng.random((64, 64, 3)).astype(np.float32)
    depth = np.full((64, 64), 300.0, np.float32)
    run = lambda **kw: filter_arrays(e, depth, 400.0, 400.0, taps7, jitter=0.3, **kw).copy()  # noqa: E731
    a = run(frame=1, seed=2)
    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        b = run(frame=1, seed=2)
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, run(frame=2, seed=2))


def test_bad_pass_settings(taps7):
    e = np.zeros((4, 4, 3), np.float32)
    d = np.full((4, 4), 1.0, np.float32)
    with pytest.raises(SettingsError, match="jitter"):
        filter_arrays(e, d, 1.0, 1.0, taps7, jitter=2.0)
    with pytest.raises(SettingsError, match="jitter"):
        filter_arrays(e, d, 1.0, 1.0, taps7, jitter=float("nan"))
    with pytest.raises(SettingsError, match="depth_mode"):
        filter_arrays(e, d, 1.0, 1.0, taps7, depth_mode="nope")
    with pytest.raises(SettingsError, match="backend"):
        filter_arrays(e, d, 1.0, 1.0, taps7, backend="cuda")
    with pytest.raises(PassError, match="SeparableTaps"):
        filter_arrays(e, d, 1.0, 1.0, "taps")
    with pytest.raises(PassError, match="same size"):
        filter_arrays(e[..., :1], d, 1.0, 1.0, taps7)


@pytest.mark.parametrize("backend", BACKENDS)
def test_footprint_larger_than_the_image(taps7, backend, rng):
    """An extreme close-up: every tap but the centre lands off the image, so each pixel keeps its value."""
    e = rng.random((8, 10, 3)).astype(np.float32)
    out = filter_arrays(e, np.full((8, 10), 1.0, np.float32), 1e5, 1e5, taps7, jitter=0.0, backend=backend)
    np.testing.assert_allclose(out, e, rtol=1e-6)


@pytest.mark.parametrize("jitter", [0.0, 0.5])
def test_unpaired_taps_match_numpy(jitter, rng):
    """Asymmetric taps (a user's tap file) take the scalar kernel's single-tap branch."""
    from ssskit.sampling.taps import SeparableTaps

    taps = SeparableTaps([[0.0, 0.7, -1.3, 2.2]], [[[0.4] * 3, [0.3, 0.2, 0.1], [0.2] * 3, [0.1, 0.3, 0.2]]],
                         [[1.0, 1.0, 1.0]], "custom", 2.2).normalised()
    e = rng.random((30, 40, 3)).astype(np.float32)
    depth = (300 + 3 * np.arange(40)[None, :] + 0 * np.arange(30)[:, None]).astype(np.float32)
    depth[5:9, 5:15] = np.inf
    a = filter_arrays(e, depth, 350.0, 420.0, taps, jitter=jitter, frame=1)
    b = filter_arrays(e, depth, 350.0, 420.0, taps, jitter=jitter, frame=1, backend="numpy")
    np.testing.assert_allclose(a, b, atol=PARITY_ATOL[np.float32])
