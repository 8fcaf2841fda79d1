"""Light through a slab: MCML's total transmittance T(t) of a homogeneous slab of thickness t, per channel,
with batch standard errors, over a thickness grid that reaches where T falls below a floor; and a compact
fit engines can evaluate, a sum of exponentials in t.

The slab is :func:`~ssskit.profiles.montecarlo.slab.slab_config`'s (MCML's one finite layer between two
ambient half-spaces, Wang, Jacques, Zheng 1995 [WJZ95], section 2.1), lit at normal incidence; T(t) is
MCML's Tt: every photon weight leaving through the bottom face, the unscattered (ballistic) part
included. Each (thickness, channel) is one cached :func:`~ssskit.profiles.montecarlo.simulate` run with
its own seed, so the table's entries are independent and their standard errors are the batch method's
(:mod:`.result`). The tables of the 11 measured materials at the defaults are shipped with the package
(:mod:`.shipped`): :func:`transmission_table` answers them without simulating when :func:`table_key` matches.

Two bounds hold for any slab, whatever its scattering, and are what the tests check the tables against
(independent of MCML's transport):

* every transmitted photon entered through the top face (weight 1 - R_sp) and travelled at least t inside,
  so with MCML's implicit absorption (weight x albedo per interaction, i.e. x exp(-sigma_a s) in
  expectation over a path of length s) T(t) <= (1 - R_sp) exp(-sigma_a t);
* the unscattered photons alone give T(t) >= T_ballistic(t) = (1 - R)^2 exp(-sigma_t t) / (1 - R^2
  exp(-2 sigma_t t)), the incoherent sum of the multiply reflected beam between two faces of normal
  Fresnel reflectance R = ((n - 1) / (n + 1))^2 ([BW99]: the thick-plate sum; for a pure absorber,
  sigma_s = 0, it is the exact answer with sigma_t = sigma_a: :func:`absorber_transmittance`).

What a camera sees of it (:attr:`TransmissionTable.diffuse`): the unscattered beam (the ballistic part,
:func:`absorber_transmittance` with sigma_t, exact in expectation for MCML's smooth faces) leaves along the
light's own direction: it is the light seen *through* the slab (the light source's image), which a camera
away from that direction never sees. The rest, T_s(t) = Tt(t) - T_ballistic(t), the light the medium
scattered, leaves in every direction: the transmittance pass's ``mcml`` model is its fit. MCML's Tt_r [WJZ95]
gives its lateral spread (:attr:`TransmissionTable.spread_mm`, the width of a Gaussian with the same median
radius as the scattered light's Tt(r), the unscattered beam taken out of the first annulus).

The fit (:func:`fit_transmission`): T(t) ~ sum_k a_k exp(-b_k t - c_k t^2), a_k, b_k, c_k >= 0, a sum of
exponentials each with a Gaussian factor. Its two limits are the published forms: with c = 0 the exponentials
of diffusion theory (the multipole model of a slab, Donner and Jensen 2005 [DJ05], a sum of
dipole pairs mirrored at both extrapolated boundaries, decays as exp(-sigma_tr t) for thick slabs; the
ballistic part as exp(-sigma_t t)); with b = 0 Jimenez et al. 2010's Gaussian sum in thickness [JWSG10]
(:mod:`ssskit.backends.transmission_plan`). A sum of exponentials alone is log-convex in t, but MCML's
T(t) of skin's green and blue is log-concave over the first millimetres (the ballistic beam gives way to
the diffuse light), which the Gaussian factors follow. The parameters are found by variable projection
(the amplitudes, linear, by non-negative least squares for each trial set of b, c), weighted by each
entry's error; the fit's error is reported in standard errors and relative terms. The scattered part
T_s(t) (``part="diffuse"``) is 0 at t = 0 and rises before it falls, which no sum of decreasing terms
follows: its fit is T_s(t) ~ sum_k a_k (exp(-b_k t - c_k t^2) - exp(-B t)), a_k >= 0, one shared B (0 at t =
0 by construction; as a sum of terms, the K above and one of amplitude -sum a_k, rate B), checked >= 0 on a
dense grid.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import ProfileError
from ...materials import Material
from ...quantities import Choice, Quantity, check_instance
from .config import MCConfig
from .result import MCResult
from .run import check_threads, simulate
from .slab import slab_config, thickness_grid

#: the transmittance a table runs down to, and what its fit of the scattered part may give
FLOOR = Quantity("floor", 0.0, 1.0, "", "a transmittance the table's thickest slab reaches", lo_open=True,
                 hi_open=True)
FIT = Quantity("fit", -1e-9, math.inf, "", "a transmittance; try another number of terms", hi_open=True)

#: T below which the table stops (the issue's "for skin, up to where T falls below 1e-4")
T_FLOOR = 1e-4

#: the candidate thicknesses (mm) of a table: dense below 1 mm (the ballistic part and thin skin), then
#: wider steps; a table stops at the first entry where every channel's T is below its floor. The last four let the
#: measured materials with the least absorption reach the floor (their shipped tables' red: Skimmilk's T = 4.8e-4
#: at 120 mm, 1.5e-4 at 140 mm, 3.2e-5 at 170 mm; Potato's 3.6e-4 and Chicken1's 2.3e-4 at 100 mm, below 1e-4 at
#: 120 mm)
GRID_MM = (0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 14.0, 17.0, 20.0,
           24.0, 28.0, 33.0, 38.0, 45.0, 52.0, 60.0, 70.0, 80.0, 100.0, 120.0, 140.0, 170.0, 200.0)

#: photons per simulation of a table (each entry: one run per channel)
DEFAULT_PHOTONS = 200_000
#: the base seed of a table (thickness i runs with seed ``DEFAULT_SEED + i``)
DEFAULT_SEED = 101
#: bump when what a table derives from its simulations changes (its fields, :func:`diffuse_spread`, the stopping
#: rule): part of :func:`table_key`, so the shipped tables (:mod:`.shipped`) of an older derivation are not used
TABLE_VERSION = 1

#: terms of the exponential fit of MCML's Tt, and of its scattered part (each with its share of the last
#: term's -sum a_k exp(-B t))
DEFAULT_TERMS = 4
DIFFUSE_TERMS = 3


def normal_fresnel(eta: float, eta_ambient: float = 1.0) -> float:
    """The normal-incidence Fresnel reflectance ((n1 - n2) / (n1 + n2))^2 ([BW99], Sec. 1.5, at normal incidence)."""
    return ((eta - eta_ambient) / (eta + eta_ambient)) ** 2


def absorber_transmittance(sigma_t: float | np.ndarray, thickness_mm: float | np.ndarray, eta: float,
                           eta_ambient: float = 1.0) -> np.ndarray:
    """T of a non-scattering slab at normal incidence: (1 - R)^2 e^(-tau) / (1 - R^2 e^(-2 tau)), tau =
    sigma_t t, R :func:`normal_fresnel` (the incoherent sum over the beam's round trips between the two
    faces; module docstring). For a scattering slab with sigma_t = sigma_a + sigma_s it is the ballistic
    part, a lower bound of T."""
    r = normal_fresnel(eta, eta_ambient)
    e = np.exp(-np.asarray(sigma_t, float) * np.asarray(thickness_mm, float))
    return np.asarray((1.0 - r) ** 2 * e / (1.0 - r * r * e * e))


@dataclass(frozen=True, eq=False)
class TransmissionTable:
    """MCML's T(t) of a material's slab: ``thickness_mm`` (N,) ascending; ``tt``, ``tt_se``, ``rd``,
    ``rd_se`` (N, 3) (transmittance and diffuse reflectance, fractions of the incident light); ``rsp``
    (3,) the specular reflectance at the top face; the simulations' ``photons`` and base ``seed``."""

    material: str
    thickness_mm: np.ndarray
    tt: np.ndarray
    tt_se: np.ndarray
    rd: np.ndarray
    rd_se: np.ndarray
    rsp: np.ndarray
    sigma_a: tuple[float, float, float]
    sigma_t: tuple[float, float, float]
    eta: float
    eta_ambient: float
    photons: int
    seed: int
    spread_mm: np.ndarray | None = None

    @property
    def ballistic(self) -> np.ndarray:
        """(N, 3) the unscattered beam's share of ``tt``: :func:`absorber_transmittance` with sigma_t (module
        docstring)."""
        return np.stack([absorber_transmittance(self.sigma_t[c], self.thickness_mm, self.eta, self.eta_ambient)
                         for c in range(3)], axis=-1)

    @property
    def diffuse(self) -> np.ndarray:
        """(N, 3) T_s = tt - ballistic: the light the slab scattered, what a camera away from the light's own
        direction sees (module docstring); its standard error is ``tt_se`` (the ballistic part is exact)."""
        return self.tt - self.ballistic

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            out[f.name] = v.tolist() if isinstance(v, np.ndarray) else (list(v) if isinstance(v, tuple) else v)
        return out

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> TransmissionTable:
        arrays = {"thickness_mm", "tt", "tt_se", "rd", "rd_se", "rsp", "spread_mm"}
        kw: dict[str, Any] = {}
        for f in dataclasses.fields(cls):
            v = d.get(f.name)
            if v is None:
                continue
            if f.name in arrays:
                kw[f.name] = np.asarray(v, float)
            elif f.name in ("sigma_a", "sigma_t"):
                kw[f.name] = tuple(float(x) for x in v)
            else:
                kw[f.name] = v
        return cls(**kw)


