"""Materials in artists' terms: (surface albedo, mean free path or diffuse mean free path per channel, eta, g)
to physical coefficients (sigma_a, sigma_s) -- and the fast Burley-fit alternative.

**The Monte Carlo inversion** (:func:`material_from_artist`, the physical one). A semi-infinite medium of
relative index eta under normal incidence has, in units of the transport mean free path 1/sigma_t'
(sigma_t' = sigma_a + sigma_s (1 - g)), a total diffuse reflectance Rd(alpha', eta) and a profile width
r50(alpha', eta) (the radius holding half the reflected light) that depend on the reduced albedo
alpha' = sigma_s (1 - g) / sigma_t' alone (the similarity relation, [JMLH01] Sec. 2; exact for g = 0, where
the table is computed). The table (``data/artist_table.json``, made by ``docs/artist_table.py`` with
ssskit's MCML engine, 4 seeds per entry, each value with its standard error) is inverted per channel:

1. alpha' from Rd(alpha', eta) = A (monotone; PCHIP in u = sqrt(1 - alpha'), eta interpolated linearly);
2. the length: with the **volume mean free path** l = 1 / sigma_t (``mfp``), sigma_t = 1 / l; with the
   **diffuse mean free path** l_d (``dmfp``, Christensen-Burley's convention that Unreal uses: Burley's
   d = l_d / (3.5 + 100 (A - 0.33)^4), Xie 2020 Eq. 5 Theta_3), the asked width is that d, and
   sigma_t' = d_fit(alpha', eta) / d with d_fit the table's Burley d fitted to the MCML profile (the fit
   every engine export makes, :func:`ssskit.export.fit_burley_channel`), so engine parameters read back,
   simulated and exported again return to themselves;
3. sigma_s = alpha sigma_t, sigma_a = (1 - alpha) sigma_t with alpha = alpha' / (1 - g + alpha' g).

**The Burley-fit inversion** (:func:`burley_from_artist`, fast, no coefficients): Burley's (A, d) directly,
d = l / (1.85 - A + 7 |A - 0.8|^3) for a volume mean free path (Xie 2020 Eq. 5 Theta_1, searchlight) or
d = l_d / (3.5 + 100 (A - 0.33)^4) for a diffuse mean free path (Theta_3).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MaterialError
from ..materials import Material
from ..quantities import ANISOTROPY, BURLEY_ALBEDO, ETA, MFP_MM, REFLECTANCE, Choice, checks, rgb

TABLE_PATH = Path(__file__).with_name("data") / "artist_table.json"
#: Burley's r50 / d: the inverse of Xie 2020 Eq. 20 at 1/2
BURLEY_R50_PER_D = 1.5522
DISTANCE_KINDS = ("mfp", "dmfp")


@dataclass(frozen=True)
class ArtistMaterial:
    """An artist's description: surface albedo A (0 < A <= 1), a length per channel (mm) of ``kind``
    (``mfp``: volume mean free path 1/sigma_t; ``dmfp``: diffuse mean free path, Burley's convention),
    relative index eta (>= 1) and anisotropy g (|g| < 1)."""

    name: str
    albedo: tuple[float, float, float]
    distance_mm: tuple[float, float, float]
    kind: str = "dmfp"
    eta: float = 1.3
    g: float = 0.0

    def __post_init__(self) -> None:
        check_artist(self.albedo, self.distance_mm, self.kind, self.eta, self.g)


@checks(MaterialError, albedo=(rgb(BURLEY_ALBEDO), "surface albedo"),
        kind=(Choice("distance kind", DISTANCE_KINDS), "distance kind"), eta=ETA, g=ANISOTROPY)
def check_artist(albedo: Any, distance_mm: Any, kind: str, eta: float, g: float) -> None:
    """The model's valid domain, naming the offending value: 0 < A <= 1 (Burley's albedo,
    :mod:`ssskit.profiles.domain`: A = 0 reflects no light beneath the surface), distance in the mean
    free paths every model takes (:data:`~ssskit.profiles.domain.MFP_RANGE_MM`), eta >= 1, |g| < 1,
    kind mfp or dmfp."""
    MFP_MM.check_rgb(distance_mm, f"the {kind} distance", MaterialError)


@lru_cache(maxsize=1)
def artist_table() -> dict[str, Any]:
    """The shipped MCML table (module docstring): {"eta": [...], "alpha_reduced": [...], "rd": [[...]],
    "rd_se", "r50", "r50_se" (per eta, per alpha'), "photons", "seed", ...}."""
    data: dict[str, Any] = json.loads(TABLE_PATH.read_text())
    return data


def _interp_eta(eta: float, key: str) -> np.ndarray:
    t = artist_table()
    etas = np.asarray(t["eta"], dtype=float)
    vals = np.asarray(t[key], dtype=float)
    ETA.within(etas[0], etas[-1], "the Monte Carlo table's range; docs/artist_table.py --eta extends it").check(
        eta, "eta", MaterialError)
    i = int(np.clip(np.searchsorted(etas, eta) - 1, 0, len(etas) - 2))
    w = (eta - etas[i]) / (etas[i + 1] - etas[i])
    out: np.ndarray = (1.0 - w) * vals[i] + w * vals[i + 1]
    return out


def reduced_albedo_for(rd: float, eta: float) -> float:
    """alpha' with Rd(alpha', eta) = rd (PCHIP in u = sqrt(1 - alpha') through the table)."""
    from scipy.interpolate import PchipInterpolator
    from scipy.optimize import brentq

    t = artist_table()
    ap = np.asarray(t["alpha_reduced"], dtype=float)
    table_rd = _interp_eta(eta, "rd")
    u = np.sqrt(1.0 - ap)
    order = np.argsort(u)
    f = PchipInterpolator(u[order], table_rd[order])
    lo, hi = float(np.min(table_rd)), float(np.max(table_rd))
    REFLECTANCE.within(lo, hi, f"what the Monte Carlo table reaches for eta {eta:g}; use the Burley-fit inversion "
                       "(--model burley)").check(rd, "surface albedo", MaterialError)
    uu = brentq(lambda x: float(f(x)) - rd, float(u.min()), float(u.max()), xtol=1e-12)
    return float(1.0 - uu * uu)


def _per_transport_mfp(alpha_reduced: float, eta: float, key: str) -> float:
    from scipy.interpolate import PchipInterpolator

    t = artist_table()
    u = np.sqrt(1.0 - np.asarray(t["alpha_reduced"], dtype=float))
    order = np.argsort(u)
    f = PchipInterpolator(u[order], np.log(_interp_eta(eta, key)[order]))
    return float(np.exp(f(math.sqrt(1.0 - alpha_reduced))))


def r50_per_transport_mfp(alpha_reduced: float, eta: float) -> float:
    """The table's r50 (in units of 1/sigma_t') at alpha' (PCHIP of ln r50 in u = sqrt(1 - alpha'))."""
    return _per_transport_mfp(alpha_reduced, eta, "r50")


def burley_d_per_transport_mfp(alpha_reduced: float, eta: float) -> float:
    """The table's Burley d (units of 1/sigma_t') fitted to the MCML profile at alpha' (as r50)."""
    return _per_transport_mfp(alpha_reduced, eta, "burley_d")


def material_from_artist(art: ArtistMaterial) -> Material:
    """The Monte Carlo inversion (module docstring): a :class:`Material` whose MCML profile has total
    reflectance A and, for ``dmfp``, a Burley fit of length l_d / (3.5 + 100 (A - 0.33)^4)."""
    sa, ss = [], []
    g = float(art.g)
    for a, length in zip(art.albedo, art.distance_mm):
        ap = reduced_albedo_for(a, art.eta)  # step 1
        alpha = ap / (1.0 - g + ap * g)  # alpha' = alpha (1 - g) / (1 - alpha g), solved for alpha
        if art.kind == "mfp":
            sigma_t = 1.0 / length  # step 2, volume mean free path
        else:
            d = length / (3.5 + 100.0 * (a - 0.33) ** 4)  # Xie 2020 Eq. 5 Theta_3
            sigma_t_red = _per_transport_mfp(ap, art.eta, "burley_d") / d
            sigma_t = sigma_t_red / (1.0 - alpha * g)  # sigma_t' = sigma_t (1 - alpha g)
        ss.append(alpha * sigma_t)
        sa.append((1.0 - alpha) * sigma_t)
    return Material(art.name, (sa[0], sa[1], sa[2]), (ss[0], ss[1], ss[2]), (g, g, g), float(art.eta),
                    source=f"artist terms ({art.kind}), Monte Carlo inversion (ssskit.profiles.artist)")


def predicted_r50_mm(material: Material) -> np.ndarray:
    """The r50 (mm) the table predicts for a material's channels (the width the inversion aimed at)."""
    out = []
    for ap, st in zip(material.albedo_reduced, material.sigma_t_reduced):
        out.append(r50_per_transport_mfp(ap, material.eta) / st)
    return np.array(out)


def burley_from_artist(art: ArtistMaterial) -> tuple[np.ndarray, np.ndarray]:
    """The Burley-fit inversion (module docstring): (A (3,), d (3,) mm)."""
    a = np.asarray(art.albedo, dtype=float)
    length = np.asarray(art.distance_mm, dtype=float)
    if art.kind == "mfp":
        return a, length / (1.85 - a + 7.0 * np.abs(a - 0.8) ** 3)  # Xie 2020 Eq. 5 Theta_1
    return a, length / (3.5 + 100.0 * (a - 0.33) ** 4)  # Theta_3


def r50_of_result(r_mm: np.ndarray, rd: np.ndarray, dr_mm: float, total: float) -> float:
    """The radius holding half of ``total`` (all reflected light, overflow included) from MCML's radial
    bins (Rd in mm^-2 at bin centres r_mm; energy per bin 2 pi r Rd dr, linear within a bin)."""
    energy = 2.0 * np.pi * r_mm * rd * dr_mm
    cum = np.concatenate([[0.0], np.cumsum(energy)])
    edges = np.arange(cum.size) * dr_mm
    k = int(np.searchsorted(cum, 0.5 * total))
    if k == 0 or k >= cum.size:
        raise MaterialError("the Monte Carlo grid holds less than half of the reflected light")
    return float(edges[k - 1] + (0.5 * total - cum[k - 1]) / (cum[k] - cum[k - 1]) * dr_mm)


def mcml_run(sigma_a: float, sigma_s: float, g: float, eta: float, photons: int, seed: int,
             use_cache: bool = False) -> Any:
    """The MCML result of :func:`mcml_rd_r50`'s run (an :class:`~ssskit.profiles.montecarlo.MCResult`)."""
    from .montecarlo import MCConfig, MCLayer, simulate

    st_red = sigma_a + sigma_s * (1.0 - g)
    length = 1.0 / math.sqrt(3.0 * max(sigma_a, 1e-12 * st_red) * st_red)
    nr = 500
    dr = (12.0 * length + 4.0 / st_red) / (nr - 1)
    cfg = MCConfig((MCLayer(sigma_a, sigma_s, g, eta),), dr_mm=dr, nr=nr, photons=photons, seed=seed)
    return simulate(cfg, use_cache=use_cache)


def mcml_rd_r50(sigma_a: float, sigma_s: float, g: float, eta: float, photons: int, seed: int,
                use_cache: bool = False) -> tuple[float, float, float]:
    """One MCML run of a semi-infinite medium (normal incidence): (total Rd with overflow, its standard
    error, r50 mm). The grid reaches 12 diffusion lengths 1/sigma_tr (sigma_tr = sqrt(3 sigma_a sigma_t'),
    [JMLH01]) plus 4 transport mean free paths, in 500 bins: the table's grid (``docs/artist_table.py``)."""
    res = mcml_run(sigma_a, sigma_s, g, eta, photons, seed, use_cache)
    return res.total_rd, res.total_rd_se, r50_of_result(res.r_mm, res.rd, res.config.dr_mm, res.total_rd)


__all__ = ["ArtistMaterial", "BURLEY_R50_PER_D", "DISTANCE_KINDS", "TABLE_PATH", "artist_table",
           "burley_d_per_transport_mfp", "burley_from_artist", "check_artist", "mcml_run", "material_from_artist", "mcml_rd_r50", "predicted_r50_mm", "r50_of_result",
           "r50_per_transport_mfp", "reduced_albedo_for"]
