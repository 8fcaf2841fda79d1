"""Kernels: every method against a paper number, an independent reference or a physical property."""

import json

import numpy as np
import pytest

from ssskit.errors import KernelError, SignalError
from ssskit.kernels import METHODS, build_kernel, load_kernel, parse_method_spec, save_kernel
from ssskit.kernels.base import Kernel, TapKernel, default_grid
from ssskit.kernels.burley_fit import _mixture, fit_burley_channel
from ssskit.kernels.jimenez2012 import kernel_jimenez2012
from ssskit.kernels.methods import fit_artist, singular_values
from ssskit.profiles import GaussianSumProfile, RGBProfile, profile_for_material
from ssskit.truth import apply_separable, convolve_2d


@pytest.fixture(scope="module")
def skin():
    return profile_for_material("skin1", "dipole")


@pytest.fixture(scope="module")
def grid(skin):
    return default_grid(skin, 101)


def _rgb(chan, name="test"):
    return RGBProfile((chan, chan, chan), "test", name)


# ---- jimenez2012 ---------------------------------------------------------------------------------

def test_jimenez2012_engine_table_11_taps():
    k = kernel_jimenez2012(11)
    # the engine numbers (6 digits)
    assert k.weights[0] == pytest.approx([0.560479, 0.669086, 0.784728], abs=5e-7)
    assert k.offsets_mm[0] == 0.0  # centre tap first
    assert k.offsets_mm[1:].tolist() == pytest.approx([-2.0, -1.28, -0.72, -0.32, -0.08, 0.08, 0.32, 0.72, 1.28, 2.0])
    assert k.weights.sum(axis=0) == pytest.approx([1.0, 1.0, 1.0], abs=1e-12)


@pytest.mark.parametrize("taps,reach", [(17, 2.0), (25, 3.0)])
def test_jimenez2012_presets(taps, reach):
    k = kernel_jimenez2012(taps)
    assert k.taps == taps and np.max(np.abs(k.offsets_mm)) == pytest.approx(reach)
    assert k.weights.sum(axis=0) == pytest.approx([1, 1, 1], abs=1e-12)
    # strength s mixes with the identity: the centre weight is at least 1 - s
    assert np.all(k.weights[0] >= 1 - np.array([0.48, 0.41, 0.28]))


def test_jimenez2012_bad_taps():
    with pytest.raises(KernelError, match="odd"):
        kernel_jimenez2012(10)
    with pytest.raises(KernelError, match="strength"):
        kernel_jimenez2012(11, strength=1.5)


# ---- SVD -----------------------------------------------------------------------------------------

def test_svd_frobenius_error_is_tail_of_singular_values(skin, grid):
    h, n = grid
    rd = skin.discretize_2d(h, n)
    sv = singular_values(skin, h, n)
    previous = np.inf
    for rank in range(1, 7):
        k = build_kernel("svd", skin, h, n, rank=rank)
        fro = np.sqrt(((rd - k.to_2d()) ** 2).sum(axis=(0, 1)))
        expect = np.sqrt((sv[:, rank:] ** 2).sum(axis=1))  # Eckart-Young (Eqs. S.3-S.4)
        assert fro == pytest.approx(expect, rel=1e-6, abs=1e-14)
        assert np.all(fro < previous)
        previous = fro


def test_svd_l1_renormalisation(skin, grid):
    h, n = grid
    k = build_kernel("svd_l1", skin, h, n, rank=1)
    assert k.l1_norm() == pytest.approx(skin.discretize_2d(h, n).sum(axis=(0, 1)), rel=1e-12)


def test_separable_profile_is_recovered_exactly():
    # a single 2D Gaussian is exactly separable: rank 1 SVD, pre-integrated and guided all return it
    g = _rgb(GaussianSumProfile([0.5], [0.8]))
    h, n = 0.1, 61
    rd = g.discretize_2d(h, n)
    for method, params in [("svd", {"rank": 1}), ("preintegrated", {}), ("guided", {"k": 0.0}), ("guided", {"k": 2.0}),
                           ("guided", {"k": 4.0})]:
        k = build_kernel(method, g, h, n, **params)
        err = np.abs(k.to_2d() - rd).max() / rd.max()
        assert err < (1e-10 if method != "guided" else 2e-3), (method, params, err)


