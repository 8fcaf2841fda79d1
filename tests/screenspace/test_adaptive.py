"""The variance-guided adaptive sampler (Xie 2020 Sec. 4.1): history update, sample counts, disocclusion,
reprojection, settings, and the circle scenario's Must-show properties (Figs. 2 and 3)."""

import math

import numpy as np
import pytest

from ssskit.errors import PassError, SettingsError
from ssskit.screenspace.adaptive import (
    AVAILABLE,
    MU,
    N_BAR,
    VAR,
    AdaptiveSettings,
    CircleRun,
    circle_scenario,
    clamp_counts,
    estimate_counts,
    new_history,
    reproject_history,
    sample_counts,
    shading_value,
    update_history,
)

SIGMA0 = 0.08
#: frames after the cold start over which the steady-state properties are measured
STEADY = slice(50, 150)
PIXELS = 200


def circle(kappa, disocclusion=False, correction="variance", seed=7):
    s = AdaptiveSettings(sigma0_sq=SIGMA0**2, kappa=kappa, b_min=8, b_max=64, alpha=0.2, correction=correction)
    return circle_scenario(s, 150, disocclusion=disocclusion, pixels=PIXELS, seed=seed)


@pytest.fixture(scope="module")
def runs():
    return {(k, d): circle(k, d) for k in (0.0, 1.0) for d in (False, True)}


# ---- the circle scenario: Must-show properties -----------------------------------------------------------

@pytest.mark.parametrize("kappa", [0.0, 1.0])
def test_circle_mu_converges_to_one(runs, kappa):
    """Xie 2020 Sec. 4.1.3: after the cold start mu converges to the true value 1 (mean of 4/pi on the disk)."""
    run = runs[(kappa, False)]
    assert run.mu[0].max() < 0.5  # H_0 = 0: the first frames are far from it (the cold start)
    assert abs(run.mu[STEADY].mean() - 1.0) < 0.01
    assert np.all(np.abs(np.median(run.mu[STEADY], axis=1) - 1.0) < 0.05)


@pytest.mark.parametrize("kappa", [0.0, 1.0])
def test_circle_sigma_stays_near_sigma0(runs, kappa):
    """After the cold start sigma (Eq. 9) stays near the target sigma0 for both kappa."""
    run = runs[(kappa, False)]
    assert run.sigma[:10].max(axis=0).min() > 3 * SIGMA0  # the cold start overshoots
    ratio = float(np.median(run.sigma[STEADY])) / SIGMA0
    assert 0.9 < ratio < 1.25, ratio
    rms = math.sqrt(float((run.sigma[STEADY] ** 2).mean())) / SIGMA0
    assert 0.9 < rms < 1.35, rms


def test_circle_counts_reach_the_needed_level(runs):
    """kappa = 0 settles where the per-frame variance (4/pi - 1) / n is near sigma0^2 (about 43 spp), inside
    the budget; kappa = 1 spends more samples than kappa = 0 (Sec. 4.1.3: "kappa = 0 uses fewer samples")."""
    n0, n1 = runs[(0.0, False)].n[STEADY].mean(), runs[(1.0, False)].n[STEADY].mean()
    needed = (4 / math.pi - 1) / SIGMA0**2
    assert 0.8 * needed < n0 < 1.2 * needed
    assert n1 > n0 + 3


def test_circle_kappa1_has_taller_shorter_peaks(runs):
    """Fig. 2's shape: kappa = 1 has higher sample-count peaks lasting fewer frames; kappa = 0 smooths the
    increases over several frames (peaks: runs of frames above the budget's midpoint)."""
    h0, l0 = runs[(0.0, False)].peaks(36, STEADY.start)
    h1, l1 = runs[(1.0, False)].peaks(36, STEADY.start)
    assert h1 > h0 + 5, (h0, h1)
    assert l1 < 0.9 * l0, (l0, l1)
    # frame-to-frame: kappa = 0 changes the count smoothly, kappa = 1 jumps
    j0 = np.abs(np.diff(runs[(0.0, False)].n[STEADY], axis=0)).mean()
    j1 = np.abs(np.diff(runs[(1.0, False)].n[STEADY], axis=0)).mean()
    assert j1 > 2 * j0