def check_table_request(material: Material, floor: float = T_FLOOR, grid: Sequence[float] = GRID_MM) -> list[float]:
    """The grid as floats, after the checks :func:`transmission_table` makes before simulating (a ProfileError for
    a request outside its domain: not homogeneous, a bad grid or floor, a material whose unscattered light alone
    stays above the floor at the grid's end); for a caller that does other work first too."""
    check_instance(material, Material, "a transmission table's material (homogeneous)", ProfileError)
    ts = thickness_grid(grid)
    FLOOR.check(floor, "the transmittance floor", ProfileError)
    # the unscattered part alone, a lower bound of T (absorber_transmittance), decides before any simulation
    # that the table cannot reach the floor within the grid
    ballistic = absorber_transmittance(np.asarray(material.sigma_t, float), ts[-1], material.eta, material.eta_ambient)
    if float(np.max(ballistic)) >= floor:
        need = -math.log(floor) / ts[-1]
        fix = ("extend the grid" if ts[-1] < GRID_MM[-1] else
               f"the transmission model's domain is sigma_t above about {need:.3g} /mm in every channel")
        raise ProfileError(f"{material.name}'s transmission table cannot reach its floor {floor:g}: the light crossing a "
                           f"{ts[-1]:g} mm slab unscattered alone is {float(np.max(ballistic)):.3g} (sigma_t "
                           f"{', '.join(f'{x:g}' for x in material.sigma_t)} /mm); {fix}")
    return ts


