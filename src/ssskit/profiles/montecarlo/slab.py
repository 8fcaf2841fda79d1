"""A medium of finite thickness: MCML's diffuse reflectance Rd(t) of a homogeneous slab of thickness t
against the semi-infinite medium's Rd(inf), per channel, with batch standard errors.

What a thin object loses: the screen-space model (paper Eq. 1 with the Monte Carlo
profile) is the semi-infinite medium's; a slab of thickness t lit from the front returns only
Rd(t) -- the rest of what the semi-infinite medium would return leaves through the back (MCML's Tt)
or is absorbed on the longer way. The slab is MCML's multi-layered geometry with one layer of finite
thickness (Wang, Jacques, Zheng 1995, section 2.1 and Fig. 1: the layer between z = 0 and z = t,
ambient media above and below; a photon crossing z = t is transmitted with the Fresnel probability of
Eqs. 3.13-3.16 at the bottom interface, and counted in Tt). Energy is conserved per photon:
Rsp + Rd + A + Tt = 1 (section 4.1; checked in tests/profiles).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ...errors import ProfileError
from ...materials import Material
from ...quantities import LENGTH_MM, THICKNESS_MM, TYPE, check_instance, check_shape, fail
from .config import MCConfig, config_for_material
from .result import MCResult
from .run import simulate

#: the thicknesses (mm) of :func:`thickness_table`'s default table: dense below the red diffusion
#: length of skin (1 / sigma_tr ~ 3.7 mm for Skin1), sparse beyond it
DEFAULT_THICKNESSES_MM = (0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 8.0, 10.0, 14.0, 20.0)


def slab_config(material: Material, channel: int, thickness_mm: float, photons: int = 200_000, seed: int = 1,
                incidence_deg: float = 0.0) -> MCConfig:
    """The supplement's simulation of ``channel`` of a homogeneous ``material``
    (:func:`~ssskit.profiles.montecarlo.config_for_material`) with its one layer ``thickness_mm`` thick
    (``inf``: the semi-infinite medium), the ambient index (eta_ambient) above and below, lit at
    ``incidence_deg``."""
    check_instance(material, Material, "a slab's material (homogeneous)", ProfileError)
    THICKNESS_MM.check(thickness_mm, "slab thickness", ProfileError)
    cfg = config_for_material(material, channel, photons=photons, seed=seed)
    layer = dataclasses.replace(cfg.layers[0], thickness_mm=float(thickness_mm))
    return dataclasses.replace(cfg, layers=(layer,), incidence_deg=float(incidence_deg))


def thickness_grid(thicknesses: Sequence[float]) -> list[float]:
    """Slab thicknesses (mm): finite, positive and ascending, as floats; or a ProfileError."""
    ts = LENGTH_MM.check_array(check_shape(thicknesses, "thicknesses", ("T",), ProfileError), "thicknesses",
                               ProfileError).tolist()
    if not ts or any(b <= a for a, b in zip(ts, ts[1:])):
        raise fail(ProfileError, TYPE, name="thicknesses", kind="ascending (each thicker than the last)", actual=ts)
    return ts


def _ratio(a: float, a_se: float, b: float, b_se: float) -> tuple[float, float]:
    """a / b and its standard error for independent a, b (first-order error propagation)."""
    r = a / b
    return r, abs(r) * math.hypot(a_se / a if a else 0.0, b_se / b)


def thickness_table(material: Material, thicknesses: Sequence[float] = DEFAULT_THICKNESSES_MM,
                    photons: int = 200_000, seed: int = 1, incidence_deg: float = 0.0,
                    threads: int | None = None) -> dict[str, Any]:
    """Rd(t) / Rd(inf) per channel for each thickness t (mm, ascending) of ``material``'s slab
    (:func:`slab_config`), every simulation with ``photons`` photons and its own seed (seed + its
    index: the runs are independent, so the ratio's standard error is the quadrature of the two
    relative errors).

    Returns a JSON-ready dict: ``thickness_mm`` (T,), ``rd`` / ``rd_se`` / ``tt`` / ``tt_se`` /
    ``absorbed`` / ``absorbed_se`` (T, 3), ``rsp`` (3,), ``rd_inf`` / ``rd_inf_se`` (3,) and ``ratio`` /
    ``ratio_se`` (T, 3) = Rd(t) / Rd(inf); cached per simulation (:func:`simulate`)."""
    ts = thickness_grid(thicknesses)
    out: dict[str, Any] = {"material": material.name, "photons": int(photons), "seed": int(seed),
                           "incidence_deg": float(incidence_deg), "thickness_mm": ts}
    keys = ("rd", "rd_se", "tt", "tt_se", "absorbed", "absorbed_se")
    rows = {k: np.zeros((len(ts), 3)) for k in keys}
    inf = np.zeros((2, 3))
    rsp = np.zeros(3)
    for c in range(3):
        res: MCResult = simulate(slab_config(material, c, math.inf, photons, seed, incidence_deg), threads=threads)
        inf[:, c] = res.total_rd, res.total_rd_se
        rsp[c] = res.rsp
        for i, t in enumerate(ts):
            r = simulate(slab_config(material, c, t, photons, seed + 1 + i, incidence_deg), threads=threads)
            for k in keys:
                rows[k][i, c] = getattr(r, "total_" + k if k.startswith("rd") else k)
    ratio = np.zeros((len(ts), 3))
    ratio_se = np.zeros((len(ts), 3))
    for i in range(len(ts)):
        for c in range(3):
            ratio[i, c], ratio_se[i, c] = _ratio(rows["rd"][i, c], rows["rd_se"][i, c], inf[0, c], inf[1, c])
    out.update({k: v.tolist() for k, v in rows.items()})
    out.update(rsp=rsp.tolist(), rd_inf=inf[0].tolist(), rd_inf_se=inf[1].tolist(), ratio=ratio.tolist(),
               ratio_se=ratio_se.tolist())
    return out


def interpolate_ratio(table: dict[str, Any], thickness_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) Rd(t) / Rd(inf) and its standard error at each thickness (N,) mm, linear in t between the
    table's entries, 0 at t = 0 (a vanishing slab returns nothing diffusely), and the last entry's
    value beyond the table (which should reach the semi-infinite limit). NaN thicknesses give NaN."""
    t = np.asarray(thickness_mm, dtype=float)
    ts = np.concatenate([[0.0], np.asarray(table["thickness_mm"], float)])
    ratio = np.vstack([np.zeros((1, 3)), np.asarray(table["ratio"], float)])
    se = np.vstack([np.zeros((1, 3)), np.asarray(table["ratio_se"], float)])
    f = np.stack([np.interp(t, ts, ratio[:, c]) for c in range(3)], axis=-1)
    f_se = np.stack([np.interp(t, ts, se[:, c]) for c in range(3)], axis=-1)
    bad = ~np.isfinite(t)
    f[bad] = np.nan
    f_se[bad] = np.nan
    return f, f_se


__all__ = ["DEFAULT_THICKNESSES_MM", "interpolate_ratio", "slab_config", "thickness_table"]