# ---- pre-integrated ------------------------------------------------------------------------------

@pytest.mark.parametrize("model", ["dipole", "burley"])
def test_preintegrated_exact_on_additively_separable_signals(model):
    prof = profile_for_material("marble", model, **({"albedo_source": "dipole"} if model == "burley" else {}))
    h, n = default_grid(prof, 41)
    rng = np.random.default_rng(3)
    e1, e2 = rng.random(96), rng.random(96)
    for image in (np.broadcast_to((np.arange(96) > 47.5)[None, :, None], (96, 96, 3)).astype(float),  # vertical edge
                  np.broadcast_to((e1[None, :] + e2[:, None])[..., None], (96, 96, 3)).copy()):  # E1(x) + E2(y)
        truth = convolve_2d(image, prof.discretize_2d(h, n))
        approx = apply_separable(image, build_kernel("preintegrated", prof, h, n), h)
        assert np.abs(approx - truth).max() <= 1e-6 * np.abs(truth).max()


def test_preintegrated_rotated_edge_within_stated_error(skin):
    from ssskit.pipeline import evaluate

    res = evaluate(skin, "edge-rotated", ["preintegrated", "svd:1"], size=128, perceptual=False).results
    # rasterising a rotated edge breaks additive separability at the pixel scale: measured 7e-3
    assert res["preintegrated"]["relative_rmse"] < 1.5e-2
    assert res["preintegrated"]["relative_rmse"] < res["svd:1"]["relative_rmse"]


def test_preintegrated_residual_svd(skin, grid):
    h, n = grid
    base = build_kernel("preintegrated", skin, h, n)
    plus = build_kernel("preintegrated_svd", skin, h, n, rank=2)
    assert plus.rank == 3 and plus.convolutions_1d == 6
    assert np.all(np.array(plus.compare(skin)["frobenius"]) < np.array(base.compare(skin)["frobenius"]))
    assert base.total() == pytest.approx(skin.discretize_2d(h, n).sum(axis=(0, 1)), rel=1e-12)


# ---- Gaussians -----------------------------------------------------------------------------------

def test_gaussians_recover_deon2007_preset():
    deon = profile_for_material(None, "deon2007")
    h, n = default_grid(deon, 101)
    k = build_kernel("gaussians", deon, h, n, count=6)
    assert max(k.compare(deon)["relative_frobenius"]) < 1e-2
    assert k.total() == pytest.approx(deon.discretize_2d(h, n).sum(axis=(0, 1)), rel=1e-10)  # L1 constraint


def test_gaussians_improve_with_count(skin, grid):
    h, n = grid
    errs = [np.mean(build_kernel("gaussians", skin, h, n, count=c).compare(skin)["relative_frobenius"])
            for c in (1, 2, 4, 6)]
    assert all(a > b for a, b in zip(errs, errs[1:]))


# ---- artist --------------------------------------------------------------------------------------

def test_artist_presets_and_unit_energy():
    k = build_kernel("artist", None, 0.01, 801, preset="production")
    assert k.params["sigma_near_mm"] == [0.25, 0.08, 0.02] and k.params["weight"] == [0.6] * 3
    # a_m integrates to 1 (Eq. 6); on a grid of half-width R the kernel holds the mass inside it
    from scipy.special import erf

    half = k.radius_mm
    inside = [0.6 * erf(half / (sn * 2**0.5)) + 0.4 * erf(half / (sf * 2**0.5)) for sn, sf in zip((0.25, 0.08, 0.02), (1.0, 0.3, 0.05))]
    assert k.total() == pytest.approx(np.square(inside), rel=1e-12)


def test_fit_artist_recovers_two_gaussian_parameters():
    # the pre-integrated 1D kernel of w G2(sn) + (1 - w) G2(sf) is exactly w G1(sn) + (1 - w) G1(sf)
    prof = _rgb(GaussianSumProfile([0.3, 0.7], [0.2**2, 1.1**2]))
    fit = fit_artist(prof, 0.05, 321)
    assert fit["sigma_near"] == pytest.approx([0.2] * 3, rel=1e-4)
    assert fit["sigma_far"] == pytest.approx([1.1] * 3, rel=1e-4)
    assert fit["weight"] == pytest.approx([0.3] * 3, rel=1e-4)


