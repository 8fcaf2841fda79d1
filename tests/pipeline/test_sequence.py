"""Frame sequences along a scene's camera path (:mod:`ssskit.pipeline.sequence` for the inputs,
:func:`ssskit.screenspace.frames.run_frames` for the loop): the adaptive history reprojected through the
camera motion, the fixed-count baseline through the same loop, the adaptive sampler's independence of the
TAA, cached G-buffers, the references' standard error and the display PSNR."""

import numpy as np
import pytest

from ssskit.errors import PassError, SettingsError
from ssskit.metrics import display_psnr
from ssskit.pipeline.sequence import sequence_gbuffers, sequence_references
from ssskit.screenspace.frames import run_frames
from ssskit.screenspace import BurleySettings
from ssskit.screenspace.adaptive import AdaptiveSettings
from ssskit.screenspace.burley import burley_params_for_material
from ssskit.screenspace.taa import TAASettings
from ssskit.materials import MATERIALS

FRAMES = 5


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(scope="module")
def setup(cache):
    mp = pytest.MonkeyPatch()
    mp.setenv("SSSKIT_CACHE_DIR", str(cache))
    try:
        params = burley_params_for_material(MATERIALS.get("skin1"))
        gbs = sequence_gbuffers("sphere", "skin1", FRAMES, width=40, height=30, spp=4)
        refs = sequence_references(gbs, params, spp=256)
    finally:
        mp.undo()
    return params, gbs, refs


BURLEY = BurleySettings(sampler="exact", mips=False)


def test_gbuffers_follow_the_camera_and_are_cached(setup, cache, monkeypatch):
    params, gbs, _ = setup
    assert [g.meta["frame"] for g in gbs] == list(range(FRAMES))
    assert not np.array_equal(gbs[0].camera.world_to_camera, gbs[1].camera.world_to_camera)
    assert len(list((cache / "gbuffers").glob("sphere-*.npz"))) == FRAMES
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(cache))
    again = sequence_gbuffers("sphere", "skin1", 2, first=1, width=40, height=30, spp=4)
    for a, b in zip(again, gbs[1:3]):
        for layer in ("diffuse", "specular", "albedo", "depth", "profile_id", "normal"):
            assert np.array_equal(getattr(a, layer), getattr(b, layer))
        assert a.camera.to_dict() == b.camera.to_dict() and a.meta == b.meta
    static = sequence_gbuffers("sphere", "skin1", 3, first=2, width=40, height=30, spp=4, static=True)
    assert static[0] is static[1] is static[2] and static[0].meta["frame"] == 2


def test_reference_standard_error_matches_its_distance_to_a_finer_reference(setup, cache, monkeypatch):
    params, gbs, refs = setup
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(cache))
    fine = sequence_references(gbs[:1], params, spp=4096, seed=77)[0]
    m = gbs[0].mask
    dist = np.sqrt(np.mean((refs[0].sss - fine.sss)[m] ** 2))
    se = np.sqrt(np.mean(refs[0].stderr[m] ** 2 + fine.stderr[m] ** 2))
    assert 0.5 < dist / se < 2.0, (dist, se)  # the two-halves estimate is the right size


def test_fixed_baseline_takes_its_count_everywhere(setup):
    params, gbs, refs = setup
    run = run_frames(gbs, params, BURLEY, spp=16, taa=TAASettings(), references=[r.sss for r in refs], keep_counts=True)
    masks = np.stack([g.mask for g in gbs])
    assert run.mean_spp == [16.0] * FRAMES and run.samples == 16 * int(masks.sum())
    assert np.array_equal(run.counts > 0, masks)
    assert all(np.isfinite(run.psnr)) and all(np.isfinite(run.psnr_taa))


def test_adaptive_sequence_is_the_same_with_taa_on_and_off(setup):
    params, gbs, refs = setup
    a = AdaptiveSettings(sigma0_sq=1e-4, kappa=0.6, b_min=4, b_max=32)
    on = run_frames(gbs, params, BURLEY, adaptive=a, taa=TAASettings(), references=[r.sss for r in refs], keep_counts=True)
    off = run_frames(gbs, params, BURLEY, adaptive=a, taa=None, references=[r.sss for r in refs], keep_counts=True)
    assert np.array_equal(on.counts, off.counts)
    assert np.array_equal(on.last, off.last) and on.psnr == off.psnr
    assert off.psnr_taa == [None] * FRAMES and on.last_taa is not None and off.last_taa is None
    # no history on the first frame (Eqs. 16-17): b_min; afterwards the counts adapt inside the budget
    assert on.mean_spp[0] == 4 and max(on.mean_spp[1:]) > 4
    assert on.counts.max() <= 32 and on.counts[masks_of(gbs)].min() >= 4


