"""The Burley Monte Carlo pass on every backend that has it (the ``backend`` fixture; skipped where
"burley" is not in ``backend.passes``): physical properties, determinism, and agreement with the
float64 numpy oracle within the (backend, dtype) tolerance of tests/conftest.py."""

import numpy as np
import pytest

from ssskit.backends import Backend, get_backend
from ssskit.backends.burley_plan import BurleyParams, build_burley_plan
from ssskit.errors import BackendError, PassError
from ssskit.screenspace import Camera, GBuffer, burley_sss
from tests.conftest import tolerance

SAMPLERS = ["exact", "xie", "golubev"]


@pytest.fixture
def burley_backend(backend):
    if "burley" not in get_backend(backend).passes:
        pytest.skip(f"backend {backend} has no Burley pass")
    return backend


def _gbuffer(diffuse, pid, depth, fx=900.0, fy=700.0):
    h, w = pid.shape
    return GBuffer(diffuse=np.asarray(diffuse, np.float32), albedo=np.full((h, w, 3), 0.5, np.float32),
                   depth=np.asarray(depth, np.float32), profile_id=pid.astype(np.uint32),
                   camera=Camera(w, h, fx, fy, w / 2, h / 2))


def _three_ids(h=40, w=56, seed=3):
    """Two disks and a band with their own ids, background without SSS, tilted and bumpy depth."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w]
    pid = np.zeros((h, w), np.uint32)
    pid[(xx - 16) ** 2 + (yy - 18) ** 2 < 13**2] = 1
    pid[(xx - 40) ** 2 + (yy - 18) ** 2 < 13**2] = 2
    pid[33:, :] = 3
    depth = (300 + 2 * xx + 3 * np.sin(yy / 3)).astype(np.float32)
    depth[pid == 0] = np.inf
    params = {1: BurleyParams.from_dmfp(0.8, (3.0, 1.5, 0.8)), 2: BurleyParams.from_dmfp(0.5, (1.0, 2.0, 4.0)),
              3: BurleyParams((0.9, 0.7, 0.4), (0.6, 0.6, 0.3))}
    return _gbuffer(rng.random((h, w, 3)), pid, depth), params


# ---- the contract ------------------------------------------------------------------------------------

def test_a_backend_without_the_pass_says_so():
    class Plain(Backend):
        name = "plain"

        def _separable(self, plan, diffuse, depth_mm, slots):
            return diffuse

    b = Plain()
    assert b.passes == frozenset({"separable"})
    with pytest.raises(BackendError, match="backend 'plain' has no Burley pass"):
        b.burley(None, None, None, None, 1)


# ---- physical properties ------------------------------------------------------------------------------

@pytest.mark.parametrize("mips", [False, True])
@pytest.mark.parametrize("sampler", SAMPLERS)
def test_constant_irradiance_stays_constant(sampler, mips, burley_backend):
    gb, params = _three_ids()
    const = gb.with_layers(diffuse=np.full(gb.diffuse.shape, 0.37, np.float32))
    out = burley_sss(const, params, spp=16, sampler=sampler, bleed=0.5, mips=mips, backend=burley_backend)
    np.testing.assert_allclose(out, 0.37, rtol=1e-6)


@pytest.mark.parametrize("mips", [False, True])
@pytest.mark.parametrize("sampler", SAMPLERS)
def test_nothing_bleeds_across_the_mask_or_between_ids(sampler, mips, burley_backend):
    gb, params = _three_ids()
    pid = gb.profile_id
    for lit in (0, 1, 2, 3):  # light one region (or the background) brightly, the rest black
        e = np.repeat(np.where((pid == lit)[..., None], 100.0, 0.0), 3, axis=2).astype(np.float32)
        out = burley_sss(gb.with_layers(diffuse=e), params, spp=32, sampler=sampler, mips=mips, backend=burley_backend)
        np.testing.assert_array_equal(out[pid != lit], 0.0)
        np.testing.assert_allclose(out[pid == lit], 100.0, rtol=1e-6)


def test_bleed_option_mixes_ids(burley_backend):
    """Unreal's BoundaryColorBleed: with bleed > 0 samples of another id count, with bleed 0 none do."""
    gb, params = _three_ids()
    pid = gb.profile_id
    e = np.repeat(np.where((pid == 3)[..., None], 1.0, 0.0), 3, axis=2).astype(np.float32)
    off = burley_sss(gb.with_layers(diffuse=e), params, spp=64, bleed=0.0, backend=burley_backend)
    on = burley_sss(gb.with_layers(diffuse=e), params, spp=64, bleed=1.0, backend=burley_backend)
    assert np.all(off[pid == 1] == 0.0)
    assert on[pid == 1].max() > 0.01 and np.all(on[pid == 0] == 0.0)