# ---- guided --------------------------------------------------------------------------------------

def test_guided_constraint_and_non_negativity(skin):
    h, n = default_grid(skin, 81)
    rd_total = skin.discretize_2d(h, n).sum(axis=(0, 1))
    for kk in (0.0, 2.0, 4.0):
        k = build_kernel("guided", skin, h, n, k=kk)
        assert k.total() == pytest.approx(rd_total, rel=1e-6)  # ||a||_1^2 = ||Rd||_1 (Eq. 7)
        assert np.all(k.components >= 0)


def test_guided_bad_k(skin):
    with pytest.raises(KernelError, match="k"):
        build_kernel("guided", skin, 0.1, 21, k=-1.0)


def _half_energy_radius(cells, cell_mm):
    """Radius of the disk holding half of each channel's energy, each cell's value uniform over its
    area (overlap areas by Gauss-Legendre along x, radius by bisection), shape (3,)."""
    n = cells.shape[0]
    edges = (np.arange(n + 1) - n / 2.0) * cell_mm
    t, w = np.polynomial.legendre.leggauss(16)
    x = 0.5 * (edges[:-1, None] + edges[1:, None]) + 0.5 * cell_mm * t

    def inside(c, radius):
        s = np.sqrt(np.maximum(radius**2 - x**2, 0.0))
        overlap = np.clip(np.minimum(edges[1:, None, None], s) - np.maximum(edges[:-1, None, None], -s), 0.0, None)
        return float(((overlap * w).sum(axis=2) * 0.5 * cell_mm * cells[..., c]).sum()) / cell_mm**2

    out = []
    for c in range(3):
        lo, hi, half = 0.0, cell_mm * n, 0.5 * cells[..., c].sum()
        for _ in range(36):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if inside(c, mid) < half else (lo, mid)
        out.append(lo)
    return np.array(out)


@pytest.mark.parametrize("material,channels", [("marble", (0, 1, 2)), ("skin1", (0, 1)), ("ketchup", (0,))])
def test_guided_k0_sharper_k4_smoother_by_half_energy_radius(material, channels):
    """Appendix A: "k = 0 provides a visually sharper variant ... and k = 4 a smoother approximation".

    Sharpness named as r50, the radius of the disk holding half of A_s's 2D energy (cells uniform over
    their area). Measured on the MCML profiles (docs/kernel-accuracy.md) it grows k = 0 < 2 < 4 in
    the channels wide against the grid (Skin1 R, Marble R, G, B, Ketchup R on 87- and 201-cell
    grids), not always in narrow ones, where a's centre spike grows with k. Other widths are not
    monotone in k (axis-marginal std and r90 dip at k = 1-3; the FWHM of A(x, 0) shrinks with the
    spike), so they are not asserted.
    """
    prof = profile_for_material(material, "dipole")
    h, n = default_grid(prof, 41)
    r50 = np.array([_half_energy_radius(build_kernel("guided", prof, h, n, k=k).to_2d(), h) for k in (0.0, 2.0, 4.0)])
    for c in channels:
        assert r50[0, c] < r50[1, c] < r50[2, c], (material, c, r50[:, c])


