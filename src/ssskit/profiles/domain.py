"""Where each profile model is valid: the materials it can take, checked before any work, with a
message naming the model, the quantity, its range and the channel (docs/models.md lists them).

Shared by every model, transport mean free paths 1/sigma_t' (sigma_t' = sigma_a + sigma_s (1 - g))
in :data:`MFP_RANGE_MM`, 1 nm to 1 km: ssskit's lengths are millimetres and its profiles are sampled
on grids of a fraction of the shortest path up to tens of the longest, so outside that range the
arithmetic overflows or underflows (sigma = 1e300 or 1e-300 gave R(r) = NaN) long before the physics
of a translucent material is left. Per model (``eta``: the index relative to the outside):

* ``dipole`` and ``gaussians`` (fitted to the dipole): eta in [1, :data:`DIPOLE_ETA_MAX`]. [JMLH01]
  takes the diffuse Fresnel reflectance from the fit F_dr = -1.440/eta^2 + 0.710/eta + 0.668 + 0.0636
  eta (Egan and Hilgeman); against the exact hemispherical average of the Fresnel equations its
  boundary term A = (1 + F_dr) / (1 - F_dr) is within 0.33% for eta <= 2, 4.6% at 2.5, 26% at 3, and
  the fit passes 1 at eta = 3.85 (A < 0: total R_d of 6.7e60 at eta = 4, negative R(r) beyond).
  ``tests/profiles/test_domain.py`` integrates the Fresnel equations to check these numbers.
* ``montecarlo`` (MCML): eta in [1, :data:`OPTICAL_ETA_MAX`] per layer, and the supplement's grid
  (dr = min MFP / 20 out to 32 max MFP) at most :data:`MAX_GRID_BINS` bins, i.e. a longest mean free
  path at most 31 times the shortest over the channels and layers (Ketchup, the widest preset: 6.1).
  MCML's transport holds for any eta >= 1; beyond 4, which no optical medium reaches in the visible
  (water 1.33, glass 1.5, diamond 2.42, rutile 2.9), the critical angle is under 14.5 degrees and the
  photons spend their time in total internal reflection. A semi-infinite medium (the last layer) must
  absorb: sigma_a / sigma_t >= :data:`MIN_ABSORBED_FRACTION` per channel. Without absorption a photon
  in a half-space returns to the surface with probability 1 but after a number of steps with no finite
  mean (a random walk's return time), and MCML's roulette never starts (its weight never falls): a run of
  10^4 photons at sigma_a = 0 did not end; below about 1e-7 the float32 weight rounds the loss away and
  behaves the same. A finite slab needs no absorption (its photons leave through the far side).
* ``burley``: A (MCML's total R_d unless given: the montecarlo domain) in (0, 1] and d > 0 from Xie
  2020 Eq. 5, whose fits are stated for A in [0, 1]; A = 0 is refused like sigma_s = 0 below (Eq. 4's
  R(r) is 0: no subsurface light, and a kernel normalised by it is 0/0). Given in artists' terms (an
  albedo with a diffuse or volume mean free path: ``render --albedo --dmfp``, ``export --albedo --dmfp``,
  :class:`~ssskit.backends.burley_plan.BurleyParams`), the mean free path lies in :data:`MFP_RANGE_MM`
  and Burley's d in :data:`BURLEY_D_RANGE_MM`, what Eq. 5 gives from such paths: its scalings s(A) = ell / d
  lie in [0.906, 23.65] over A in [0, 1] (searchlight 1.85 - A + 7 |A - 0.8|^3 is least at A = 1, 0.906;
  dmfp 3.5 + 100 (A - 0.33)^4 largest at A = 1, 23.65).
* ``deon2007``: a fixed preset, no material.

Every model of a material needs it to scatter: sigma_s > 0 in every channel (for a layered material, in some
layer per channel). Without scattering there is no subsurface profile: the light that enters is absorbed or
leaves through the far side (R(r) = 0, so a kernel normalised by it is 0/0; a zero-albedo Burley fit, an
all-zero transmission fit).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from functools import partial
from typing import Any

from ..errors import ProfileError
from ..materials import CHANNELS, LayeredMaterial, Material
from ..quantities import ETA, MFP_MM, Quantity

#: transport mean free paths 1/sigma_t' every model takes (mm): :data:`ssskit.quantities.MFP_MM`
MFP_RANGE_MM = (MFP_MM.lo, MFP_MM.hi)
#: Xie 2020 Eq. 5's scalings s(A) = ell / d over A in [0, 1], all three configurations (module docstring)
BURLEY_EQ5_SCALING_RANGE = (0.906, 3.5 + 100.0 * 0.67**4)
#: Burley's d (mm) that Eq. 5 gives from mean free paths in MFP_RANGE_MM (module docstring)
BURLEY_D_RANGE_MM = (MFP_RANGE_MM[0] / BURLEY_EQ5_SCALING_RANGE[1], MFP_RANGE_MM[1] / BURLEY_EQ5_SCALING_RANGE[0])
#: Burley's length d as a quantity: the range above, and why
BURLEY_D = Quantity("Burley length d", *BURLEY_D_RANGE_MM, "mm", "what Xie 2020 Eq. 5 gives from the mean free paths "
                    "in [1e-06, 1e+06] mm every model takes, docs/models.md")
#: the largest relative index of the [JMLH01] dipole's F_dr fit (its A within 5% of the exact one)
DIPOLE_ETA_MAX = 2.5
#: the largest relative index the Monte Carlo model takes (no optical medium in the visible beyond it)
OPTICAL_ETA_MAX = 4.0
#: the most radial bins of the supplement's Monte Carlo grid (its tallies hold one row per batch)
MAX_GRID_BINS = 20_000
#: the smallest absorbed fraction sigma_a / sigma_t per interaction the Monte Carlo model takes in a semi-infinite
#: medium (module docstring): 1e-7, about the float32 rounding of a photon's weight (2^-23 = 1.2e-7 relative).
#: Measured (numba engine, sigma_s = 1 mm^-1, 10^4 photons per channel, 2026-12-05): 1e-6 in 2.3 s, 3e-7 in 4.1 s,
#: 1e-7 in 9 s (10^7 photons: hours, which the progress line's estimate says); 1e-14, like 0, did not end in 60 s
MIN_ABSORBED_FRACTION = 1e-7

#: the per-model physics above as quantities: a scattering coefficient (every model of a material), the grid of
#: MCML's supplement F and the absorbed fraction of its semi-infinite medium (module docstring)
SCATTERING = Quantity("sigma_s", 0.0, math.inf, "mm^-1", "a scattering material: without scattering there is no "
                      "subsurface profile, the light is absorbed or leaves through the far side", lo_open=True,
                      hi_open=True)
GRID_BINS = Quantity("grid", 2, MAX_GRID_BINS, "bins", "supplement F: dr = shortest mean free path / 20, out to 32 "
                     f"longest, so a longest path at most {MAX_GRID_BINS / 640:.3g} times the shortest; Ketchup, the "
                     "widest preset, 6.1", integer=True)
ABSORBED = Quantity("sigma_a / sigma_t", MIN_ABSORBED_FRACTION, 1.0, "", "a semi-infinite medium must absorb: without "
                    "it a photon's float32 weight loses nothing and a walk in a half-space has no finite mean length, "
                    "the run would not finish; or give a finite thickness_mm")

#: the relative index eta each model takes (module docstring): the dipole's (its F_dr fit), the Monte Carlo's
DIPOLE_ETA = ETA.within(1.0, DIPOLE_ETA_MAX, "its diffuse Fresnel fit F_dr of [JMLH01] is within 5% there and passes 1 "
                        "at eta = 3.85")
OPTICAL_ETA = ETA.within(1.0, OPTICAL_ETA_MAX, "no optical medium is denser in the visible; beyond it the photons are "
                         "trapped by total internal reflection")
#: the transport mean free path 1/sigma_t' every model takes (module docstring)
TRANSPORT_MFP = MFP_MM.within(reason=f"sigma_t' = sigma_a + sigma_s (1 - g), mm^-1; {MFP_MM.reason}")


def _layers(material: Material | LayeredMaterial) -> tuple[Material, ...]:
    return tuple(material.layers) if isinstance(material, LayeredMaterial) else (material,)


def check_mfp(model: str, mfp_mm: Iterable[float], where: str = "") -> None:
    """Refuse transport mean free paths (R, G, B) outside :data:`MFP_RANGE_MM`, naming ``model`` and the channel."""
    for channel, v in zip(CHANNELS, mfp_mm):
        TRANSPORT_MFP.check(v, f"the {model} model's transport mean free path 1/sigma_t' in channel {channel}{where}",
                            ProfileError)


def check_scatters(model: str, material: Material | LayeredMaterial) -> None:
    """sigma_s > 0 in every channel (in some layer of a layered material): module docstring."""
    layers = _layers(material)
    for c, channel in enumerate(CHANNELS):
        if not any(float(layer.sigma_s[c]) > 0 for layer in layers):
            SCATTERING.refuse(0.0, f"the {model} model's sigma_s in channel {channel} of {material.name!r}", ProfileError)


def check_dipole(material: Material, model: str = "dipole") -> None:
    """The domain of the [JMLH01] dipole (and of what is fitted to it): module docstring."""
    check_scatters(model, material)
    check_mfp(model, material.mfp_reduced_mm)
    DIPOLE_ETA.check(material.eta / material.eta_ambient, f"the {model} model's relative index eta", ProfileError)


def check_montecarlo(material: Material | LayeredMaterial, model: str = "montecarlo") -> None:
    """The domain of the MCML model on the supplement's grid (a scattering material among it): module docstring."""
    check_scatters(model, material)
    layers = _layers(material)
    for k, layer in enumerate(layers):
        where = f" of layer {k + 1}" if len(layers) > 1 else ""
        check_mfp(model, layer.mfp_reduced_mm, where)
        OPTICAL_ETA.check(layer.eta, f"the {model} model's relative index eta", ProfileError)
    mfp = [v for layer in layers for v in layer.mfp_reduced_mm]
    ratio = max(mfp) / min(mfp)
    GRID_BINS.check(math.ceil(32.0 * 20.0 * ratio), f"the {model} model's grid (its longest transport mean free path "
                    f"{ratio:.3g} times the shortest)", ProfileError)
    last = layers[-1]
    if last.is_semi_infinite:
        where = " of the semi-infinite last layer" if len(layers) > 1 else ""
        for c, channel in enumerate(CHANNELS):
            a, t = float(last.sigma_a[c]), float(last.sigma_a[c]) + float(last.sigma_s[c])
            ABSORBED.check(a / t, f"the {model} model's sigma_a / sigma_t in channel {channel}{where} of "
                           f"{material.name!r}", ProfileError)