@pytest.mark.parametrize("kappa", [0.0, 1.0])
def test_circle_disocclusion_removes_the_initial_burst(runs, kappa):
    """Fig. 3: with Eqs. 16-17 on frame 1 the cold start's burst of samples disappears: no excess over the
    steady-state rate in the first 20 frames, and n_hat's start-up peak drops by an order of magnitude."""
    cold, dis = runs[(kappa, False)], runs[(kappa, True)]
    rate_cold, rate_dis = cold.n[75:].mean(), dis.n[75:].mean()
    excess_cold = cold.n[:20].mean() - rate_cold
    excess_dis = dis.n[:20].mean() - rate_dis
    assert excess_cold > 8, excess_cold
    assert excess_dis < 2, excess_dis
    assert np.median(dis.n_hat[:30].max(axis=0)) < 0.1 * np.median(cold.n_hat[:30].max(axis=0))
    # the cold start pins (nearly) every pixel at b_max for frames 3..15 (Fig. 2); after a disocclusion the first
    # three frames stay below the steady-state rate (Fig. 3)
    assert (cold.n[2:15] == 64).mean() > 0.95
    assert dis.n[:3].mean() < rate_dis
    # and mu starts at the first estimate instead of climbing from 0
    assert abs(dis.mu[0].mean() - 1.0) < 0.06 and cold.mu[0].max() < 0.5


def test_circle_is_reproducible():
    a, b = circle(1.0, seed=3), circle(1.0, seed=3)
    assert np.array_equal(a.n, b.n) and np.array_equal(a.mu, b.mu)
    assert not np.array_equal(a.n, circle(1.0, seed=4).n)


def test_correction_forms_agree_at_kappa0_and_differ_otherwise():
    """kappa = 0 drops Delta (Eq. 14), so Eq. 15 as printed and its variance form give the same run;
    at kappa = 0.2 the printed form (1/(sigma + sigma0) times larger near the target) already acts like
    kappa = 1, the variance form stays between kappa = 0 and kappa = 1."""
    assert np.array_equal(circle(0.0, correction="sigma").n, circle(0.0, correction="variance").n)

    def jumps(kappa, correction):
        return np.abs(np.diff(circle(kappa, correction=correction).n[STEADY], axis=0)).mean()

    j0, j1 = jumps(0.0, "variance"), jumps(1.0, "variance")
    jv, js = jumps(0.2, "variance"), jumps(0.2, "sigma")
    assert j0 < jv < 0.85 * j1
    assert js > 0.9 * j1


def test_variance_form_is_free_of_the_values_unit():
    """The same problem in other units (irradiance and sigma0 both times c) takes the same counts with the
    variance form (Eqs. 13-15 then depend on sigma^2 / sigma0^2 only); with Eq. 15 as printed Delta scales
    with 1 / c, so a small kappa acts like a larger one as the unit shrinks (c = 0.125: sigma0 = 0.01, Fig. 4)."""
    def run(correction, c):
        s = AdaptiveSettings(sigma0_sq=(SIGMA0 * c) ** 2, kappa=0.05, correction=correction)
        return circle_scenario(s, 150, pixels=PIXELS, seed=7, scale=c).n[STEADY]

    a, b = run("variance", 1.0), run("variance", 0.125)
    assert abs(a.mean() - b.mean()) < 0.01 * a.mean() and abs((a == 64).mean() - (b == 64).mean()) < 0.02
    a, b = run("sigma", 1.0), run("sigma", 0.125)
    assert (b == 64).mean() > (a == 64).mean() + 0.1


# ---- the equations -----------------------------------------------------------------------------------------

def finch(mean, var, x, a):
    """Finch 2009, incremental exponentially weighted mean and variance (independent of the module)."""
    diff = x - mean
    incr = a * diff
    mean = mean + incr
    var = (1 - a) * (var + diff * incr)
    return mean, var


