"""The adaptive sampler's guiding phase (:mod:`ssskit.backends.adaptive_plan`) on every backend that has it
(the ``backend`` fixture; skipped where "adaptive" is not in ``backend.passes``): agreement with the numpy
oracle (history within float32 rounding, counts equal but for a tiny fraction of +-1 flips where an
estimate lies within float32 rounding of an integer), the device-resident frame loop against the host
entry points, same-seed determinism, and the equations' fixed points."""

import numpy as np
import pytest

from tests.conftest import assert_history_ulps
from ssskit.backends import Backend, get_backend
from ssskit.backends.adaptive_plan import as_plan
from ssskit.backends.base import PHASES
from ssskit.errors import BackendError, PassError
from ssskit.screenspace import BurleyParams, BurleySettings, Camera, GBuffer
from ssskit.screenspace.adaptive import AdaptiveSettings, new_history
from ssskit.screenspace.frames import adaptive_frames

#: the largest fraction of counts a float32 backend may have one off the oracle's (rounding boundaries)
COUNT_FLIPS = 2e-3


@pytest.fixture
def guide_backend(backend):
    if "adaptive" not in get_backend(backend).passes:
        pytest.skip(f"backend {backend} has no adaptive guiding pass")
    return backend


def _frame(h=41, w=57, seed=5):
    """A history with and without history, inside and outside the mask, motion vectors that leave the image."""
    rng = np.random.default_rng(seed)
    hist = np.zeros((h, w, 4), np.float32)
    hist[..., 0] = rng.uniform(8, 64, (h, w))
    hist[..., 1] = rng.random((h, w))
    hist[..., 2] = rng.uniform(0, 3e-3, (h, w))
    hist[..., 3] = rng.random((h, w)) > 0.2
    hist[hist[..., 3] == 0] = 0.0
    mask = rng.random((h, w)) > 0.1
    motion = rng.normal(0, 4, (h, w, 2))
    valid = rng.random((h, w)) > 0.1
    rgb = (rng.random((h, w, 3)) * 1.2 - 0.05).astype(np.float32)  # a few negative values (clamped to 0)
    counts = np.where(mask, rng.integers(8, 65, (h, w)), 0)
    return hist, mask, motion, valid, rgb, counts


def _assert_counts_close(ref, got):
    diff = np.abs(np.asarray(ref, np.int64) - np.asarray(got, np.int64))
    assert diff.max(initial=0) <= 1
    assert (diff > 0).mean() <= COUNT_FLIPS


def _assert_history_close(ref, got):
    np.testing.assert_allclose(got, ref, rtol=2e-6, atol=1e-7)


@pytest.mark.parametrize("gamma", [2.2, 1.0])
@pytest.mark.parametrize("correction", ["variance", "sigma"])
@pytest.mark.parametrize("moving", [False, True])
def test_guiding_phase_matches_the_oracle(guide_backend, moving, correction, gamma):
    hist, mask, motion, valid, rgb, counts = _frame()
    plan = as_plan(AdaptiveSettings(sigma0_sq=1e-3, kappa=0.6, correction=correction, gamma=gamma))
    mv, ok = (motion, valid) if moving else (None, None)
    oracle, b = get_backend("numpy"), get_backend(guide_backend)
    _assert_counts_close(oracle.adaptive_counts(plan, hist, mask, mv, ok), b.adaptive_counts(plan, hist, mask, mv, ok))
    h0, n0 = oracle.adaptive_update(plan, hist, rgb, counts, mask, mv, ok)
    h1, n1 = b.adaptive_update(plan, hist, rgb, counts, mask, mv, ok)
    assert h1.dtype == np.float32 and h1.shape == hist.shape
    _assert_history_close(h0, h1)
    _assert_counts_close(n0, n1)