def check_burley_material(material: Material, albedo_given: bool) -> None:
    """The domain of Burley's profile matched to a material: its mean free paths, and the montecarlo
    domain where A comes from MCML (``albedo_given`` False)."""
    check_scatters("burley", material)
    check_mfp("burley", material.mfp_reduced_mm)
    if not albedo_given:
        check_montecarlo(material, "burley (A from MCML)")


#: each model's domain of a material, by the model's name (the montecarlo's, and the dipole's for what is fitted
#: to it): what :func:`ssskit.profiles.check_model_domain` checks before a profile is built
DOMAINS: dict[str, Callable[[Any], None]] = {
    "dipole": check_dipole, "gaussians": partial(check_dipole, model="gaussians (fitted to the dipole)"),
    "burley": partial(check_burley_material, albedo_given=False), "montecarlo": check_montecarlo}

__all__ = ["BURLEY_D", "DOMAINS", "BURLEY_D_RANGE_MM", "BURLEY_EQ5_SCALING_RANGE", "DIPOLE_ETA_MAX", "MAX_GRID_BINS", "MFP_RANGE_MM",
           "MIN_ABSORBED_FRACTION", "OPTICAL_ETA_MAX", "check_burley_material",
           "check_dipole", "check_mfp", "DIPOLE_ETA", "OPTICAL_ETA", "TRANSPORT_MFP", "check_montecarlo", "check_scatters"]