def test_update_history_follows_eqs_6_8_9():
    s = AdaptiveSettings(sigma0_sq=1e-3, alpha=0.25)
    h = new_history(2, 3, available=True)
    h[..., N_BAR], h[..., MU], h[..., VAR] = 20.0, 0.5, 0.01
    value = np.array([[0.4, 0.5, 0.9], [0.0, 1.0, 0.55]])
    counts = np.array([[8, 16, 64], [9, 30, 12]])
    out = update_history(h, value, counts, s)
    assert out.shape == (2, 3, 4) and out.dtype == np.float32
    mean, var = finch(0.5, 0.01, value, 0.25)
    np.testing.assert_allclose(out[..., MU], mean, rtol=1e-6)
    np.testing.assert_allclose(out[..., VAR], var, rtol=1e-5)
    np.testing.assert_allclose(out[..., N_BAR], 0.75 * 20 + 0.25 * counts, rtol=1e-6)
    assert np.all(out[..., AVAILABLE] == 1)


def test_disocclusion_eqs_16_17_and_mask():
    s = AdaptiveSettings(sigma0_sq=2e-3)
    h = new_history(1, 3, available=True)
    h[..., N_BAR], h[..., MU], h[..., VAR] = 30.0, 0.2, 0.05
    h[0, 1] = 0.0  # pixel 1 has no history: C_s = 0
    out = update_history(h, np.array([[0.7, 0.7, 0.7]]), np.array([[8, 8, 8]]), s, mask=np.array([[1, 1, 0]]))
    # M' = 1: mu = S, n_bar = n; sigma^2 = sigma0^2 (Eq. 17)
    np.testing.assert_allclose(out[0, 1], [8.0, 0.7, 2e-3, 1.0], rtol=1e-6)
    assert out[0, 0, MU] == pytest.approx(0.8 * 0.2 + 0.2 * 0.7)
    assert np.all(out[0, 2] == 0)  # outside the SSS mask: no history


def test_estimate_counts_eqs_13_15():
    h = new_history(1, 4, available=True)
    h[..., N_BAR] = 16.0
    h[..., VAR] = [0.04, 0.01, 0.0025, 0.01]
    h[0, 3, AVAILABLE] = 0.0
    h[0, 3] = 0.0
    k = 2 / 0.2 - 1
    var = np.array([0.04, 0.01, 0.0025])
    expected = var / 0.01 * 16  # Eq. 13's E(n_bar)
    for kappa in (0.0, 0.5, 1.0):
        s = AdaptiveSettings(sigma0_sq=0.01, kappa=kappa, alpha=0.2, correction="variance")
        got = estimate_counts(h, s)[0]
        np.testing.assert_allclose(got[:3], expected + kappa * (var - 0.01) / 0.01 * 16 * (k - 1), rtol=1e-5, atol=1e-4)
        assert got[3] == 0.0
        s = s.replace(correction="sigma")
        np.testing.assert_allclose(estimate_counts(h, s)[0, :3],
                                   expected + kappa * (np.sqrt(var) - 0.1) / 0.01 * 16 * (k - 1), rtol=1e-5, atol=1e-3)
    # at the target variance Delta vanishes in both forms: n_hat = n_bar
    for corr in ("variance", "sigma"):
        assert estimate_counts(h, AdaptiveSettings(sigma0_sq=0.01, kappa=1.0, correction=corr))[0, 1] == \
            pytest.approx(16.0, abs=1e-3)


def test_counts_are_clamped_to_the_budget():
    s = AdaptiveSettings(b_min=8, b_max=64)
    n_hat = np.array([[-50.0, 0.0, 8.2, 40.0, 63.5, 1e9, np.inf]])
    np.testing.assert_array_equal(clamp_counts(n_hat, s), [[8, 8, 9, 40, 64, 64, 64]])
    mask = np.array([[1, 1, 1, 0, 1, 1, 1]], bool)
    counts = clamp_counts(n_hat, s, mask)
    assert counts.dtype == np.int64 and counts[0, 3] == 0
    c, nh = sample_counts(new_history(2, 2), s)
    assert np.all(c == 8) and np.all(nh == 0)  # no history: the floor beta = b_min