def test_guided_k4_puts_most_energy_in_the_far_range():
    """Supplement D: k = 4 "emphasize[s] far scattering"; Appendix A: it "models the far-range scattering".

    The energy of A_s beyond the radius holding 90% of Rd's grows from k = 2 to k = 4 in every
    channel, and overshoots Rd's own far-range energy (so "emphasise", not "more faithfully").
    """
    for material in ("skin1", "marble"):
        prof = profile_for_material(material, "dipole")
        h, n = default_grid(prof, 41)
        rd = prof.discretize_2d(h, n)
        x = (np.arange(n) - n // 2) * h
        far = np.hypot(x[:, None], x[None, :])[..., None] > np.asarray(prof.radius_at_fraction(0.9))
        beyond = {k: (build_kernel("guided", prof, h, n, k=k).to_2d() * far).sum(axis=(0, 1)) for k in (2.0, 4.0)}
        rd_beyond = (rd * far).sum(axis=(0, 1))
        assert np.all(beyond[4.0] > beyond[2.0]), (material, beyond)
        assert np.all(beyond[4.0] > rd_beyond), (material, beyond[4.0] / rd_beyond)


def _eq7_objective(rd, gamma, a, cell_mm):
    """sum Gamma (Rd - a a^T)^2 over the cells (Eq. 7 discretised), rd and a as densities."""
    return float((gamma * (rd - np.outer(a, a)) ** 2).sum() * cell_mm**2)


@pytest.mark.parametrize("k", [0.0, 2.0, 4.0])
def test_guided_solves_eq7_on_channels_narrow_against_the_grid(k):
    """The returned a_s minimises Eq. 7 under its constraint: no feasible candidate does better.

    Ketchup's green and blue channels are a few cells wide on the grid that red needs; there SLSQP
    used to stall and its start came back as the answer (objective up to 1e4 x the optimum).
    Candidates: the pre-integrated a_p / sqrt(||Rd||_1) and the axis-slice start, both feasible, and
    small feasible perturbations of a_s (mass moved between two cells).
    """
    from ssskit.kernels.guided import _cell_guide

    prof = profile_for_material("ketchup", "dipole")
    h, n = default_grid(prof, 41)
    gamma = _cell_guide(n, k, 50.0)
    kernel = build_kernel("guided", prof, h, n, k=k)
    rng = np.random.default_rng(7)
    for c in range(3):
        rd = prof.channels[c].discretize_2d(h, n) / h**2
        root = np.sqrt(rd.sum() * h**2)
        a = kernel.components[c, 0]
        assert a.sum() * h == pytest.approx(root, rel=1e-9) and np.all(a >= 0)  # ||a||_1^2 = ||Rd||_1
        f = _eq7_objective(rd, gamma, a, h)
        a_p = rd.sum(axis=0) * h / root
        axis = np.sqrt(np.maximum(rd[n // 2], 0.0))
        axis *= root / (axis.sum() * h)
        for cand in (a_p, axis):
            assert f <= _eq7_objective(rd, gamma, cand, h) * (1 + 1e-9), (c, f, _eq7_objective(rd, gamma, cand, h))
        half = a[n // 2:]
        mult = np.where(np.arange(half.size) == 0, 1.0, 2.0)  # cell i > 0 appears at +-i
        for _ in range(20):  # move 5% of cell i's mass to cell j (both sides): still feasible
            i, j = rng.choice(half.size, 2, replace=False)
            moved = half.copy()
            moved[i] -= 0.05 * half[i]
            moved[j] += 0.05 * half[i] * mult[i] / mult[j]
            trial = np.concatenate([moved[:0:-1], moved])
            assert trial.sum() * h == pytest.approx(root, rel=1e-9)
            assert f <= _eq7_objective(rd, gamma, trial, h) * (1 + 1e-7), (c, i, j)


# ---- Burley fit (Xie 2020 A.1) -------------------------------------------------------------------

@pytest.mark.parametrize("error", ["difference", "ratio", "derivative"])
def test_burley_fit_recovers_engine_falloff(error):
    w, sig = _mixture("jimenez2012", np.array([0.5]))
    target = GaussianSumProfile(0.6 * w, sig**2)
    fit = fit_burley_channel(target, "jimenez2012", error)
    assert fit["params"]["falloff"] == pytest.approx(0.5, rel=1e-5)
    assert fit["relative_l2"] < 1e-6


def test_burley_fit_difference_error_gives_the_closest_profile_in_2d_l2():
    """Xie 2020, A.1.1: "We observed that S_Delta is the best error function for non-linear least
    squares fitting." (S_Delta = sum (R_B - R_S)^2, Eq. 25; against the ratio, Eq. 26, and the
    derivative, Eq. 27.)

    Measured independently of the fitter's samples and yardstick: the fitted radial profile R_S
    (a sum of 2D Gaussians) and Burley's R_B, both as exact cell integrals on a 101-cell grid over
    the 99.9% radius, compared in relative 2D L2. The fits rank difference < ratio < derivative.
    R_B ~ 1/r at r = 0 makes this norm peak-dominated and cell-size dependent (with 21 cells the
    ratio fit wins), and the rendered result ranks the fits differently (next test).
    """
    burley = profile_for_material("skin1", "burley", albedo_source="dipole")
    for channel in burley.channels:
        one = _rgb(channel)
        h, n = default_grid(one, 101)
        rb = channel.discretize_2d(h, n)
        err = {}
        for error in ("difference", "ratio", "derivative"):
            fit = fit_burley_channel(channel, "jimenez2012", error)
            w, sig = _mixture("jimenez2012", np.array([fit["params"]["falloff"]]))
            rs = GaussianSumProfile(channel.total_rd() * w, sig**2).discretize_2d(h, n)
            err[error] = np.sqrt(((rs - rb) ** 2).sum() / (rb**2).sum())
        assert err["difference"] < err["ratio"] < err["derivative"], err


def test_burley_fit_difference_error_is_not_the_closest_when_rendered():
    """Xie's claim (previous test) does not carry over to the image: Xie fits "to make the separable
    and Burley models appear as similar as possible visually", but the separable engine kernel of the
    ratio fit reproduces Burley's exact 2D convolution about 2x better than the difference fit's, on an
    edge and a disk. The difference fit matches the 1/r peak and is too narrow (Skin1 R falloff 0.59 vs
    1.40) and leaves too much energy near the centre; the kernel still holds Burley's total energy.
    """
    from ssskit.pipeline import evaluate

    burley = profile_for_material("skin1", "burley", albedo_source="dipole")
    specs = ["burley_fit:difference", "burley_fit:ratio", "burley_fit:derivative"]
    for signal in ("edge", "disk"):
        res = evaluate(burley, signal, specs, size=96, perceptual=False).results
        err = {s.split(":")[1]: res[s]["relative_rmse"] for s in specs}
        assert err["ratio"] < 0.75 * err["difference"] < 0.75 * err["derivative"], (signal, err)
    k = build_kernel("burley_fit", burley, *default_grid(burley, 101), error="ratio")
    assert k.total() == pytest.approx(burley.total_rd(), rel=1e-3)


# ---- the Kernel type -----------------------------------------------------------------------------

def test_kernel_roundtrip_and_resample(skin, grid, tmp_path):
    k = build_kernel("svd", skin, *grid, rank=2)
    for suffix in (".json", ".npz"):
        save_kernel(k, tmp_path / f"k{suffix}")
        back = load_kernel(tmp_path / f"k{suffix}")
        assert isinstance(back, Kernel) and back.method == "svd" and back.params["rank"] == 2
        np.testing.assert_array_equal(back.components, k.components)
        np.testing.assert_array_equal(back.signs, k.signs)
    t = kernel_jimenez2012(17)
    save_kernel(t, tmp_path / "t.npz")
    back = load_kernel(tmp_path / "t.npz")
    assert isinstance(back, TapKernel)
    np.testing.assert_array_equal(back.weights, t.weights)
    # resampling to a coarser grid conserves each component's integral
    r = k.resample(grid[0] * 3)
    assert r.cell_weights().sum(axis=2) == pytest.approx(k.cell_weights().sum(axis=2), rel=1e-12)
    assert k.to_2d().sum(axis=(0, 1)) == pytest.approx(k.total(), rel=1e-12)


def test_tap_kernel_on_pixels_conserves_weights():
    t = kernel_jimenez2012(11)
    k = t.to_kernel(0.07)
    assert k.cell_weights()[:, 0].sum(axis=1) == pytest.approx(t.weights.sum(axis=0), rel=1e-12)


def test_kernel_errors(tmp_path):
    with pytest.raises(KernelError, match="odd"):
        Kernel(0.1, np.ones((3, 1, 10)), np.ones((3, 1)), "x")
    with pytest.raises(KernelError, match="NaN"):
        Kernel(0.1, np.full((3, 1, 11), np.nan), np.ones((3, 1)), "x")
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"type": "tabulated"}))
    with pytest.raises(KernelError, match="not a tabulated"):
        load_kernel(bad)
    bad.write_text(json.dumps({"type": "taps", "offsets": [0.0], "method": "x"}))  # (no weights)
    with pytest.raises(KernelError, match="not an ssskit tap kernel: 'weights'"):
        load_kernel(bad)
    bad.write_text(json.dumps({"type": "taps", "offsets": [0.0, 1.0], "weights": [[1, 1, 1]], "method": "x"}))
    with pytest.raises(KernelError, match=r"tap weights must be a real array of shape \(2, 3\)"):
        load_kernel(bad)  # (the kernel's own rule, in its words)
    with pytest.raises(KernelError, match="does not exist"):
        load_kernel(tmp_path / "nope.npz")
    with pytest.raises(KernelError, match="unknown kernel method|kernel method"):
        parse_method_spec("nosuch:3")
    with pytest.raises(KernelError, match="integer"):
        parse_method_spec("svd:three")


def test_every_registered_method_builds(skin):
    h, n = default_grid(skin, 41)
    for name, m in METHODS.items():
        k = build_kernel(name, skin, h, n)
        assert np.all(np.isfinite(k.total())) and np.all(k.total() > 0), name


# ---- ground truth ------------------------------------------------------------------------------

def test_truth_constant_and_delta(skin):
    h, n = default_grid(skin, 31)
    rd = skin.discretize_2d(h, n)
    const = convolve_2d(np.ones((40, 40, 3)), rd)
    np.testing.assert_allclose(const, np.broadcast_to(rd.sum(axis=(0, 1)), const.shape), rtol=1e-12)
    delta = np.zeros((41, 41, 3))
    delta[20, 20] = 1.0
    out = convolve_2d(delta, rd)
    np.testing.assert_allclose(out[5:36, 5:36], rd, atol=1e-15)
    k = build_kernel("svd", skin, h, n, rank=3)
    np.testing.assert_allclose(apply_separable(delta, k, h)[5:36, 5:36], k.to_2d(), atol=1e-15)


def test_truth_rejects_bad_images():
    with pytest.raises(SignalError, match="shape"):
        convolve_2d(np.ones((4, 4)), np.ones((3, 3, 3)))
    with pytest.raises(SignalError, match="NaN"):
        convolve_2d(np.full((4, 4, 3), np.nan), np.ones((3, 3, 3)))


def test_build_kernel_refuses_what_it_cannot_use(skin):
    """A zero grid is refused (not silently replaced by the default grid); an unknown keyword is a KernelError
    naming the method's keywords; a material or a name where the profile is expected is a KernelError saying
    what is expected; the SVD rank has one limit, MAX_SVD_RANK, in the API and in method specs alike."""
    from ssskit.kernels import MAX_SVD_RANK
    from ssskit.materials import get_material

    with pytest.raises(KernelError, match=r"kernel cell size must lie in \(0, inf\) mm, got 0"):
        build_kernel("svd", skin, cell_mm=0.0)
    with pytest.raises(KernelError, match=r"kernel grid size must lie in \[3, 100001\], got 0 \(odd, so the origin"):
        build_kernel("svd", skin, n=0)
    with pytest.raises(KernelError, match=r"kernel method 'svd': unknown keyword argument\(s\) rnk "
                                          r"\(known: rank, renormalise\)"):
        build_kernel("svd", skin, rnk=2)
    with pytest.raises(KernelError, match=r"unknown keyword argument\(s\) sigmanear \(known: preset, sigma_near"):
        build_kernel("artist", skin, sigmanear=1.0)
    for wrong in (get_material("skin1"), "skin1"):
        with pytest.raises(KernelError, match=r"the profile of kernel method 'svd' \(profile_for_material\(material, model\) makes one\) "
                                          r"must be RGBProfile, got (Material|str)$"):
            build_kernel("svd", wrong)
    assert MAX_SVD_RANK == 64
    h, n = default_grid(skin, 201)
    for method in ("svd", "svd_l1", "preintegrated_svd"):
        with pytest.raises(KernelError, match=rf"rank must lie in \[1, {MAX_SVD_RANK}\], got {MAX_SVD_RANK + 1}"):
            build_kernel(method, skin, h, n, rank=MAX_SVD_RANK + 1)
        with pytest.raises(KernelError, match=rf"rank must lie in \[1, {MAX_SVD_RANK}\], got {MAX_SVD_RANK + 1}"):
            parse_method_spec(f"{method}:{MAX_SVD_RANK + 1}")