def test_disocclusion_spp_takes_its_count_where_the_history_is_missing(setup):
    from ssskit.screenspace import motion_vectors
    from ssskit.screenspace.adaptive import AVAILABLE, new_history, reproject_history

    import dataclasses

    params, gbs, refs = setup
    # frame 0 without part of its SSS: those pixels become SSS in frame 1 (a disocclusion)
    pid = gbs[0].profile_id.copy()
    pid[:, : pid.shape[1] // 2] = 0
    gbs = [dataclasses.replace(gbs[0], profile_id=pid), *gbs[1:]]
    a = AdaptiveSettings(sigma0_sq=1e-3, kappa=0.2, b_min=4, b_max=32)
    paper = run_frames(gbs, params, BURLEY, adaptive=a, keep_counts=True)
    variant = run_frames(gbs, params, BURLEY, adaptive=a, disocclusion_spp=32, keep_counts=True)
    assert paper.mean_spp[0] == 4 and variant.mean_spp[0] == 32  # frame 0 has no history anywhere
    # later frames: the pixels whose previous position was not SSS (or off-screen) take 32
    seen = 0
    for f in range(1, FRAMES):
        prev, gb = gbs[f - 1], gbs[f]
        h = new_history(*gb.shape)
        h[..., AVAILABLE] = prev.mask
        moved = reproject_history(h, motion_vectors(gb.depth, gb.camera, prev.camera))
        missing = gb.mask & (moved[..., AVAILABLE] == 0)
        assert np.all(variant.counts[f][missing] == 32)
        assert np.all(paper.counts[f][missing] == 4)
        seen += int(missing.sum())
    assert seen > 0  # the orbit uncovers pixels
    with pytest.raises(SettingsError):
        run_frames(gbs, params, BURLEY, adaptive=a, disocclusion_spp=64)  # outside [b_min, b_max]
    with pytest.raises(SettingsError):
        run_frames(gbs, params, BURLEY, spp=8, disocclusion_spp=8)


def masks_of(gbs):
    return np.stack([g.mask for g in gbs])


def test_history_follows_the_camera():
    """The history reprojected through the camera's motion vectors lands on the same surface point: on
    the bumpy tile (static light, orbiting camera) the Lambertian diffuse layer is view-independent, so
    last frame's value fetched through the motion matches this frame's far better than an unmoved fetch."""
    from ssskit.scenes import render_gbuffer
    from ssskit.screenspace import motion_vectors
    from ssskit.screenspace.adaptive import MU, new_history, reproject_history, update_history

    prev, gb = (render_gbuffer("bumpy", 0.5, width=64, height=48, spp=16, frame=f) for f in (0, 3))
    s = AdaptiveSettings(alpha=1.0)  # the history's mu is exactly the previous frame's value
    value = lambda g: g.diffuse.mean(axis=2)  # noqa: E731
    hit = np.isfinite(prev.depth)
    h = update_history(new_history(48, 64), value(prev), np.full((48, 64), 8), s, hit)
    mv = motion_vectors(gb.depth, gb.camera, prev.camera)
    assert np.abs(mv[np.isfinite(gb.depth)]).max() > 2.0  # the camera moved by pixels
    moved = reproject_history(h, mv)
    still = reproject_history(h)
    ok = np.isfinite(gb.depth) & (moved[..., 3] > 0) & (still[..., 3] > 0)
    err_moved = np.abs(moved[..., MU] - value(gb))[ok].mean()
    err_still = np.abs(still[..., MU] - value(gb))[ok].mean()
    assert err_moved < 0.5 * err_still, (err_moved, err_still)


def test_display_psnr_properties(rng):
    ref = rng.random((8, 9, 3))
    img = ref + 0.01 * rng.standard_normal(ref.shape)
    mask = np.ones((8, 9), bool)
    assert display_psnr(ref, ref, mask) == np.inf
    p = display_psnr(ref, img, mask)
    assert np.isfinite(p) and display_psnr(7.0 * ref, 7.0 * img, mask) == pytest.approx(p)  # exposure-free
    assert display_psnr(ref, ref + 0.02 * rng.standard_normal(ref.shape), mask) < p
    assert display_psnr(ref, img, np.zeros((8, 9), bool)) is None


def test_bad_sequence_arguments(setup):
    params, gbs, refs = setup
    with pytest.raises(SettingsError):
        run_frames(gbs, params, BURLEY)  # neither adaptive nor spp
    with pytest.raises(SettingsError):
        run_frames(gbs, params, BURLEY, adaptive=AdaptiveSettings(), spp=8)
    with pytest.raises(PassError):
        run_frames(gbs, params, BURLEY, spp=8, references=[r.sss for r in refs[:2]])
    with pytest.raises(PassError):
        run_frames([], params, BURLEY, spp=8)


def _host_loop(gbs, params, b, a, disocclusion_spp=None):
    """The sequence loop as it ran before the backend's runner: the guiding phase through the numpy public
    functions of ssskit.screenspace.adaptive (the oracle), the Burley pass on ``b.backend``; (counts, last)."""
    from ssskit.screenspace import burley_sss, motion_vectors
    from ssskit.screenspace.adaptive import (AVAILABLE, new_history, reproject_history, sample_counts,
                                             shading_value, update_history)

    history = new_history(*gbs[0].shape)
    counts_all, prev, sss = [], None, None
    for f, gb in enumerate(gbs):
        motion = None if prev is None else motion_vectors(gb.depth, gb.camera, prev.camera)
        h = reproject_history(history, motion)
        counts, _ = sample_counts(h, a, gb.mask)
        if disocclusion_spp is not None:
            counts[gb.mask & (h[..., AVAILABLE] <= 0)] = disocclusion_spp
        sss = burley_sss(gb, params, b.replace(frame=b.frame + f), counts=counts)
        history = update_history(h, shading_value(sss, a.gamma), counts, a, gb.mask)
        counts_all.append(counts)
        prev = gb
    return np.stack(counts_all), sss


@pytest.mark.parametrize("disocclusion_spp", [None, 24])
def test_sequence_runs_the_guiding_phase_on_the_backend(setup, backend, disocclusion_spp):
    """run_frames runs the guiding phase through the Burley backend's runner: on numpy the counts and
    frames equal the host loop on the numpy oracle bit for bit (the same code); on numba (the oracle's
    float32 operations, but FMA contraction and vector maths that differ by CPU: conftest.ULPS) the counts
    agree but for rare +-1 flips, and wherever a pixel's counts agree in every frame so does its last frame
    (the same Burley sampler on both sides); on gl (float32 GLSL) the counts differ in a tiny fraction of
    pixels (rounding flips, test_adaptive.py's bound for adaptive_frames) and the PSNRs agree."""
    from ssskit.backends import get_backend

    if "burley" not in get_backend(backend).passes:
        pytest.skip(f"backend {backend} has no Burley pass")
    params, gbs, refs = setup
    b = BURLEY.replace(backend=backend)
    a = AdaptiveSettings(sigma0_sq=1e-4, kappa=0.6, b_min=4, b_max=32)
    ref_counts, ref_last = _host_loop(gbs, params, b, a, disocclusion_spp)
    run = run_frames(gbs, params, b, adaptive=a, references=[r.sss for r in refs], keep_counts=True,
                       disocclusion_spp=disocclusion_spp)
    masks = masks_of(gbs)
    ref_spp = [float(c[m].mean()) for c, m in zip(ref_counts, masks)]
    if backend == "gl":
        assert (run.counts != ref_counts).mean() < 0.01
        np.testing.assert_allclose(run.mean_spp, ref_spp, atol=0.2)
        np.testing.assert_allclose(run.last, gbs[-1].composite(ref_last), rtol=0.05, atol=0.02 * ref_last.max())
    elif backend == "numba":
        flips = run.counts != ref_counts
        assert np.abs(run.counts - ref_counts).max() <= 1 and flips.mean() <= 2e-3
        same = ~flips.any(axis=0)
        np.testing.assert_allclose(run.mean_spp, ref_spp, atol=0.05)
        np.testing.assert_array_equal(run.last[same], gbs[-1].composite(ref_last)[same])
    else:
        np.testing.assert_array_equal(run.counts, ref_counts)
        assert run.mean_spp == ref_spp
        np.testing.assert_array_equal(run.last, gbs[-1].composite(ref_last))
    # the runner's per-phase times: the guiding phase and the pass, and the whole loop's wall time
    for series in (run.ms, run.ms_update, run.ms_frame):  # one finite, non-negative time per frame (never
        assert len(series) == len(gbs) and all(np.isfinite(t) and t >= 0 for t in series)  # an order of times)
    fixed = run_frames(gbs, params, b, spp=8, references=[r.sss for r in refs])
    assert fixed.ms_update == [0.0] * FRAMES and all(w > 0 for w in fixed.ms_frame)
    assert {"ms", "ms_update", "ms_frame"} <= set(run.rows()[0])


def _run_docstring_examples(obj, globs):
    """Run ``obj``'s docstring examples with doctest, their ``+SKIP`` lifted: (failed, attempted)."""
    import doctest

    test = doctest.DocTestFinder(recurse=False).find(obj, globs=globs)[0]
    for example in test.examples:
        example.options.pop(doctest.SKIP, None)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    runner.run(test)
    return runner.summarize(verbose=False)


def test_module_example_runs(setup, cache, monkeypatch):
    """The module docstring's example (every line +SKIP under doctest: it path traces on a first run) runs as
    written and gives what it shows, with the G-buffers the fixture cached."""
    import ssskit.pipeline.sequence as module

    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(cache))
    failed, attempted = _run_docstring_examples(module, {})
    assert attempted >= 10 and failed == 0