@pytest.mark.parametrize("sigma0_sq", [1e-4, 1e-3])  # float32(sigma0^2) rounds down / up
def test_disocclusion_counts_agree_exactly(guide_backend, sigma0_sq):
    """After a disocclusion n_bar = n is an integer and sigma^2 = sigma0^2 (Eqs. 16-17): n_hat lies exactly
    on an integer; every backend takes the oracle's side of it."""
    h, w = 16, 24
    plan = as_plan(AdaptiveSettings(sigma0_sq=sigma0_sq, kappa=0.2))
    rgb = np.random.default_rng(1).random((h, w, 3)).astype(np.float32)
    counts = np.random.default_rng(2).integers(8, 65, (h, w))
    mask = np.ones((h, w), bool)
    h0, n0 = get_backend("numpy").adaptive_update(plan, new_history(h, w), rgb, counts, mask)
    h1, n1 = get_backend(guide_backend).adaptive_update(plan, new_history(h, w), rgb, counts, mask)
    np.testing.assert_array_equal(h1[..., 2], np.float32(sigma0_sq))
    np.testing.assert_array_equal(n1, n0)


def test_fixed_points_of_the_equations(guide_backend):
    """No history: the count is b_min inside the mask and 0 outside; the update takes the value itself, the
    frame's count and sigma0^2 (Eqs. 16-17); a history at (n_bar, mu = S, sigma^2 = sigma0^2) keeps mu and
    gives E(n_bar) = n_bar (Eq. 13) at kappa = 0."""
    b = get_backend(guide_backend)
    plan = as_plan(AdaptiveSettings(sigma0_sq=1e-4, kappa=0.0, b_min=4, b_max=40))
    h, w = 8, 12
    mask = np.zeros((h, w), bool)
    mask[2:6, 3:9] = True
    counts = b.adaptive_counts(plan, new_history(h, w), mask)
    np.testing.assert_array_equal(counts, np.where(mask, 4, 0))
    rgb = np.full((h, w, 3), 0.25, np.float32)
    hist, nxt = b.adaptive_update(plan, new_history(h, w), rgb, np.where(mask, 17, 0), mask)
    s = np.float32(0.25) ** np.float32(1 / 2.2)
    np.testing.assert_allclose(hist[mask], np.tile([17.0, s, 1e-4, 1.0], (mask.sum(), 1)), rtol=1e-6)
    np.testing.assert_array_equal(hist[~mask], 0.0)
    np.testing.assert_array_equal(nxt, np.where(mask, 17, 0))
    hist2, nxt2 = b.adaptive_update(plan, hist, rgb, np.where(mask, 17, 0), mask)
    np.testing.assert_allclose(hist2[mask][:, 1], s, rtol=1e-6)  # mu stays
    np.testing.assert_allclose(hist2[mask][:, 2], 0.8e-4, rtol=1e-5)  # (1 - a) sigma^2 (Eq. 9, S = C)
    assert np.all(nxt2[mask] == 14)  # ceil(0.8 * 17)


def test_a_backend_without_the_pass_says_so():
    class Plain(Backend):
        name = "plain"

        def _separable(self, plan, diffuse, depth_mm, slots):
            return diffuse

    plan = as_plan(AdaptiveSettings())
    with pytest.raises(BackendError, match="no adaptive guiding pass"):
        Plain().adaptive_counts(plan, new_history(2, 2), np.ones((2, 2), bool))
    with pytest.raises(BackendError, match="no adaptive guiding pass"):
        Plain().adaptive_runner(plan, new_history(2, 2))


def test_bad_inputs_raise(guide_backend):
    b = get_backend(guide_backend)
    plan = as_plan(AdaptiveSettings())
    hist = new_history(4, 5)
    with pytest.raises(PassError, match="mask"):
        b.adaptive_counts(plan, hist, np.ones((5, 4), bool))
    with pytest.raises(PassError, match="motion vectors"):
        b.adaptive_counts(plan, hist, np.ones((4, 5), bool), np.full((4, 5, 2), np.nan))
    with pytest.raises(PassError, match="sample counts"):
        b.adaptive_update(plan, hist, np.zeros((4, 5, 3)), np.zeros((4, 5)), np.ones((4, 5), bool))
    # a required input not given is named as such (numpy would call None "shape () object")
    with pytest.raises(PassError, match=r"the pass's result must be an array \(it is required\), got None"):
        b.adaptive_update(plan, hist, None, np.zeros((4, 5), np.int64), np.ones((4, 5), bool))


# ---- the frame loop (history and counts kept with the backend; on gl on the device) ------------------

