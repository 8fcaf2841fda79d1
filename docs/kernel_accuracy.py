"""Regenerate docs/kernel-accuracy.md: every kernel method's error on edges, disk and texture.

    python docs/kernel_accuracy.py [--photons 200000] [--out docs/kernel-accuracy.md]

Monte Carlo profiles (MCML, supplement F grid; cached), 256 x 256 signals, errors against the
exact 2D convolution (see ssskit.pipeline.evaluate). Then the guided optimisation's claims (paper Appendix A)
checked for k = 0..4: image errors, kernel errors against Rd's exact cell integrals and width
statistics on the evaluation grid, kernel-space measures and timings on the finer default grid;
and Xie's Burley fits rendered against Burley's exact 2D convolution.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

# The kernels are small: BLAS threads only contend with each other (on a busy machine they slowed
# this script about 5x). Set before numpy loads its BLAS; an explicit setting in the environment wins.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np

from ssskit.pipeline import evaluate, evaluation_grid
from ssskit.kernels import build_kernel
from ssskit.kernels.base import default_grid
from ssskit.kernels.burley_fit import ERROR_FUNCTIONS, compare_error_functions
from ssskit.profiles import profile_for_material

MATERIALS = ("skin1", "marble", "ketchup")
SIGNALS = ("edge", "edge-rotated", "disk", "texture")
METHODS = ["svd:1", "svd:2", "svd:3", "svd:6", "svd_l1:1", "gaussians:1", "gaussians:2", "gaussians:6",
           "preintegrated", "preintegrated_svd:1", "artist:close fit", "artist:production", "artist:fit",
           "guided:0", "guided:1", "guided:2", "guided:3", "guided:4", "jimenez2012", "burley_fit"]
GUIDED_K = (0, 1, 2, 3, 4)
GUIDED_SIGNALS = ("edge", "disk", "texture")


NOTES = """## Where the numbers disagree with the paper, and why

- **Guided optimisation: k ~ 2 is not the guided family's closest match to the actual kernel.**
  Appendix A says k ~ 2 "yields the approximation of the actual diffusion kernel", k = 0 a sharper
  and k = 4 a smoother variant. Against the exact 2D convolution (87-cell kernels, tables above)
  the relative RMSE (and PSNR, its logarithm) is lowest at k = 1 on the edge and disk for Skin1
  and Ketchup (k = 2 within 1-4%: Skin1 edge 1.24e-02 vs 1.22e-02, disk 8.99e-02 vs 8.89e-02),
  at k = 0 on every signal for Marble (k = 2 is 20% worse on the edge: 1.37e-02 vs 1.14e-02), and
  at k = 4 on the texture for Skin1 and Ketchup. FLIP is lowest at k = 2 only for Skin1's edge and
  disk (0.019, 0.010) and Ketchup's edge (0.020, tied with k = 1). Against the exact cell
  integrals of Rd the relative L2 error falls with k on the evaluation grid (k = 4 closest, k = 3
  for Marble R; Ketchup G and B, narrower than two cells, closest at k = 0) while the relative L1
  error rises with k (k = 0 closest in 8 of 9 channels). On the 2.3x finer default grid the L2
  minimum moves to k = 2 for Marble (0.469 / 0.449 / 0.435 against 0.723 / 0.706 / 0.694 at
  k = 0) and Ketchup R, to k = 3 for Skin1 R. So the closest k depends on the measure and the
  grid; k = 2 is a compromise, never the lowest-RMSE choice here. Every guided kernel is further
  from the truth than the pre-integrated kernel (also rank 1): 1.7-2.0x on the texture, 2.0-2.6x
  on the disk.