def table_runs(material: Material, photons: int = DEFAULT_PHOTONS, seed: int = DEFAULT_SEED,
               grid: Sequence[float] = GRID_MM) -> list[list[MCConfig]]:
    """The simulations a table may run: per thickness i of ``grid`` the three channels' slab configurations
    (:func:`~ssskit.profiles.montecarlo.slab.slab_config`, seed ``seed + i``); :func:`transmission_table` runs
    a prefix of them, up to the floor."""
    return [[slab_config(material, c, float(t), photons, seed + i) for c in range(3)] for i, t in enumerate(grid)]


def table_key(material: Material, photons: int = DEFAULT_PHOTONS, seed: int = DEFAULT_SEED, floor: float = T_FLOOR,
              grid: Sequence[float] = GRID_MM) -> str:
    """Every input of a table, hashed: the cache key (:meth:`~ssskit.profiles.montecarlo.MCConfig.key`: the
    material's coefficients, eta, the radial grid, photons, seed, batches and the engine version) of each
    simulation it may run (:func:`table_runs`), the floor and :data:`TABLE_VERSION`. The material's name is
    not an input: equal coefficients give the same table. A shipped table (:mod:`.shipped`) answers a request
    of the same key."""
    ts = check_table_request(material, floor, grid)
    runs = [cfg.key() for row in table_runs(material, photons, seed, ts) for cfg in row]
    text = json.dumps({"runs": runs, "floor": float(floor), "table_version": TABLE_VERSION}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def transmission_table(material: Material, photons: int = DEFAULT_PHOTONS, seed: int = DEFAULT_SEED,
                       floor: float = T_FLOOR, grid: Sequence[float] = GRID_MM,
                       threads: int | None = None, *, shipped: bool = True, resume: bool = False,
                       progress: bool | None = None) -> TransmissionTable:
    """T(t) of ``material``'s slab over ``grid`` (mm, ascending), stopping after the first thickness at
    which every channel's T is below ``floor`` (so the table reaches the floor; a ProfileError if the grid
    ends first). Thickness i, channel c runs with seed ``seed + i`` (the channel's stream is mixed in by
    :func:`~ssskit.profiles.montecarlo.config.config_for_material`); every run is cached by
    :func:`~ssskit.profiles.montecarlo.simulate` (``resume``: continue a run interrupted before; ``progress``:
    its progress bar, as there).

    A request the package ships (the 11 measured materials at the defaults, :func:`~.shipped.shipped_table`:
    the same :func:`table_key`) is answered from the shipped file without simulating, named after
    ``material``; ``shipped=False``, or a :func:`~.shipped.recompute` block (``ssskit demo --full``),
    simulates instead. The result does not depend on ``threads``."""
    ts = check_table_request(material, floor, grid)
    check_threads(threads)  # before any answer, the shipped one included
    if shipped:
        from .shipped import shipped_table

        found = shipped_table(table_key(material, photons, seed, floor, ts))
        if found is not None:
            return dataclasses.replace(TransmissionTable.from_dict(found), material=material.name)
    rows: dict[str, list[list[float]]] = {k: [] for k in ("tt", "tt_se", "rd", "rd_se", "spread")}
    rsp = np.zeros(3)
    used: list[float] = []
    for t, cfgs in zip(ts, table_runs(material, photons, seed, ts)):
        vals = {k: [0.0, 0.0, 0.0] for k in rows}
        for c, cfg in enumerate(cfgs):
            r = simulate(cfg, threads=threads, resume=resume, progress=progress,
                         label=f"{material.name} {t:g} mm {'RGB'[c]}")
            vals["tt"][c], vals["tt_se"][c] = r.tt, r.tt_se
            vals["rd"][c], vals["rd_se"][c] = r.total_rd, r.total_rd_se
            vals["spread"][c] = diffuse_spread(r, float(absorber_transmittance(material.sigma_t[c], t, material.eta,
                                                                                material.eta_ambient)))
            rsp[c] = r.rsp
        for k in rows:
            rows[k].append(vals[k])
        used.append(t)
        if max(vals["tt"]) < floor:
            break
    else:
        raise ProfileError(f"{material.name}'s transmittance is still {max(rows['tt'][-1]):.3g} at the grid's last "
                           f"thickness {ts[-1]:g} mm, above the floor {floor:g}: extend the grid")
    tt, tt_se, rd, rd_se, spread = (np.asarray(rows[k]) for k in ("tt", "tt_se", "rd", "rd_se", "spread"))
    return TransmissionTable(material.name, np.asarray(used), tt, tt_se, rd, rd_se, rsp,
                             material.sigma_a, material.sigma_t, float(material.eta),
                             float(material.eta_ambient), int(photons), int(seed), spread)


#: the width of a Gaussian (its sigma) over its median radius: a 2D Gaussian holds half its light within
#: sigma sqrt(2 ln 2)
GAUSS_MEDIAN = math.sqrt(2.0 * math.log(2.0))


def diffuse_spread(result: MCResult, ballistic: float) -> float:
    """The lateral spread of the scattered transmitted light of one slab run (normal incidence): sigma (mm) of
    the Gaussian with the same median radius as Tt(r) [WJZ95] less the unscattered beam ``ballistic`` (which
    leaves on the axis: the first annulus), r_50 / sqrt(2 ln 2); NaN where the scattered part is not resolved
    (below 3 SE) or the run has no Tt(r) tally. The median, not the second moment: light guided along a thin
    slab by total internal reflection gives Tt(r) a long tail (Skin1 at 0.05 mm: median 0.5 mm, rms radius
    2.2 mm) that a blur of the seen surface could not follow anyway."""
    if not result.has_transmitted_tallies:
        return math.nan
    w = result.tt_r * 2.0 * np.pi * result.r_mm * result.config.dr_mm
    w = np.append(w, result.tt_overflow)
    w[0] -= ballistic
    total = float(w.sum())
    if not total > 3.0 * result.tt_se:
        return math.nan
    edges = np.arange(w.shape[0] + 1) * result.config.dr_mm  # the overflow bin ends one bin past the grid
    cdf = np.concatenate([[0.0], np.cumsum(w)]) / total
    k = int(np.searchsorted(cdf, 0.5))
    lo, hi = cdf[k - 1], cdf[k]
    r50 = edges[k - 1] + (0.5 - lo) / (hi - lo) * (edges[k] - edges[k - 1]) if hi > lo else edges[k]
    return float(r50 / GAUSS_MEDIAN)


@dataclass(frozen=True, eq=False)
class TransmissionFit:
    """T(t) ~ sum_k a_k exp(-b_k t - c_k t^2) per channel (module docstring): ``amplitudes`` a, ``rates_per_mm``
    b and ``gauss_per_mm2`` c, each (3, K), b, c >= 0; a >= 0 for ``part`` "total" (MCML's Tt), and for
    "diffuse" (the scattered part T_s) but for the last term, whose amplitude is minus the others' sum (0 at t =
    0). The fit's errors on the table's resolved entries (T > 3 SE): ``max_se`` (3,) max |fit - T| / SE; on the
    precise ones (SE < 10 % of T) ``max_rel_error`` and ``rms_rel_error`` (3,) of |fit - T| / T; the
    thickness range it was fitted on."""

    material: str
    amplitudes: np.ndarray
    rates_per_mm: np.ndarray
    gauss_per_mm2: np.ndarray
    max_rel_error: np.ndarray
    rms_rel_error: np.ndarray
    max_se: np.ndarray
    fitted_mm: tuple[float, float]
    part: str = "total"

    def __call__(self, thickness_mm: float | np.ndarray) -> np.ndarray:
        """(..., 3) fitted T at the thicknesses (mm)."""
        t = np.asarray(thickness_mm, float)[..., None, None]
        return np.asarray(np.sum(self.amplitudes * np.exp(-self.rates_per_mm * t - self.gauss_per_mm2 * t * t), axis=-1))

    def to_dict(self) -> dict[str, Any]:
        return {"material": self.material, "form": "T(t) = sum_k a_k exp(-b_k t - c_k t^2), t in mm",
                "part": self.part, "amplitudes": self.amplitudes.tolist(), "rates_per_mm": self.rates_per_mm.tolist(),
                "gauss_per_mm2": self.gauss_per_mm2.tolist(),
                "max_rel_error": self.max_rel_error.tolist(), "rms_rel_error": self.rms_rel_error.tolist(),
                "max_se": self.max_se.tolist(), "fitted_mm": list(self.fitted_mm)}


#: the parts of MCML's transmittance a fit follows: Tt, or its scattered part T_s (module docstring)
PARTS = ("total", "diffuse")
#: exponential terms of a fit (module docstring)
FIT_TERMS = Quantity("terms", 1, 6, "", "exponential terms of a fit", integer=True)


def _fit_channel(t: np.ndarray, y: np.ndarray, se: np.ndarray, starts: Sequence[np.ndarray], terms: int,
                 rel_floor: float, diffuse: bool = False, gauss: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(a, b, c) of sum_k a_k exp(-b_k t - c_k t^2) minimising sum ((fit - y) / s)^2 with s = sqrt(se^2 +
    (rel_floor y)^2) (each entry's error, floored relative to it so that no precise entry dominates):
    variable projection, the amplitudes by non-negative least squares for each trial (b, c) (b = e^x, c =
    x'^2), from each start; the best. ``diffuse``: each basis function is exp(-b_k t - c_k t^2) - exp(-B t)
    with one more parameter B = e^x (the last of x), and the result has K + 1 terms, the last (-sum a, B, 0).
    ``gauss`` False: c = 0 (pure exponentials; the starts carry no c)."""
    from scipy.optimize import least_squares, nnls

    s = np.sqrt(se ** 2 + (rel_floor * y) ** 2)
    k = terms

    def basis(x: np.ndarray, tt: np.ndarray) -> np.ndarray:
        m = np.exp(-np.outer(tt, np.exp(x[:k])) - (np.outer(tt * tt, x[k:2 * k] ** 2) if gauss else 0.0))
        return m - np.exp(-np.exp(x[-1]) * tt)[:, None] if diffuse else m

    def amps(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        m = basis(x, t) / s[:, None]
        a, _ = nnls(m, y / s)
        return a, m @ a - y / s

    def residual(x: np.ndarray) -> np.ndarray:
        return amps(x)[1]

    best: tuple[float, np.ndarray] | None = None
    for x0 in starts:
        res = least_squares(residual, x0, method="trf", max_nfev=400 if diffuse else 300)
        cost = float(np.sum(res.fun ** 2))
        if best is None or cost < best[0]:
            best = (cost, res.x)
    assert best is not None
    x = best[1]
    a, _ = amps(x)
    b, c = np.exp(x[:k]), (x[k:2 * k] ** 2 if gauss else np.zeros(k))
    order = np.argsort(b)
    a, b, c = a[order], b[order], c[order]
    if diffuse:
        a, b, c = np.append(a, -a.sum()), np.append(b, np.exp(x[-1])), np.append(c, 0.0)
    return a, b, c


def _lowest(a: np.ndarray, b: np.ndarray, c: np.ndarray, t_max: float) -> float:
    """The fit's least value on [0, 2 t_max] (20,001 points)."""
    dense = np.linspace(0.0, 2.0 * t_max, 20_001)[:, None]
    return float(np.min(np.sum(a * np.exp(-b * dense - c * dense ** 2), axis=-1)))


def fit_transmission(table: TransmissionTable, terms: int | None = None, rel_floor: float = 0.01,
                     part: str = "total") -> TransmissionFit:
    """The fit of a table's ``part`` (:data:`PARTS`: MCML's Tt, or its scattered part T_s, ``table.diffuse``;
    module docstring), per channel on its entries with T > 3 SE, each weighted by its error sqrt(SE^2 +
    (rel_floor T)^2); ``terms`` (default 4 for the total, 3 + the one of -sum a for the scattered part; a channel
    with too few resolved entries for them takes as many as it can, one with none is 0: its light is below 3 SE
    at every thickness).
    Deterministic starts: rates spanning the channel's diffusion rate sigma_tr = sqrt(3 sigma_a sigma_t') (g =
    0) to a few times its extinction sigma_t, with small and moderate Gaussian terms (and B = 2 sigma_t). A
    scattered-part fit negative anywhere on [0, 2 x the table's last thickness] is a ProfileError."""
    part = Choice("part", PARTS).check(part, "the fit's part", ProfileError)
    diffuse = part == "diffuse"
    terms = FIT_TERMS.check((DIFFUSE_TERMS if diffuse else DEFAULT_TERMS) if terms is None else terms,
                            "the fit's terms", ProfileError)
    n_out = terms + 1 if diffuse else terms
    out = np.zeros((3, 3, n_out))
    errs = np.zeros((3, 3))
    lo, hi = math.inf, 0.0
    values = table.diffuse if diffuse else table.tt
    for c in range(3):
        y, se, t = values[:, c], table.tt_se[:, c], table.thickness_mm
        ok = (y > 0) & (y > 3 * se)
        # a channel with fewer resolved entries than the terms need takes fewer terms (each term costs two
        # parameters, the scattered part's beam one more): Ketchup's green, nearly a pure absorber, has three; a
        # channel with none resolved (its light below 3 SE at every thickness) is 0
        k_c = min(terms, (int(ok.sum()) - (1 if diffuse else 0)) // 2)
        if k_c < 1:
            errs[:, c] = (0.0, 0.0, float(np.max(np.abs(y) / np.maximum(se, 1e-300), initial=0.0)))
            continue
        sa, st = table.sigma_a[c], table.sigma_t[c]
        sig_tr = math.sqrt(3.0 * sa * st) if sa > 0 else 1.0 / float(t[ok].max())
        tail = [math.log(2.0 * st)] if diffuse else []
        starts = [np.r_[np.log(np.geomspace(f_lo * sig_tr, f_hi * max(st, sig_tr), k_c)), np.full(k_c, math.sqrt(c0)),
                        tail]
                  for f_lo, f_hi, c0 in ((0.9, 2.0, 1e-3), (0.5, 4.0, 0.03 * sig_tr), (0.95, 8.0, 1e-3))]
        a, b, g = _fit_channel(t[ok], y[ok], se[ok], starts, k_c, rel_floor, diffuse)
        if diffuse and k_c < terms and _lowest(a, b, g, float(t.max())) < -1e-9:
            # few entries: the Gaussian factors' extrapolation may dip below 0 beyond them (a term's e^(-c t^2)
            # falling under the beam's e^(-B t)); pure exponentials there
            a, b, g = _fit_channel(t[ok], y[ok], se[ok], [np.r_[x0[:k_c], x0[-1]] for x0 in starts], k_c, rel_floor,
                                   diffuse, gauss=False)
        n_c = len(a)  # k_c, or k_c + 1 for the scattered part; the rest of the row stays 0 (no light)
        out[0, c, :n_c], out[1, c, :n_c], out[2, c, :n_c] = a, b, g
        f = np.sum(a * np.exp(-b * t[ok, None] - g * t[ok, None] ** 2), axis=-1)
        rel = np.abs(f - y[ok]) / y[ok]
        precise = se[ok] < 0.1 * y[ok]
        errs[:, c] = (float(rel[precise].max(initial=0.0)),
                      math.sqrt(float(np.mean(rel[precise] ** 2))) if precise.any() else 0.0,
                      float(np.max(np.abs(f - y[ok]) / np.maximum(se[ok], 1e-300))))
        lo, hi = min(lo, float(t[ok].min())), max(hi, float(t[ok].max()))
        if diffuse:
            low = _lowest(a, b, g, float(t.max()))
            if low < -1e-9:  # (try another number of terms)
                FIT.refuse(low, f"{table.material}: channel {c}'s fit of the scattered transmittance", ProfileError)
    if lo > hi:  # no channel resolved anywhere
        lo = hi = 0.0
    return TransmissionFit(table.material, out[0], out[1], out[2], errs[0], errs[1], errs[2], (lo, hi), part)


__all__ = ["DEFAULT_PHOTONS", "DEFAULT_SEED", "DEFAULT_TERMS", "DIFFUSE_TERMS", "GAUSS_MEDIAN", "GRID_MM", "PARTS",
           "TABLE_VERSION", "T_FLOOR", "TransmissionFit", "TransmissionTable", "absorber_transmittance",
           "check_table_request", "diffuse_spread",
           "fit_transmission", "normal_fresnel", "table_key", "table_runs", "transmission_table"]