def test_reproject_history_nearest_and_offscreen():
    h = new_history(3, 4, available=True)
    h[..., MU] = np.arange(12).reshape(3, 4)
    mv = np.zeros((3, 4, 2))
    mv[..., 0] = -1.0  # the surface was one pixel to the left
    out = reproject_history(h, mv)
    np.testing.assert_array_equal(out[:, 1:, MU], h[:, :-1, MU])
    assert np.all(out[:, 0] == 0)  # fetched from off screen: no history
    mv[..., 0] = 0.4  # nearest fetch: 0.4 px stays in the same pixel, 0.6 moves one
    np.testing.assert_array_equal(reproject_history(h, mv)[..., MU], h[..., MU])
    mv[..., 0] = 0.6
    np.testing.assert_array_equal(reproject_history(h, mv)[:, :3, MU], h[:, 1:, MU])
    valid = np.ones((3, 4), bool)
    valid[1, 2] = False
    out = reproject_history(h, None, valid)
    assert np.all(out[1, 2] == 0) and out[0, 0, AVAILABLE] == 1
    assert np.array_equal(reproject_history(h)[..., MU], h[..., MU])


def test_reproject_through_camera_motion_vectors():
    """A camera panning by a whole number of pixels: motion_vectors + the nearest fetch find each surface
    point's own history."""
    from ssskit.screenspace import Camera, motion_vectors

    w2c = np.eye(4)
    prev = Camera(16, 8, 20.0, 20.0, 8.0, 4.0, w2c)
    shift = np.eye(4)
    shift[0, 3] = -3.0 * 10.0 / 20.0  # 3 px at depth 10
    cur = Camera(16, 8, 20.0, 20.0, 8.0, 4.0, shift)
    depth = np.full((8, 16), 10.0)
    h = new_history(8, 16, available=True)
    h[..., MU] = np.arange(16)[None, :]
    out = reproject_history(h, motion_vectors(depth, cur, prev))
    np.testing.assert_array_equal(out[:, :13, MU], h[:, 3:, MU])
    assert np.all(out[:, 13:, AVAILABLE] == 0)


def test_shading_value_is_gamma_corrected_luminance():
    rgb = np.zeros((1, 3, 3))
    rgb[0, 0] = 1.0
    rgb[0, 1] = [0.0, 0.25, 0.0]
    rgb[0, 2] = [0.5, 0.5, 0.5]
    v = shading_value(rgb, 2.0)
    np.testing.assert_allclose(v[0], [1.0, math.sqrt(0.7152 * 0.25), math.sqrt(0.5)])
    np.testing.assert_allclose(shading_value(rgb, 1.0)[0, 2], 0.5)


# ---- bad parameters ----------------------------------------------------------------------------------------

@pytest.mark.parametrize("kwargs, message", [
    ({"sigma0_sq": 0.0}, "sigma0_sq must lie in (0, inf)"),
    ({"sigma0_sq": -1e-3}, "sigma0_sq"),
    ({"sigma0_sq": float("nan")}, "sigma0_sq"),
    ({"kappa": 1.5}, "kappa must lie in [0, 1]"),
    ({"kappa": -0.1}, "kappa"),
    ({"b_min": 65, "b_max": 64}, "needs b_min <= b_max, got b_min=65 > b_max=64"),
    ({"b_min": 0}, "b_min must lie in [1, 65536]"),
    ({"alpha": 0.0}, "alpha must lie in (0, 1]"),
    ({"alpha": 1.2}, "alpha"),
    ({"correction": "stddev"}, "correction must be one of variance, sigma"),
])
def test_bad_settings_one_clear_line(kwargs, message):
    with pytest.raises(SettingsError) as err:
        AdaptiveSettings(**kwargs)
    text = str(err.value)
    assert message in text and "\n" not in text


def test_settings_round_trip_and_k():
    s = AdaptiveSettings(sigma0_sq=1e-4, kappa=0.6, b_min=4, b_max=32, alpha=1.0, correction="SIGMA")
    assert s.correction == "sigma" and s.k == 1.0
    assert AdaptiveSettings.from_dict(s.to_dict()) == s
    assert AdaptiveSettings().k == pytest.approx(9.0)