def _gbuffer(h=36, w=48):
    yy, xx = np.mgrid[0:h, 0:w]
    diffuse = np.full((h, w, 3), 0.05, np.float32)
    diffuse[xx >= w // 2] = 0.8
    pid = np.ones((h, w), np.uint32)
    pid[:4] = 0
    depth = np.where(pid > 0, 400.0, np.inf).astype(np.float32)
    return GBuffer(diffuse=diffuse, albedo=np.ones_like(diffuse), depth=depth, profile_id=pid,
                   camera=Camera(w, h, 25.0 * w, 25.0 * w, w / 2, h / 2))


PARAMS = BurleyParams.from_dmfp((0.8, 0.5, 0.3), (2.0, 1.0, 0.5))


def _host_loop(gb, settings, bs, frames, motions):
    """The oracle's loop: numpy estimate, the Burley pass on bs.backend, numpy update."""
    from ssskit.screenspace.burley import burley_plan_for, burley_sss

    plan = as_plan(settings)
    oracle = get_backend("numpy")
    mask = gb.profile_id > 0
    hist = new_history(*gb.shape)
    outs, counts_all = [], []
    slots_plan = burley_plan_for(PARAMS, [1], gb.camera.fx, gb.camera.fy, bs)
    assert slots_plan.slots == 2
    for f in range(frames):
        counts = oracle.adaptive_counts(plan, hist, mask, motions[f])
        out = burley_sss(gb, PARAMS, bs.replace(frame=f), counts=counts)
        hist, _ = oracle.adaptive_update(plan, hist, out, counts, mask, motions[f])
        outs.append(out)
        counts_all.append(counts)
    return outs, counts_all, hist


@pytest.mark.parametrize("mips", [False, True])
def test_runner_with_motion_matches_the_host_loop(guide_backend, mips):
    from ssskit.screenspace.burley import burley_plan_for

    gb = _gbuffer()
    settings = AdaptiveSettings(sigma0_sq=1e-4, kappa=0.6)
    bs = BurleySettings(sequence="random", mips=mips, backend=guide_backend if guide_backend != "numpy" else "numba")
    frames = 5
    motions = [None] + [np.full(gb.shape + (2,), (-1.0 + 0.5 * f, 0.7), np.float64) for f in range(1, frames)]
    outs, counts_ref, hist_ref = _host_loop(gb, settings, bs, frames, motions)
    runner, sampler = _runner(guide_backend, gb, settings)  # (its Burley pass on bs.backend)
    base = burley_plan_for(PARAMS, [1], gb.camera.fx, gb.camera.fy, bs)
    slots = base.slot_map(gb.profile_id)
    import dataclasses

    try:
        for f in range(frames):
            runner.load(gb.diffuse, gb.depth_mm, slots, motions[f])
            counts = runner.counts()
            runner.sample(dataclasses.replace(base, frame=f))
            runner.update()
            _assert_counts_close(counts_ref[f], counts)
            if np.array_equal(counts_ref[f], counts):
                np.testing.assert_allclose(runner.result(), outs[f], atol=1e-5)
        if sampler.name == "numba":  # the same Burley results: the same history
            _assert_history_close(hist_ref, runner.history())
        assert all(len(runner.times[p]) == frames for p in PHASES if p != "prefilter" or mips)
    finally:
        runner.release()


def test_adaptive_frames_route_the_guiding_phase(guide_backend):
    """adaptive_frames(backend=...) runs the guiding phase there. The CPU backends run the oracle's float32
    operations in the same order: their history lies within conftest.ULPS float32 ulps of the oracle's (conftest.py: FMA contraction and the vector pow differ by CPU), their counts agree but for
    rare +-1 flips where an estimate lies within that rounding of an integer, and wherever a pixel's counts
    agree in every frame its frames are the same Burley results (the same numba sampler on both sides);
    gl: the same counts but for rare rounding flips."""
    gb = _gbuffer()
    settings = AdaptiveSettings(sigma0_sq=1e-4, kappa=0.6)
    bs = BurleySettings(sequence="random", backend="numba")
    ref = adaptive_frames(gb, PARAMS, settings, 6, burley=bs, backend="numpy")
    run = adaptive_frames(gb, PARAMS, settings, 6, burley=bs.replace(backend=guide_backend)
                          if guide_backend == "gl" else bs, backend=guide_backend)
    assert run.backend == guide_backend
    assert set(run.phases) == set(PHASES) and len(run.ms_pass) == len(run.ms_update) == 6
    if guide_backend == "gl":
        diff = run.counts != ref.counts
        assert diff.mean() < 0.01
        np.testing.assert_allclose(run.mean_spp, ref.mean_spp, atol=0.2)
    else:
        for f in range(len(ref.counts)):
            _assert_counts_close(ref.counts[f], run.counts[f])
        same = np.all(run.counts == ref.counts, axis=0)  # (H, W): the pixel took the oracle's counts throughout
        assert same.mean() > 0.99
        assert_history_ulps(run.history, ref.history, guide_backend, where=same)
        np.testing.assert_array_equal(run.mean[same], ref.mean[same])


def test_same_seed_same_frames_and_thread_count_free(guide_backend):
    gb = _gbuffer()
    settings = AdaptiveSettings(sigma0_sq=1e-4, kappa=1.0)
    bs = BurleySettings(sequence="random", backend=guide_backend if guide_backend != "numpy" else "numba", seed=7)
    a = adaptive_frames(gb, PARAMS, settings, 4, burley=bs, backend=guide_backend)
    if guide_backend == "numba":
        import numba

        n = numba.get_num_threads()
        numba.set_num_threads(1)
        try:
            b = adaptive_frames(gb, PARAMS, settings, 4, burley=bs, backend=guide_backend)
        finally:
            numba.set_num_threads(n)
    else:
        b = adaptive_frames(gb, PARAMS, settings, 4, burley=bs, backend=guide_backend)
    np.testing.assert_array_equal(a.counts, b.counts)
    np.testing.assert_array_equal(a.history, b.history)
    np.testing.assert_array_equal(a.last, b.last)
    c = adaptive_frames(gb, PARAMS, settings, 4, burley=bs.replace(seed=8), backend=guide_backend)
    assert not np.array_equal(a.last, c.last)


def _runner(guide_backend, gb, settings):
    """(a runner of ``guide_backend`` for ``gb``'s frames, the backend of its Burley pass: numba for numpy's guiding
    phase, else the same)."""
    from ssskit.backends.base import AdaptiveRunner

    b = get_backend(guide_backend)
    sampler = b if guide_backend != "numpy" else get_backend("numba")
    plan = as_plan(settings)
    runner = (b.adaptive_runner(plan, new_history(*gb.shape)) if sampler is b
              else AdaptiveRunner(b, plan, new_history(*gb.shape), sampler=sampler))
    return runner, sampler


def test_runner_follows_a_change_of_sampler(guide_backend):
    """A loaded frame sampled with another sampler (another shader on gl) gives that sampler's pass."""
    from ssskit.screenspace.burley import burley_plan_for

    gb = _gbuffer(24, 32)
    runner, sampler = _runner(guide_backend, gb, AdaptiveSettings(sigma0_sq=1e-4))
    exact = burley_plan_for(PARAMS, [1], gb.camera.fx, gb.camera.fy, BurleySettings(mips=False))
    xie = burley_plan_for(PARAMS, [1], gb.camera.fx, gb.camera.fy, BurleySettings(sampler="xie", mips=True))
    slots = exact.slot_map(gb.profile_id)
    try:
        runner.load(gb.diffuse, gb.depth_mm, slots)
        counts = runner.counts()
        runner.sample(exact)
        first = runner.result()
        runner.sample(xie)
        second = runner.result()
    finally:
        runner.release()
    np.testing.assert_allclose(first, sampler.burley(exact, gb.diffuse, gb.depth_mm, slots, counts), atol=1e-6)
    np.testing.assert_allclose(second, sampler.burley(xie, gb.diffuse, gb.depth_mm, slots, counts), atol=1e-6)
    assert not np.allclose(first, second)


def test_runner_takes_counts_from_the_caller(guide_backend):
    """load(estimate=False) + set_counts: the pass runs with the caller's counts (a fixed count, or the
    estimate changed), the update records them (Eq. 8); sampling without counts, or bad counts, raise."""
    from ssskit.screenspace.burley import burley_plan_for

    gb = _gbuffer(24, 32)
    runner, sampler = _runner(guide_backend, gb, AdaptiveSettings(sigma0_sq=1e-4, b_min=4, b_max=40))
    burley = burley_plan_for(PARAMS, [1], gb.camera.fx, gb.camera.fy, BurleySettings(mips=False))
    slots = burley.slot_map(gb.profile_id)
    mask = slots > 0
    fixed = np.where(mask, 17, 0)
    try:
        runner.load(gb.diffuse, gb.depth_mm, slots, estimate=False)
        assert not runner.times["estimate"]
        with pytest.raises(PassError, match="set its counts"):
            runner.sample(burley)
        with pytest.raises(PassError):
            runner.set_counts(np.zeros((3, 3), np.int64))
        with pytest.raises(PassError):
            runner.set_counts(np.full(gb.shape, 1.5))
        mine = fixed.copy()
        runner.set_counts(mine)
        mine[...] = 3  # the caller's array changed afterwards: the runner keeps what it was given
        np.testing.assert_array_equal(runner.counts(), fixed)
        runner.sample(burley)
        out = runner.result()
        runner.update()
        hist = runner.history()
    finally:
        runner.release()
    np.testing.assert_allclose(out, sampler.burley(burley, gb.diffuse, gb.depth_mm, slots, fixed), atol=1e-6)
    np.testing.assert_array_equal(hist[..., 0], np.where(mask, 17.0, 0.0))  # Eq. 16: M' = 1, n_bar = n


def test_every_runner_keeps_the_order_of_the_phases(guide_backend):
    """One order for every runner (stated once in AdaptiveRunner): result needs a sample since the last load,
    update one sample since the last load or update. The numpy runner returned NaN for a result before any
    sample, and updated the history again with a stale result (twice, or after a new frame was loaded)."""
    from ssskit.screenspace.burley import burley_plan_for

    gb = _gbuffer(24, 32)
    runner, _ = _runner(guide_backend, gb, AdaptiveSettings(sigma0_sq=1e-4))
    burley = burley_plan_for(PARAMS, [1], gb.camera.fx, gb.camera.fy, BurleySettings(mips=False))
    slots = burley.slot_map(gb.profile_id)
    try:
        with pytest.raises(PassError, match="no frame sampled yet"):
            runner.result()
        runner.load(gb.diffuse, gb.depth_mm, slots)
        with pytest.raises(PassError, match="sample a frame before updating the history"):
            runner.update()
        runner.sample(burley)
        runner.update()
        runner.result()  # (the frame's result stays readable after its update)
        with pytest.raises(PassError, match="sample a frame before updating the history"):
            runner.update()
        runner.sample(burley)  # the same frame again, with the counts the update produced
        runner.load(gb.diffuse, gb.depth_mm, slots)
        with pytest.raises(PassError, match="sample a frame before updating the history"):
            runner.update()
        with pytest.raises(PassError, match="no frame sampled yet"):
            runner.result()
    finally:
        runner.release()


def test_every_runner_refuses_a_bad_frame_before_its_pass(guide_backend):
    """The Burley pass's frame rule (a finite positive depth on every pixel with SSS, slots within the plan) holds
    for every runner: the gl runner's device pass, which does not go through Backend.burley, took a NaN depth and
    slots beyond the plan's tables without a word."""
    from ssskit.screenspace.burley import burley_plan_for

    gb = _gbuffer(24, 32)
    runner, _ = _runner(guide_backend, gb, AdaptiveSettings(sigma0_sq=1e-4))
    burley = burley_plan_for(PARAMS, [1], gb.camera.fx, gb.camera.fy, BurleySettings(mips=False))
    slots = burley.slot_map(gb.profile_id)
    depth = gb.depth_mm.copy()
    depth[slots > 0] = np.where(np.arange(np.count_nonzero(slots > 0)) == 3, np.nan, depth[slots > 0])
    try:
        runner.load(gb.diffuse, depth, slots)
        with pytest.raises(PassError, match="depth must be finite"):
            runner.sample(burley)
        runner.load(gb.diffuse, gb.depth_mm, np.where(slots > 0, 2, 0))  # (the plan has one profile id)
        with pytest.raises(PassError, match=r"slots must lie in \[0, 1\]"):
            runner.sample(burley)
    finally:
        runner.release()
