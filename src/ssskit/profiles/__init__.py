"""Radial diffuse reflectance profiles R(r) and a registry of profile models.

``profile_for_material(material, model)`` gives an :class:`RGBProfile` for a material; the models
are ``dipole`` ([JMLH01]), ``burley`` (Xie 2020 Eq. 4-5), ``gaussians`` (Eq. S.1 fitted to the
material's dipole) and ``deon2007`` (the six-Gaussian skin preset of [dLE07], material-independent).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import ProfileError, SsskitError
from ..quantities import BURLEY_ALBEDO, check_choice
from ..materials import LayeredMaterial, Material, get_material
from ..registry import Registry
from .base import RadialProfile, RGBProfile
from .burley import (
    BURLEY_CONFIGURATIONS,
    BurleyProfile,
    burley_cdf,
    burley_d,
    burley_d_diffuse_transmission,
    burley_d_dmfp,
    burley_d_searchlight,
    burley_inverse_cdf,
)
from .dipole import DipoleProfile, fresnel_diffuse_reflectance
from .discretize import cell_integrals, grid_coordinates
from .montecarlo.config import DEFAULT_PHOTONS
from .domain import DOMAINS, check_domain
from .gaussians import (
    DEON2007_SKIN_VARIANCES,
    DEON2007_SKIN_WEIGHTS,
    GaussianSumProfile,
    fit_gaussian_sum,
)

ProfileFactory = Callable[..., RGBProfile]
MODELS: Registry[ProfileFactory] = Registry("profile model", ProfileError)


@MODELS.decorator("dipole")
def dipole_profile(material: Material) -> RGBProfile:
    """The [JMLH01] dipole for each channel of ``material``; valid for a relative index eta in [1, 2.5]
    and transport mean free paths in [1e-6, 1e6] mm (:mod:`ssskit.profiles.domain`)."""
    check_domain(material, DOMAINS["dipole"])
    r, g, b = (
        DipoleProfile(material.sigma_a[i], material.sigma_s[i], material.g[i], material.eta / material.eta_ambient)
        for i in range(3)
    )
    return RGBProfile((r, g, b), "dipole", material.name, {"material": material.to_dict()})


#: where Burley's A comes from for a material: MCML's total diffuse reflectance (default) or the dipole's
BURLEY_ALBEDO_SOURCES = ("montecarlo", "dipole")


@MODELS.decorator("burley")
def burley_profile(
    material: Material,
    configuration: str = "searchlight",
    albedo: tuple[float, float, float] | None = None,
    albedo_source: str = "montecarlo",
    photons: int = DEFAULT_PHOTONS,
) -> RGBProfile:
    """Burley's normalized diffusion (Xie 2020 Eq. 4) matched to ``material``.

    A defaults to the material's total diffuse reflectance from MCML (``albedo_source="montecarlo"``:
    all reflected light, the grid's and beyond, ``photons`` per channel, cached), or from the [JMLH01]
    dipole closed form (``"dipole"``; its albedo error against MCML is the dipole's, e.g. Skin1 green
    0.2273 vs 0.2093); ``albedo`` given explicitly wins. ell is the transport mean free path
    1 / sigma_t' (the volume mean free path for g = 0, as in all presets), turned into d by the chosen
    Eq. 5 configuration (default: searchlight, the normal-incidence set-up of the supplement's
    simulations).

    Valid domain (:mod:`ssskit.profiles.domain`): transport mean free paths in [1e-6, 1e6] mm, and
    the domain of the model A comes from (montecarlo's, or the dipole's).
    """
    source = check_choice("albedo source", albedo_source, BURLEY_ALBEDO_SOURCES, ProfileError)
    check_domain(material, DOMAINS["burley (A given)" if albedo is not None or source == "dipole" else "burley"])
    if albedo is not None:
        albedo = BURLEY_ALBEDO.check_rgb(albedo, "a given Burley albedo A", ProfileError)
        source = "given"
    elif source == "dipole":
        a_r, a_g, a_b = (float(v) for v in dipole_profile(material).total_rd())
        albedo = (a_r, a_g, a_b)
    else:
        from .montecarlo import MonteCarloProfile, montecarlo_rgb

        mc = montecarlo_rgb(material, photons=photons)
        totals = []
        for c in mc.channels:
            assert isinstance(c, MonteCarloProfile)  # montecarlo_rgb's channels, for the type checker
            totals.append(float(c.total_rd_with_overflow()))
        a_r, a_g, a_b = totals
        albedo = (a_r, a_g, a_b)
    ds = burley_d(albedo, material.mfp_reduced_mm, configuration)
    r, g, b = (BurleyProfile(albedo[i], float(ds[i])) for i in range(3))
    prov: dict[str, Any] = {"material": material.to_dict(), "configuration": configuration, "albedo_source": source}
    if source == "montecarlo":
        prov["photons"] = photons
    return RGBProfile((r, g, b), "burley", material.name, prov)


@MODELS.decorator("gaussians")
def gaussians_profile(material: Material, n: int = 6) -> RGBProfile:
    """A sum of ``n`` Gaussians (Eq. S.1) fitted to the material's dipole, L1-constrained (the dipole's
    valid domain, :mod:`ssskit.profiles.domain`)."""
    check_domain(material, DOMAINS["gaussians"])
    base = dipole_profile(material)
    r, g, b = (fit_gaussian_sum(c, n) for c in base.channels)
    return RGBProfile((r, g, b), "gaussians", material.name, {"material": material.to_dict(), "fit_to": "dipole"})


@MODELS.decorator("deon2007")
def deon2007_profile(material: None = None) -> RGBProfile:
    """The six-Gaussian skin profile of [dLE07]: a fixed preset, so it takes no material."""
    refuse_material("deon2007", material)
    r, g, b = (
        GaussianSumProfile([w[i] for w in DEON2007_SKIN_WEIGHTS], DEON2007_SKIN_VARIANCES) for i in range(3)
    )
    return RGBProfile((r, g, b), "deon2007", "d'Eon 2007 skin", {"source": "[dLE07] six-Gaussian skin fit"})


@MODELS.decorator("montecarlo")
def montecarlo_profile(material: Material | LayeredMaterial, photons: int = DEFAULT_PHOTONS, seed: int = 1,
                       grid_fraction: float | None = None, roughness: float = 0.0, **options: Any) -> RGBProfile:
    """MCML-simulated profiles (supplement F grid; cached on disk). Needs numba.

    ``grid_fraction`` (e.g. 0.999): lengthen the grid of a channel until it holds that fraction of
    the reflected light. ``roughness`` > 0: a rough top surface of that Beckmann alpha (the
    path-traced references' boundary) instead of MCML's smooth one. Valid domain
    (:mod:`ssskit.profiles.domain`): eta in [1, 4] per layer, transport mean free paths in [1e-6, 1e6]
    mm, the longest at most 31 times the shortest. ``options`` go to :func:`ssskit.profiles.montecarlo.simulate_material`
    (threads, progress, resume, restart, use_cache, batch_size).
    """
    from .montecarlo import montecarlo_rgb

    # (its domain, scattering included, is checked before any photon: config_for_material's check_montecarlo)
    return montecarlo_rgb(material, photons=photons, seed=seed, grid_fraction=grid_fraction, roughness=roughness,
                          **options)


#: Models that take no material (fixed presets).
MATERIAL_FREE_MODELS = frozenset({"deon2007"})


def refuse_material(model: str, material: object, model_name: str = "", material_name: str = "material",
                    error: type[SsskitError] = ProfileError) -> None:
    """A material given to a model that takes none (:data:`MATERIAL_FREE_MODELS`, fixed presets) refused, the
    rule stated once for the API and every command (``model_name``, ``material_name``: how the caller names them,
    e.g. ``--model deon2007`` and ``--material``)."""
    if material is not None and model.strip().lower() in MATERIAL_FREE_MODELS:
        raise error(f"{model_name or f'the {model} model'} is a fixed preset and takes no {material_name} "
                    f"(got {getattr(material, 'name', material)!r})")


def check_model_domain(material: Material | LayeredMaterial | str, model: str) -> None:
    """Refuse a material outside ``model``'s valid domain (:mod:`ssskit.profiles.domain`) without
    computing anything: the check :func:`profile_for_material` makes, for callers that build the
    profile later (a render plans every input first)."""
    MODELS.get(model)  # an unknown model fails here with the list of models
    key = model.strip().lower()
    if key not in MATERIAL_FREE_MODELS:
        check_domain(_homogeneous_unless_montecarlo(get_material(material), key), DOMAINS[key])


def _check_options(factory: ProfileFactory, key: str, options: dict[str, Any]) -> None:
    """A ProfileError naming each keyword ``factory`` (the model ``key``'s) does not take, and those it takes."""
    import inspect

    from ..errors import check_keywords

    params = list(inspect.signature(factory).parameters.values())[1:]  # (the first is the material)
    if key == "montecarlo":  # its **options go to simulate_material
        from .montecarlo.sweep import simulate_material

        params += [p for p in inspect.signature(simulate_material).parameters.values() if p.kind is p.KEYWORD_ONLY]
    elif any(p.kind is p.VAR_KEYWORD for p in params):
        return  # (a model of one's own that takes any keyword)
    known = list(dict.fromkeys(p.name for p in params if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)))
    check_keywords(f"profile model {key!r}", options, known, ProfileError)


def profile_for_material(material: Material | LayeredMaterial | str | None, model: str = "dipole",
                         **options: Any) -> RGBProfile:
    """An :class:`RGBProfile` of ``model`` for a material (preset name, file path or Material).

    Models in :data:`MATERIAL_FREE_MODELS` take no material (``None``); the others need one.
    A layered material works with the montecarlo model only.
    """
    factory = MODELS.get(model)
    key = model.strip().lower()
    _check_options(factory, key, options)
    if key in MATERIAL_FREE_MODELS:  # (its factory refuses a material given: deon2007_profile)
        return factory(material, **options)
    if material is None:
        raise ProfileError(f"profile model {model!r} needs a material")
    return factory(_homogeneous_unless_montecarlo(get_material(material), key), **options)


def _homogeneous_unless_montecarlo(material: Material | LayeredMaterial, key: str) -> Any:
    """``material``, or a ProfileError for a layered material under a model other than montecarlo."""
    if isinstance(material, LayeredMaterial) and key != "montecarlo":
        raise ProfileError(f"layered material {material.name!r} is only supported by the montecarlo model")
    return material


__all__ = [
    "BURLEY_ALBEDO_SOURCES",
    "BURLEY_CONFIGURATIONS",
    "BurleyProfile",
    "DEON2007_SKIN_VARIANCES",
    "DEON2007_SKIN_WEIGHTS",
    "DipoleProfile",
    "GaussianSumProfile",
    "MATERIAL_FREE_MODELS",
    "refuse_material",
    "MODELS",
    "RGBProfile",
    "RadialProfile",
    "burley_cdf",
    "burley_d",
    "burley_d_diffuse_transmission",
    "burley_d_dmfp",
    "burley_d_searchlight",
    "burley_inverse_cdf",
    "burley_profile",
    "cell_integrals",
    "check_model_domain",
    "deon2007_profile",
    "dipole_profile",
    "fit_gaussian_sum",
    "fresnel_diffuse_reflectance",
    "gaussians_profile",
    "grid_coordinates",
    "montecarlo_profile",
    "profile_for_material",
]