- **"k = 0 sharper, k = 4 smoother": reproduced by r50, in the wide channels.** r50, the radius
  of the disk holding half the kernel's 2D energy, grows k = 0 < 2 < 4 in 8 of 9 channels on the
  evaluation grid (Skin1 R 2.897, 2.992, 3.089 mm; Marble R 2.401, 2.636, 2.855 mm; Ketchup R
  4.240, 4.450, 4.615 mm; not Skin1 G: 1.372, 1.370, 1.372 mm) and in 6 of 9 on the default grid
  (not Skin1 G and B, Ketchup G: there r50 falls again at k = 3-4 as a's centre spike grows). The
  other statistics tried are not monotone: the standard deviation of the axis marginal and r90
  are mostly U-shaped, smallest at k = 1-3 (Skin1 G std 2.37, 1.74, 1.61, 1.61, 1.62 mm for
  k = 0..4), because k = 0 gives a the heaviest tails; the FWHM of A(x, 0) falls with k in the
  wide channels (Skin1 R 0.96 to 0.61 mm), the opposite direction, because a's centre cell holds
  a growing share of its mass (Skin1 R 0.18 to 0.32): a spike at the grid's resolution.
- **Far range: more energy, not more faithful.** The guided kernels put more energy beyond the
  radius holding 90% of Rd's than Rd does (all but Ketchup B at k = 0, 0.99x), and k = 4 the most
  in every channel (Skin1 1.50 / 1.85 / 2.08x against 1.33 / 1.69 / 1.85x at k = 2; Marble
  1.54-1.67x; the pre-integrated kernel 0.96-1.17x): k = 4 emphasises the far range (supplement
  D's wording) by overshooting it.
- **Why the centre spike: Eq. 7 is nearly degenerate on the axes.** Gamma (Eq. 8) vanishes on
  x = 0 and y = 0, so a's centre cell meets only Gamma's suppressed cross and is nearly free; the
  L1 constraint's surplus (the L2-best rank-1 fit holds less energy than ||Rd||_1) collects there,
  more so as k grows, and depending on the grid. ssskit keeps the published formulation (b = 50 on
  [-1, 1] over the shared RGB grid, Gamma averaged over cells).
- **Fixed: the guided solver failed silently on narrow channels.** SLSQP stalled ("positive
  directional derivative for linesearch") where a channel is much narrower than the shared grid
  and the start came from the interpolated coarser level, and that start was returned as the
  answer: at k >= 2 Eq. 7's objective was 40 to 16,000 times the optimum (Ketchup B at k = 4 on
  the evaluation grid: 4971 against 0.304; relative L1 error 1.68 instead of 0.09). The solver now
  works in scaled variables and, where SLSQP does not converge, falls back to L-BFGS from two
  starts plus an SLSQP polish (kernels/guided.py); where the old solver converged the objective is
  unchanged. Changed numbers: the Ketchup guided:2 and guided:4 rows (FLIP on the edge 0.027 and
  0.028 to 0.020 and 0.022, on the rotated edge 0.034 and 0.036 to 0.027 and 0.030; relative RMSE
  in the third digit at most), and on the default grid Skin1 k = 3 and 4 (k = 4: centre share
  G, B 0.306, 0.428 to 0.389, 0.473; std 1.68, 0.89 to 1.64, 0.86 mm). The previous notes' "k = 0
  is the closest to the pre-integrated kernel" measured a against a_p, which is supplement D's
  aim, not Appendix A's claim (the 2D distance of A_s to A_p is still smallest at k = 0).
- **Other changes in this regeneration:** rows guided:1 and guided:3 added to the image tables;
  the Skin1-only default-grid table replaced by the tables above for all three materials, its
  "L1 distance of a to a_p" (1D) now the 2D distance of A_s to A_p; the exact pre-integrated edge
  residuals (3e-16 to 6e-16) differ in their rounding digits (the script now runs BLAS on one
  thread). No other number in the image tables changed.
- **Artist presets (Table 2) are far from these profiles.** The paper tuned them by eye for a head
  model at an unknown length unit; ssskit reads sigma in mm, where "close fit" is much narrower than
  the MCML skin profile. `artist:fit` (least squares to a_p) is the two-Gaussian model's best case.
- **`jimenez2012` is a fixed skin kernel** (offsets in mm, falloff defaults), so its error on marble
  and ketchup mostly measures the wrong width, not the method.
- **Burley-to-separable (Xie 2020 A.1): the difference error wins in L2, not in the rendered
  result.** Xie: "We observed that S_Delta is the best error function for non-linear least squares
  fitting." On the fitter's own samples the difference fit (Eq. 25) has the lowest 2D L2 error in
  every channel (0.548 against 0.653 for the ratio, 1.233 for the derivative; the same in every
  channel because Burley's profile and the engine's are one-parameter scale families). But the
  separable engine kernels rendered against Burley's exact 2D convolution favour the ratio fit
  (Eq. 26) by 2.2-2.8x on every signal and material (Skin1: edge 0.019 vs 0.043, disk 0.082 vs
  0.194, texture 0.021 vs 0.056). Burley's profile goes as 1/r at r = 0, so its 2D L2 norm
  diverges logarithmically there and L2 measures are dominated by the peak that S_Delta fits
  (falloff 0.59 for Skin1 R, a narrow kernel), while the rendered result depends on where the
  energy goes, which the wider ratio fit (falloff 1.40) matches better. The L2 ranking itself
  depends on resolution: on exact cell integrals of one channel it holds with 101 or 201 cells
  across the 99.9% diameter and reverses with 21. tests/kernels/test_kernels.py asserts both
  halves (L2 on 101 cells; the rendered edge and disk).
"""


def energy_within(cells: np.ndarray, cell_mm: float, radius: float, nodes: int = 16) -> np.ndarray:
    """Energy inside the disk of ``radius`` (mm) of cells (n, n, C), each cell's value uniform over its
    area: sum over cells of value x (area of cell and disk) / cell area, the area integrated along x
    (Gauss-Legendre per column) of the overlap of [-s(x), s(x)] with each row; shape (C,)."""
    n = cells.shape[0]
    edges = (np.arange(n + 1) - n / 2.0) * cell_mm
    t, w = np.polynomial.legendre.leggauss(nodes)
    x = 0.5 * (edges[:-1, None] + edges[1:, None]) + 0.5 * cell_mm * t[None, :]  # (columns, nodes)
    s = np.sqrt(np.maximum(radius**2 - x**2, 0.0))
    overlap = np.clip(np.minimum(edges[1:, None, None], s[None]) - np.maximum(edges[:-1, None, None], -s[None]), 0.0, None)
    area = (overlap * w).sum(axis=2) * 0.5 * cell_mm  # (rows, columns)
    return np.einsum("yx,yxc->c", area, cells) / cell_mm**2


def radius_at_fraction_2d(cells: np.ndarray, cell_mm: float, fraction: float) -> np.ndarray:
    """Radius of the disk holding ``fraction`` of each channel's energy (bisection on :func:`energy_within`)."""
    out = []
    for c in range(cells.shape[2]):
        one = cells[..., c : c + 1]
        target = fraction * one.sum()
        lo, hi = 0.0, cell_mm * cells.shape[0]
        for _ in range(36):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if energy_within(one, cell_mm, mid)[0] < target else (lo, mid)
        out.append(0.5 * (lo + hi))
    return np.array(out)


def axis_std(cells: np.ndarray, cell_mm: float) -> np.ndarray:
    """Standard deviation of the axis marginal m(x) = sum_y A(x, y), per channel (Kernel.width_mm)."""
    n = cells.shape[0]
    x2 = ((np.arange(n) - n // 2) * cell_mm)[:, None] ** 2
    m = cells.sum(axis=0)
    return np.sqrt((x2 * m).sum(axis=0) / m.sum(axis=0))


def axis_fwhm(cells: np.ndarray, cell_mm: float) -> np.ndarray:
    """Full width at half maximum of the axis slice A(x, 0) (linear interpolation between cell centres)."""
    n = cells.shape[0]
    c = n // 2
    x = np.arange(n - c) * cell_mm
    out = []
    for ch in range(cells.shape[2]):
        y = cells[c, c:, ch]
        i = int(np.argmax(y < y[0] / 2.0)) or len(y) - 1
        out.append(2.0 * float(np.interp(y[0] / 2.0, [y[i], y[i - 1]], [x[i], x[i - 1]])))
    return np.array(out)


def far_energy_ratio(cells: np.ndarray, rd: np.ndarray, cell_mm: float, r_far: np.ndarray) -> np.ndarray:
    """Energy of A beyond radius r_far (per channel) divided by Rd's energy there (1 = right far-range energy)."""
    n = cells.shape[0]
    x = (np.arange(n) - n // 2) * cell_mm
    r = np.hypot(x[:, None], x[None, :])
    return np.array([cells[..., c][r > r_far[c]].sum() / rd[..., c][r > r_far[c]].sum() for c in range(3)])


def _trend(rows: list[np.ndarray]) -> str:
    """Per channel: 'up' (strictly increasing with k), 'up=' (non-decreasing, with ties), 'down', 'no'."""
    d = np.diff(np.array(rows), axis=0)
    words = []
    for c in range(d.shape[1]):
        col = d[:, c]
        words.append("up" if np.all(col > 0) else "up=" if np.all(col >= 0) else "down" if np.all(col < 0) else "no")
    return ", ".join(words)


def _rgb(v, fmt="{:.3f}") -> str:
    return ", ".join(fmt.format(x) for x in v)


def guided_tables(prof, res: dict, h: float, n: int) -> tuple[list[str], dict]:
    """Appendix A checked on one material: the guided kernels k = 0..4 on the evaluation grid (the
    same kernels the images above use) against the exact 2D convolution and the exact cell integrals."""
    rd = prof.discretize_2d(h, n)
    r90 = np.asarray(prof.radius_at_fraction(0.9), dtype=float)
    kernels = {f"guided:{k}": build_kernel("guided", prof, h, n, k=float(k)) for k in GUIDED_K}
    pre = build_kernel("preintegrated", prof, h, n)
    rows_err, rows_w, stats = [], [], {}
    for label, ker in list(kernels.items()) + [("preintegrated", pre), ("Rd (exact cells)", None)]:
        cells = rd if ker is None else ker.to_2d()
        st = {"r50": radius_at_fraction_2d(cells, h, 0.5), "r90": radius_at_fraction_2d(cells, h, 0.9),
              "std": axis_std(cells, h), "fwhm": axis_fwhm(cells, h),
              "far": far_energy_ratio(cells, rd, h, r90)}
        if ker is not None:
            cmp_ = ker.compare(prof)
            st["l2"], st["l1"] = np.array(cmp_["relative_frobenius"]), np.array(cmp_["relative_l1"])
            w = ker.cell_weights()[:, 0]
            st["centre"] = w[:, n // 2] / w.sum(axis=1)
            st["rmse"] = [res[s][label]["relative_rmse"] for s in GUIDED_SIGNALS]
            st["psnr"] = [res[s][label]["psnr"] for s in GUIDED_SIGNALS]
            st["flip"] = [res[s][label]["flip"] for s in GUIDED_SIGNALS]
            rows_err.append(f"| {label} | {_rgb(st['rmse'], '{:.2e}')} | {_rgb(st['psnr'], '{:.1f}')} | "
                            f"{_rgb(st['flip'])} | {_rgb(st['l2'])} | {_rgb(st['l1'])} |")
        rows_w.append(f"| {label} | {_rgb(st['r50'])} | {_rgb(st['r90'], '{:.2f}')} | {_rgb(st['std'], '{:.2f}')} | "
                      f"{_rgb(st['fwhm'], '{:.2f}')} | {_rgb(st['far'], '{:.2f}')} | "
                      + (_rgb(st["centre"]) if "centre" in st else "") + " |")
        stats[label] = st
    g = [stats[f"guided:{k}"] for k in GUIDED_K]

    def best(key):
        return ", ".join(str(GUIDED_K[i]) for i in np.argmin(np.array([s[key] for s in g]), axis=0))

    rows_err.append(f"| **closest k** | {best('rmse')} | (same as RMSE) | {best('flip')} | {best('l2')} | {best('l1')} |")
    rows_w.append("| **trend in k** | " + " | ".join(_trend([s[key] for s in g]) for key in ("r50", "r90", "std", "fwhm", "far"))
                  + " | " + _trend([s["centre"] for s in g]) + " |")
    lines = [f"### {prof.name}: errors ({n} x {n} cells of {h:.3f} mm, the image kernels above)", "",
             "| kernel | rel. RMSE (edge, disk, texture) | PSNR dB | FLIP | kernel rel. L2 (R, G, B) | kernel rel. L1 (R, G, B) |",
             "|---|---|---|---|---|---|"] + rows_err + ["",
             f"### {prof.name}: widths [mm] and far-range energy", "",
             "| kernel | r50 (R, G, B) | r90 | std of axis marginal | FWHM of axis slice | energy beyond Rd's r90 / Rd's "
             "| centre cell's share of a |", "|---|---|---|---|---|---|---|"] + rows_w + [""]
    return lines, stats


def guided_fine_grid(prof) -> list[str]:
    """The kernel-space measures on the default 201-cell grid (2.3x finer): the grid dependence."""
    h, n = default_grid(prof)
    rd = prof.discretize_2d(h, n)
    pre = build_kernel("preintegrated", prof, h, n).to_2d()
    rows, r50s, l2s = [], [], []
    for k in GUIDED_K:
        t0 = time.perf_counter()
        g = build_kernel("guided", prof, h, n, k=float(k))
        dt = (time.perf_counter() - t0) / 3.0
        cells = g.to_2d()
        cmp_ = g.compare(prof)
        w = g.cell_weights()[:, 0]
        r50 = radius_at_fraction_2d(cells, h, 0.5)
        r50s.append(r50)
        l2s.append(cmp_["relative_frobenius"])
        to_pre = np.abs(cells - pre).sum(axis=(0, 1)) / pre.sum(axis=(0, 1))
        rows.append(f"| {k} | {dt:.2f} | {_rgb(cmp_['relative_frobenius'])} | {_rgb(cmp_['relative_l1'])} | "
                    f"{_rgb(r50)} | {_rgb(axis_std(cells, h), '{:.2f}')} | {_rgb(w[:, n // 2] / w.sum(axis=1))} | "
                    f"{_rgb(to_pre)} |")
    closest = ", ".join(str(GUIDED_K[i]) for i in np.argmin(np.array(l2s), axis=0))
    rows.append(f"| Rd | | 0 | 0 | {_rgb(radius_at_fraction_2d(rd, h, 0.5))} | "
                f"{_rgb(axis_std(rd, h), '{:.2f}')} | | |")
    rows.append(f"| **closest k / trend** | | {closest} | | {_trend(r50s)} | | | |")
    return [f"### {prof.name} on the default grid ({n} x {n} cells of {h:.3f} mm)", "",
            "| k | time per channel [s] | kernel rel. L2 (R, G, B) | kernel rel. L1 | r50 [mm] | std of axis marginal [mm] "
            "| centre cell's share of a | L1 distance of A_s to A_p |", "|---:|---:|---|---|---|---|---|---|"] + rows + [""]


def burley_fits_on_signals(mat: str) -> str:
    """Xie A.1's three fits to the material's Burley profile, rendered: relative RMSE vs Burley's exact 2D convolution."""
    burley = profile_for_material(mat, "burley")
    specs = [f"burley_fit:{e}" for e in ERROR_FUNCTIONS]
    res = {s: evaluate(burley, s, specs, size=256, perceptual=False).results for s in GUIDED_SIGNALS}
    return "; ".join(f"{e}: " + ", ".join(f"{res[s]['burley_fit:' + e]['relative_rmse']:.3f}" for s in GUIDED_SIGNALS)
                     for e in ERROR_FUNCTIONS)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--photons", type=int, default=200_000)
    ap.add_argument("--out", default="docs/kernel-accuracy.md")
    args = ap.parse_args()
    lines = ["# Kernel accuracy: every method against the exact 2D convolution", "",
             f"Generated by `python docs/kernel_accuracy.py --photons {args.photons}` on {platform.machine()} "
             f"({time.strftime('%Y-%m-%d')}). Profiles: MCML Monte Carlo, {args.photons:,} photons per channel, "
             "supplement F grid. Signals 256 x 256 px; the radius holding 99.9% of the widest channel's energy "
             "spans 1/6 of the image. Cells: relative RMSE (linear) / mean LDR-FLIP. `conv` = 1D convolutions.", ""]
    claims: list[str] = []
    guided: list[str] = []
    fine: list[str] = []
    for mat in MATERIALS:
        prof = profile_for_material(mat, "montecarlo", photons=args.photons)
        res = {s: evaluate(prof, s, METHODS, size=256).results for s in SIGNALS}
        px = res["edge"]["svd:1"]["pixel_mm"]
        lines += [f"## {prof.name} ({px:.3f} mm/pixel)", "",
                  "| method | conv | " + " | ".join(SIGNALS) + " |", "|---|---:|" + "---:|" * len(SIGNALS)]
        for m in METHODS:
            cells = " | ".join(f"{res[s][m]['relative_rmse']:.2e} / {res[s][m]['flip']:.3f}" for s in SIGNALS)
            lines.append(f"| {m} | {res['edge'][m]['convolutions_1d']} | {cells} |")
        lines.append("")
        rel = {s: {m: res[s][m]["relative_rmse"] for m in METHODS} for s in SIGNALS}
        nonexact = ("edge-rotated", "disk", "texture")
        claims.append(f"- **{prof.name}**: pre-integrated on the axis-aligned edge: relative RMSE "
                      f"{rel['edge']['preintegrated']:.1e} (exact); on the rotated edge {rel['edge-rotated']['preintegrated']:.1e}.")
        h, n = evaluation_grid(prof, 256)
        gl, gst = guided_tables(prof, res, h, n)
        guided += gl
        fine += guided_fine_grid(prof)
        gk = [f"guided:{k}" for k in GUIDED_K]
        r50 = np.array([gst[m]["r50"] for m in gk])
        checks = {
            "rank-1 SVD worse than pre-integrated (all signals)": all(rel[s]["svd:1"] > rel[s]["preintegrated"] for s in SIGNALS),
            "pre-integrated beats 1 Gaussian at the same cost (all signals)": all(rel[s]["gaussians:1"] > rel[s]["preintegrated"] for s in SIGNALS),
            "SVD error falls with rank 1 > 2 > 3 > 6 (all signals)": all(
                rel[s]["svd:1"] > rel[s]["svd:2"] > rel[s]["svd:3"] > rel[s]["svd:6"] for s in SIGNALS),
            "SVD rank 3 (6 conv) beats 6 Gaussians (12 conv) on the disk (supplement B, Fig. S.5)": rel["disk"]["svd:3"] < rel["disk"]["gaussians:6"],
            "L1-renormalised rank-1 SVD beats plain rank-1 SVD (all signals)": all(rel[s]["svd_l1:1"] < rel[s]["svd:1"] for s in SIGNALS),
            "pre-integrated + rank-1 residual beats pre-integrated off the exact case": all(
                rel[s]["preintegrated_svd:1"] < rel[s]["preintegrated"] for s in nonexact),
            "guided k=2 within 2x of pre-integrated (texture; supplement Fig. S.3: 'a comparably good fit')":
                rel["texture"]["guided:2"] < 2 * rel["texture"]["preintegrated"],
        }
        for s in GUIDED_SIGNALS:
            errs = [rel[s][m] for m in gk]
            checks[f"guided k=2 the closest of k = 0..4 to the exact 2D convolution, {s} (Appendix A; "
                   f"closest: k = {GUIDED_K[int(np.argmin(errs))]})"] = int(np.argmin(errs)) == GUIDED_K.index(2)
        claims += [f"  - {'yes' if ok else '**no**'}: {text}" for text, ok in checks.items()]
        claims.append("  - guided r50 (radius holding 50% of the 2D energy) grows k = 0 < 2 < 4 (Appendix A: 'k = 0 "
                      "sharper, k = 4 smoother'): " + ", ".join(
                          f"{ch} {'yes' if r50[0, c] < r50[2, c] < r50[4, c] else '**no**'} "
                          f"({r50[0, c]:.3f}, {r50[2, c]:.3f}, {r50[4, c]:.3f} mm)" for c, ch in enumerate("RGB")))
        best = compare_error_functions(profile_for_material(mat, "burley"))
        claims.append(f"  - Burley-to-separable fit (Xie A.1), lowest 2D L2 error of the radial profile on the fitter's samples, "
                      f"per channel: {', '.join(best['best'])}; "
                      + "; ".join(f"{e}: falloff " + ", ".join(f"{f['params']['falloff']:.3f}" for f in fits)
                                  + " (rel. L2 " + ", ".join(f"{f['relative_l2']:.3f}" for f in fits) + ")"
                                  for e, fits in best["fits"].items()))
        claims.append("  - The same fits rendered (Burley profile, separable engine kernel vs Burley's exact 2D "
                      "convolution; relative RMSE on edge, disk, texture): " + burley_fits_on_signals(mat))
    lines += ["## The paper's claims, checked", ""] + claims + [""]
    lines += ["## Guided optimisation (Appendix A) against the exact 2D kernel", "",
              "Appendix A: \"k ≈ 2 yields the approximation of the actual diffusion kernel, while k = 0 provides a "
              "visually sharper variant and k = 4 a smoother approximation that models the far-range scattering of "
              "the diffusion profile more faithfully.\" Below: the guided kernels for k = 0..4 on each material's "
              "evaluation grid (the kernels of the image tables above). Errors: relative RMSE, PSNR and FLIP against "
              "the exact 2D convolution (signals edge, disk, texture); kernel rel. L2 / L1 = ||A_s - Rd|| / ||Rd|| "
              "over the exact cell integrals of Rd on the same grid (`Kernel.compare`). Widths: r50 / r90 = radius "
              "of the disk holding 50% / 90% of the kernel's 2D energy (each cell's value uniform over its area, the areas exact); std "
              "= standard deviation of the axis marginal sum_y A(x, y); FWHM of A(x, 0); far-range energy = the "
              "kernel's energy beyond the radius holding 90% of Rd's, divided by Rd's energy there. 'closest k' "
              "is per signal or per channel; 'trend in k' per channel: up = strictly increasing from k = 0 to 4, "
              "up= = non-decreasing with ties, no = not monotone.", ""] + guided
    lines += ["## Guided optimisation on a finer grid", "",
              "The same kernel-space measures on the default grid (201 cells spanning the 99.9% radius of the "
              "widest channel, 2.3x finer than the evaluation grid). The time is one kernel build / 3.", ""] + fine
    lines += [NOTES]
    with open(args.out, "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")
    print(args.out)


if __name__ == "__main__":
    main()