def test_energy_spreads_like_the_profile(burley_backend):
    """A lit half-plane: the blurred edge's mean over the dark half equals the lit profile mass there."""
    h, w = 24, 96
    pid = np.ones((h, w), np.uint32)
    e = np.zeros((h, w, 3), np.float32)
    e[:, : w // 2] = 1.0
    gb = _gbuffer(e, pid, np.full((h, w), 500.0), fx=1000.0, fy=1000.0)  # 2 px per mm
    p = BurleyParams((0.8, 0.8, 0.8), (2.0, 1.0, 0.5))
    out = burley_sss(gb, p, spp=256, sequence="random", mips=False, backend=burley_backend)
    # in the middle rows, the blurred edge is symmetric: out(x) + out(w - 1 - x) = 1 (statistically)
    mid = out[8:16]
    sym = mid[:, : w // 2] + mid[:, ::-1][:, : w // 2]
    assert abs(float(sym.mean()) - 1.0) < 0.02
    # wider d spreads further: red reaches farther into the dark half than blue
    dark = mid[:, w // 2 + 4: w // 2 + 12].mean(axis=(0, 1))
    assert dark[0] > dark[1] > dark[2] > 0


# ---- determinism ------------------------------------------------------------------------------------

def assert_matches_oracle(got, want, backend, spp):
    """Within the backend's tolerance everywhere; for ``gl`` (float32 sample positions, plan step 4's note)
    a sample may land on the neighbouring texel when its float64 position lies within float32 rounding
    of a texel edge: at most 0.5% of the values may then differ, each by at most one sample's share."""
    tol = tolerance(backend)
    diff = np.abs(np.asarray(got, np.float64) - np.asarray(want, np.float64))
    if backend != "gl":
        np.testing.assert_allclose(got, want, atol=tol)
        return
    off = diff > tol
    assert off.mean() <= 0.005, f"{off.sum()} of {off.size} values differ by more than {tol}"
    assert diff.max() <= 2.0 / float(np.min(spp)), diff.max()


@pytest.mark.parametrize("mips", [False, True])
@pytest.mark.parametrize("sampler", SAMPLERS)
@pytest.mark.parametrize("sequence", ["r2", "random"])
def test_matches_the_numpy_oracle(sampler, sequence, mips, burley_backend):
    gb, params = _three_ids()
    kw = dict(spp=24, sampler=sampler, sequence=sequence, frame=2, seed=7, c=2.6, bleed=0.3, mips=mips)
    a = burley_sss(gb, params, backend=burley_backend, **kw)
    b = burley_sss(gb, params, backend="numpy", **kw)
    assert_matches_oracle(a, b, burley_backend, 24)


@pytest.mark.parametrize("mip_scale", [1e-6, 1.0 / 16.0, 1e4])
def test_mips_at_every_level_match_the_oracle(mip_scale, burley_backend):
    """Eq. 22's a moves the samples between level 0 (numba: the float32 lanes' bilinear fetch) and the levels
    above (numba: the float64 fallback with the float32 pyramid): a = 1e-6 (the smallest allowed) puts every
    sample of this frame at level 4 or above, 1e4 almost every one on level 0, Xie's 1/16 mixes them; each within the
    tolerance."""
    gb, params = _three_ids()
    counts = np.random.default_rng(5).integers(0, 40, gb.shape)
    kw = dict(sampler="exact", frame=1, seed=2, bleed=0.3, mips=True, mip_scale=mip_scale)
    assert_matches_oracle(burley_sss(gb, params, counts=counts, backend=burley_backend, **kw),
                          burley_sss(gb, params, counts=counts, backend="numpy", **kw), burley_backend,
                          np.maximum(counts, 1))


def test_numba_pyramid_is_the_oracles():
    """The numba backend's float32 pyramid (levels 1..MAX_MIP, slot s at plane s - 1) holds the oracle's
    mip_pyramid (float64) to float32 rounding, on a frame with odd sizes and three ids; the pass gives the
    same image with either."""
    from ssskit.backends.burley_plan import MAX_MIP, mip_pyramid
    from ssskit.backends.numba_backend import NumbaBackend, NumbaMips

    gb, params = _three_ids(h=37, w=53)
    b = NumbaBackend()
    plan = build_burley_plan(params, 900.0, 700.0, mips=True)
    slots = plan.slot_map(gb.profile_id)
    mine = b.burley_prefilter(plan, gb.diffuse, slots)
    want = NumbaMips.from_levels(mip_pyramid(gb.diffuse, slots, plan.slots))
    np.testing.assert_array_equal(mine.off, want.off)
    np.testing.assert_array_equal(mine.hh, [-(-37 // 2**k) for k in range(MAX_MIP + 1)])
    np.testing.assert_array_equal(mine.ww, want.ww)
    np.testing.assert_allclose(mine.pyr, want.pyr, rtol=1e-6, atol=1e-7)
    a = b.burley(plan, gb.diffuse, gb.depth_mm, slots, 16, pyramid=mine)
    np.testing.assert_allclose(b.burley(plan, gb.diffuse, gb.depth_mm, slots, 16,
                                        pyramid=mip_pyramid(gb.diffuse, slots, plan.slots)), a, atol=1e-6)


def test_count_image(burley_backend):
    gb, params = _three_ids()
    h, w = gb.shape
    counts = np.full((h, w), 12, np.int64)
    a = burley_sss(gb, params, spp=12, seed=3, backend=burley_backend)
    b = burley_sss(gb, params, counts=counts, seed=3, backend=burley_backend)
    np.testing.assert_array_equal(a, b)
    counts[:, : w // 2] = 0  # no samples: the diffuse value
    c = burley_sss(gb, params, counts=counts, seed=3, backend=burley_backend)
    np.testing.assert_array_equal(c[:, : w // 2], gb.diffuse[:, : w // 2])
    np.testing.assert_array_equal(c[:, w // 2:], a[:, w // 2:])
    counts = np.random.default_rng(1).integers(0, 40, (h, w))
    assert_matches_oracle(burley_sss(gb, params, counts=counts, backend=burley_backend),
                          burley_sss(gb, params, counts=counts, backend="numpy"), burley_backend, np.maximum(counts, 1))


def test_same_seed_same_image_on_one_and_two_threads(burley_backend):
    import numba

    gb, params = _three_ids(h=72, w=64)  # >= 64 rows: the numba backend splits rows over threads
    run = lambda **kw: burley_sss(gb, params, spp=16, backend=burley_backend, **kw)  # noqa: E731
    a = run(frame=1, seed=2)
    before = numba.get_num_threads()
    try:
        for t in sorted({1, min(2, numba.config.NUMBA_NUM_THREADS)}):
            numba.set_num_threads(t)
            np.testing.assert_array_equal(run(frame=1, seed=2), a)
    finally:
        numba.set_num_threads(before)
    assert not np.array_equal(a, run(frame=2, seed=2))
    assert not np.array_equal(a, run(frame=1, seed=3))


def test_stable_pattern_ignores_the_frame(burley_backend):
    gb, params = _three_ids()
    a = burley_sss(gb, params, spp=8, frame=1, stable=True, backend=burley_backend)
    np.testing.assert_array_equal(a, burley_sss(gb, params, spp=8, frame=5, stable=True, backend=burley_backend))
    moved = gb.with_layers(depth=gb.depth + np.float32(1.0))  # a new depth: a new pattern
    assert not np.array_equal(a, burley_sss(moved, params, spp=8, frame=1, stable=True, backend=burley_backend))


def test_results_are_new_arrays(burley_backend):
    gb, params = _three_ids()
    a = burley_sss(gb, params, spp=4, backend=burley_backend)
    b = burley_sss(gb, params, spp=4, backend=burley_backend)
    assert a is not b and not np.shares_memory(a, b)
    a[:] = -1
    assert np.all(b >= 0)


# ---- bad inputs ----------------------------------------------------------------------------------------

def test_bad_frames_and_counts(burley_backend):
    gb, params = _three_ids()
    h, w = gb.shape
    b = get_backend(burley_backend)
    plan = build_burley_plan(params, 900.0, 700.0)
    slots = plan.slot_map(gb.profile_id)
    with pytest.raises(PassError, match=r"the sample counts must be an integer array of shape \(40, 56\), got shape \(40, 55\)"):
        b.burley(plan, gb.diffuse, gb.depth_mm, slots, np.ones((h, w - 1), np.int64))
    with pytest.raises(PassError, match="spp must lie in"):
        b.burley(plan, gb.diffuse, gb.depth_mm, slots, 0)
    with pytest.raises(PassError, match=r"the sample counts must be an integer array of shape \(40, 56\), got shape \(40, 56\) float64"):
        b.burley(plan, gb.diffuse, gb.depth_mm, slots, np.ones((h, w)))
    with pytest.raises(PassError, match="sample counts must lie"):
        b.burley(plan, gb.diffuse, gb.depth_mm, slots, -np.ones((h, w), np.int64))
    bad = gb.depth_mm.copy()
    bad[slots > 0] = np.nan
    with pytest.raises(PassError, match=r"depth must (be finite|lie in \(0, inf\) mm), got .* pixels with SSS"):
        b.burley(plan, gb.diffuse, bad, slots, 4)
    with pytest.raises(PassError, match="slots must"):
        b.burley(plan, gb.diffuse, gb.depth_mm, slots[:, :-1], 4)
    for bad_value, pixel in ((np.nan, (20, 16)), (np.inf, (0, 0))):  # inside a disk; background, no SSS
        e = gb.diffuse.copy()
        e[pixel + (1,)] = bad_value
        with pytest.raises(PassError, match=r"diffuse must be finite, got NaN or inf in \d+ of \d+ colour values"):
            b.burley(plan, e, gb.depth_mm, slots, 4)
    with pytest.raises(PassError, match=r"slots must be an integer array of shape \(40, 56\), got shape \(40, 56\) float32"):
        b.burley(plan, gb.diffuse, gb.depth_mm, slots.astype(np.float32), 4)


def test_numba_exact_inverse_is_the_oracles_root():
    """The numba kernel's five-call inverse of Eq. 20 (plan step 4) against burley_inverse_cdf."""
    pytest.importorskip("numba")
    from numba import njit

    from ssskit.backends._numba_burley import inverse_cdf_unit
    from ssskit.profiles.burley import burley_cdf, burley_inverse_cdf

    @njit
    def many(xs):
        out = np.empty_like(xs)
        for i in range(xs.size):
            out[i] = inverse_cdf_unit(xs[i])
        return out

    xs = np.concatenate([(np.arange(4096) + 0.5) / 4096, np.logspace(-8, -2.5, 500), 1 - np.logspace(-7.5, -2, 500),
                         [2.0**-25, 1e-3, 0.5, 1 - 2.0**-25]])
    r = many(xs)
    np.testing.assert_allclose(r, burley_inverse_cdf(xs, 1.0), rtol=1e-13)
    np.testing.assert_allclose(burley_cdf(r, 1.0), xs, rtol=1e-13)