def test_bad_arrays_raise_pass_error():
    h = new_history(2, 2)
    with pytest.raises(PassError, match=r"\(H, W, 4\)"):
        sample_counts(np.zeros((2, 2, 3)))
    with pytest.raises(PassError, match="NaN"):
        sample_counts(np.full((2, 2, 4), np.nan))
    with pytest.raises(PassError, match="shading value must be"):
        update_history(h, np.zeros((3, 2)), np.zeros((2, 2), int))
    with pytest.raises(PassError, match="motion vectors must be"):
        reproject_history(h, np.zeros((2, 2)))
    with pytest.raises(PassError, match="AdaptiveSettings"):
        sample_counts(h, {"kappa": 1})


# ---- the static frame loop ---------------------------------------------------------------------------------

def _step_gbuffer(h=32, w=32):
    """A flat, fronto-parallel SSS plane (300 mm away, 0.5 mm pixels) lit in three flat patches."""
    from ssskit.screenspace import Camera, GBuffer

    diffuse = np.full((h, w, 3), 0.05, np.float32)
    diffuse[:, w // 2:] = 0.8
    diffuse[h // 2:, : w // 4] = 0.4
    return GBuffer(diffuse=diffuse, albedo=np.ones((h, w, 3), np.float32), depth=np.full((h, w), 300.0, np.float32),
                   profile_id=np.ones((h, w), np.uint32), camera=Camera(w, h, 600.0, 600.0, w / 2, h / 2))


def _params():
    from ssskit.screenspace import BurleyParams

    return BurleyParams.from_dmfp((0.8, 0.6, 0.4), (4.0, 2.5, 1.5))


def test_adaptive_frames_runs_the_guiding_phase_per_frame():
    from ssskit.screenspace import BurleySettings, burley_sss
    from ssskit.screenspace.frames import adaptive_frames

    gb = _step_gbuffer(12, 16)
    b = BurleySettings(sampler="exact", sequence="random", mips=False, backend="numpy", frame=5, seed=2)
    s = AdaptiveSettings(sigma0_sq=1e-4, kappa=0.2)
    run = adaptive_frames(gb, _params(), s, 4, burley=b)
    assert run.counts.shape == (4, 12, 16) and len(run.ms_pass) == len(run.ms_update) == 4
    assert np.all(run.counts[0] == 8)  # no history: frame 0 takes b_min (Eqs. 16-17)
    # replay the loop by hand: counts from the history, the pass at frame 5 + f, the update
    h = new_history(12, 16)
    frames = []
    for f in range(4):
        counts, _ = sample_counts(h, s)
        np.testing.assert_array_equal(counts, run.counts[f])
        out = burley_sss(gb, _params(), b.replace(frame=5 + f), counts=counts)
        h = update_history(h, shading_value(out, s.gamma), counts, s)
        frames.append(out.astype(np.float64))
    np.testing.assert_allclose(run.mean, np.mean(frames, axis=0), rtol=1e-12)
    np.testing.assert_array_equal(run.last, frames[-1].astype(np.float32))
    np.testing.assert_array_equal(run.history, h)
    assert run.counts[1:].max() > 8  # the counts adapt
    np.testing.assert_allclose(run.mean_spp, run.counts.reshape(4, -1).mean(axis=1))


def test_adaptive_frames_bad_inputs():
    from ssskit.screenspace.frames import adaptive_frames

    gb = _step_gbuffer(8, 8)
    with pytest.raises(PassError, match="gbuffer must be GBuffer, got"):
        adaptive_frames(np.zeros((8, 8, 3)), _params())
    with pytest.raises(PassError, match=r"the adaptive history must be a float array of shape \(8, 8, 4\), "
                                        r"got shape \(4, 4, 4\)"):
        adaptive_frames(gb, _params(), history=new_history(4, 4))
    with pytest.raises(SettingsError, match="frames must lie in"):
        adaptive_frames(gb, _params(), frames=0)
    with pytest.raises(PassError, match="burley must be BurleySettings"):
        adaptive_frames(gb, _params(), burley={"spp": 8})


def test_with_mips_adapting_counts_moves_the_average_no_more_than_its_noise():
    """Eq. 22's mip level depends on the count n, so the adaptive pass with prefiltered mips reads other levels
    than fixed 64 spp. With a = 1/16 in Xie's units (docs/burley-mips.md) that changes the prefilter's bias by
    less than the Monte Carlo error: the 256-frame averages of the adaptive pass and of fixed 64 spp (mips
    on, independent seeds) differ by about one combined standard error (RMS over pixels), while both carry
    the mips' bias against the no-mips limit. (Before the mip units were fixed the distance was 3.4.)"""
    from ssskit.pipeline.burley_frame import burley_exact
    from ssskit.screenspace import BurleySettings
    from ssskit.screenspace.frames import adaptive_frames

    gb = _step_gbuffer()
    b = BurleySettings(sampler="exact", sequence="random", mips=True, backend="numba")
    ada = adaptive_frames(gb, _params(), AdaptiveSettings(sigma0_sq=1e-3, kappa=0.2), 256, burley=b.replace(seed=5))
    fix = adaptive_frames(gb, _params(), AdaptiveSettings(b_min=64, b_max=64), 256, burley=b.replace(seed=6))
    assert 20 < ada.counts[128:].mean() < 40  # the counts adapt, well below 64
    d = ada.mean - fix.mean
    se = np.sqrt(np.mean(ada.stderr**2 + fix.stderr**2))
    assert np.sqrt(np.mean(d**2)) / se < 1.25
    ref = burley_exact(gb, _params())
    for run in (ada, fix):  # the mips' own bias: above the noise floor of the average, for both
        assert np.sqrt(np.mean((run.mean - ref) ** 2)) > 1.5 * np.sqrt(np.mean(run.stderr**2))


def test_adaptive_average_has_no_visible_bias():
    """Must-show: on a static scene the average of 256 frames of the adaptive pass equals the converged
    reference within Monte Carlo error. The reference is the pass's own limit (exact sampler, no mips:
    :func:`ssskit.pipeline.burley_frame.burley_exact`); the error is each pixel's standard error across the frames.
    The counts are chosen from earlier frames only, so adapting them adds no bias."""
    from ssskit.pipeline.burley_frame import burley_exact
    from ssskit.screenspace import BurleySettings
    from ssskit.screenspace.frames import adaptive_frames

    gb = _step_gbuffer()
    b = BurleySettings(sampler="exact", sequence="random", mips=False, backend="numba", seed=0)
    run = adaptive_frames(gb, _params(), AdaptiveSettings(sigma0_sq=1e-4, kappa=0.2), 256, burley=b)
    late = run.counts[128:]
    assert late.min() == 8 and late.max() == 64 and 20 < late.mean() < 60  # the counts do adapt
    ref = burley_exact(gb, _params())
    noisy = run.stderr > 1e-4  # flat patches far from an edge return their value exactly
    assert noisy.mean() > 0.95
    z = (run.mean - ref)[noisy] / run.stderr[noisy]
    assert abs(z.mean()) < 0.15, z.mean()
    assert 0.85 < math.sqrt((z**2).mean()) < 1.2
    assert (np.abs(z) > 4).mean() < 0.01  # rare-event tails far from an edge aside, no outliers


def test_circle_run_peaks_counts_closed_runs():
    """Two pixels: runs above 36 of heights 40, 50 (lengths 2, 1) and one still open at the end (not
    counted); a pixel with no run contributes nothing; no run at all gives NaN."""
    n = np.array([[8, 8], [40, 8], [38, 8], [8, 8], [50, 8], [8, 8], [60, 8]], float)
    z = np.zeros_like(n)
    run = CircleRun(AdaptiveSettings(), False, z, n, z, z, z)
    assert run.peaks(36) == (45.0, 1.5)
    assert run.peaks(36, start=3) == (50.0, 1.0)
    assert all(math.isnan(v) for v in run.peaks(100))
