"""Engine material parameters from an ssskit profile, their re-import, and the error of the round trip.

Every engine export starts from a source :class:`~ssskit.profiles.RGBProfile` (a material under a
profile model) and maps it onto the engine's own diffusion model:

* **Burley engines** (Unreal Burley, Unity HDRP, Blender Christensen-Burley) take Burley's
  normalized diffusion R(r) = A (e^{-r/d} + e^{-r/3d}) / (8 pi d r) (Xie 2020 Eq. 4). ssskit
  fits (A, d) per channel to the source (:func:`fit_burley`): A is the source's total diffuse
  reflectance (exact), d minimises the share of the energy put at a wrong radius (the error the
  table reports, below). For a Burley source the fit is exact.
* **Unreal's legacy separable profile** is the 2012 demo profile (5 Gaussians of d'Eon's skin fit,
  widened per channel by a falloff): its falloff is fitted to the source by Xie 2020 appendix A.1
  (:func:`ssskit.kernels.burley_fit.fit_burley_channel` with each error function, Eqs. 25-27; the
  fit with the least misplaced energy is kept).

Each engine's parameters are then the engine's own encoding of (A, d) or of the falloff, with the
formula and the engine source it comes from (``ENGINE_SOURCES``). :func:`reimport` reads the
parameters back into ssskit's Burley or Gaussian-sum model the way the engine interprets them, and
:func:`profile_error` measures the re-imported profile against the source: the fraction of the
reflected energy the engine puts at the wrong radius, relative L1 of the radial densities,
int |p_src - p_eng| dr / int p_src dr with p = 2 pi r R(r), and the total ratio.

Lengths: ssskit works in mm. Unreal's lengths are centimetres (MeanFreePathDistance, ScatterRadius),
Unity HDRP's scattering distance is in mm at its default world scale 1, Blender's radius x scale is
in scene units (metres at the default unit scale 1).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from ..errors import ProfileError
from ..registry import Registry
from ..quantities import check_shape

if TYPE_CHECKING:
    from ..profiles.base import RadialProfile, RGBProfile

#: the targets of a parameter export (one JSON file each); the error table adds unreal's two models
ENGINES = ("unreal", "unity", "blender")
#: rows of the error table: (engine, model)
ENGINE_MODELS = (("unreal", "burley"), ("unreal", "separable"), ("unity", "burley"), ("blender", "burley"))

ENGINE_SOURCES = {
    "unreal-burley": "Unreal Engine 5 SubsurfaceProfile.cpp CreateTexture (bEnableMeanFreePath: DMFP (mm) = "
                     "MFP * GetSearchLightDiffuseScalingFactor(A) / GetPerpendicularScalingFactor(A) * 10 / 0.6; "
                     "Bias clamps 0.009) and BurleyNormalizedSSSCommon.ush (D = DMFP / (3.5 + 100 (A - 0.33)^4), "
                     "Xie 2020 Eq. 5 Theta_3); the dmfp block: UE 4.25-4.27 (DMFP = MeanFreePathColor * "
                     "MeanFreePathDistance * 10)",
    "unreal-separable": "Unreal Engine SeparableSSS.cpp ComputeMirroredSSSKernel (the 2012 demo profile with "
                        "SubsurfaceColor as strength and FalloffColor as falloff) and SubsurfaceProfile.cpp (kernel "
                        "offsets in -3..3 times ScatterRadius / 3, SUBSURFACE_KERNEL_SIZE = 3; FalloffColor clamped "
                        "to >= 0.009)",
    "unity": "Unity HDRP DiffusionProfileSettings.cs (shapeParam S = 1 / (scatteringDistance * "
             "scatteringDistanceMultiplier), R = S (e^{-Sr} + e^{-Sr/3}) / (8 pi r), i.e. Burley with d = "
             "scatteringDistance * multiplier in mm at worldScale 1; filterRadius = the CDF inverse at 0.997 of "
             "the widest channel; ior clamped to [1, 2]; the albedo is the material's)",
    "blender": "Blender Cycles intern/cycles/kernel/closure/bssrdf.h bssrdf_setup_radius (Blender 3.0 through 4.2): "
               "d = radius / (4 pi) for CLOSURE_BSSRDF_BURLEY_ID, used as Burley's d by bssrdf_burley_eval and "
               "truncated at 16 d (BURLEY_TRUNCATE); radius = Subsurface Radius * Subsurface Scale in scene units; "
               "the BSSRDF weight is the base colour. Checked in Cycles (bpy 4.2) by ssskit.export.blender.render_slab",
}

LOST = {
    "unreal-burley": [
        "the profile's shape beyond Burley's two exponentials (the fit error of the table)",
        "WorldUnitScale is written as UE's default (0.1) and not derived: the mapping assumes lengths in UE's cm",
        "SurfaceAlbedo and MeanFreePathColor are clamped to >= 0.009 by the engine: ssskit applies the clamps "
        "and lists each one that fires under 'clamps'",
        "not run in Unreal: the mapping follows UE's source; the editor script is checked by Python's ast only",
    ],
    "unreal-separable": [
        "the shape: the fixed five-Gaussian skin profile, only widened per channel (the fit error of the table)",
        "the albedo: the profile is normalised; the total reflectance must come from the base colour",
        "the energy beyond the kernel's reach (+-3 falloff-scaled units with 25 taps, +-2 below 21), "
        "renormalised by the engine",
        "falloffs below 0.009 of the widest channel are clamped by the engine",
    ],
    "unity": [
        "the profile's shape beyond Burley's two exponentials (the fit error of the table)",
        "the albedo: HDRP's profile is normalised; the total reflectance is the material's base colour",
        "not run in Unity: the .asset is checked with a YAML parser against DiffusionProfileSettings.cs",
        "the tail beyond filterRadius (0.3% of the widest channel's energy)",
        "scatteringDistance is the serialised (linear) colour; HDRP's inspector shows it sRGB-encoded "
        "(scatteringDistance_inspector_srgb)",
    ],
    "blender": [
        "the profile's shape beyond Burley's two exponentials (the fit error of the table)",
        "Cycles truncates Burley at 16 d (0.36% of the energy); EEVEE uses its own screen-space approximation",
        "Subsurface IOR and Anisotropy act only in the Random Walk methods, not in Christensen-Burley",
        "the numbers are for subsurface_method BURLEY: Random Walk reads the radius as a mean free path and "
        "renders another plateau and width (docs/exports.md)",
        "Specular IOR Level is set to 0: a specular layer would take its share of the plateau",
    ],
}


# ------------------------------------------------------------------------------------------ fits


def _radial_grid(channel: RadialProfile, samples: int = 512, fraction: float = 0.999) -> np.ndarray:
    r_max = float(np.max(channel.radius_at_fraction(fraction)))
    if not (np.isfinite(r_max) and r_max > 0):
        raise ProfileError(f"cannot size a radial grid: the radius holding {fraction} of the energy is {r_max!r}")
    return (np.arange(samples) + 0.5) * (r_max / samples)


def _burley_density(r: np.ndarray, d: float) -> np.ndarray:
    """2 pi r R(r) / A for Burley (Xie 2020 Eq. 4): (e^{-r/d} + e^{-r/(3d)}) / (4 d)."""
    return (np.exp(-r / d) + np.exp(-r / (3.0 * d))) / (4.0 * d)


def _misplaced(channel: RadialProfile, density: Callable[[np.ndarray], np.ndarray]) -> float:
    """int |p_src - p| dr / int p_src dr on the source's grid, p = 2 pi r R(r) / A (a fraction of the energy)."""
    r = _radial_grid(channel, 4096)
    p = 2.0 * np.pi * r * channel.eval(r)
    p = p / np.sum(p)
    q = density(r)
    return float(np.sum(np.abs(p - q / np.sum(q))))


def fit_burley_channel(channel: RadialProfile) -> tuple[float, float]:
    """(A, d mm) of the Burley profile closest to one radial channel (module docstring).

    A = the channel's total diffuse reflectance (exact); d minimises the share of the energy put at a
    wrong radius, int |p_src - p_B| dr / int p_src dr with p = 2 pi r R(r) / A (the metric of
    :func:`profile_error`), by a bounded scalar search on ln d within a factor e^2 of the start d0 that
    matches the source's median radius r_50 (Burley's r_50 = 1.5522 d, the inverse of Xie 2020 Eq. 20).
    """
    from scipy.optimize import minimize_scalar

    from ..profiles.burley import burley_inverse_cdf

    a = float(channel.total_rd())
    if not (np.isfinite(a) and a > 0):
        raise ProfileError(f"cannot fit Burley to a profile whose total reflectance is {a!r}")
    d0 = float(channel.radius_at_fraction(0.5)) / float(burley_inverse_cdf(0.5, 1.0))
    x0 = math.log(d0)
    sol = minimize_scalar(lambda x: _misplaced(channel, lambda r: _burley_density(r, math.exp(x))),
                          bounds=(x0 - 2.0, x0 + 2.0), method="bounded", options={"xatol": 1e-7})
    return min(a, 1.0), float(math.exp(sol.x))


def fit_separable_channel(channel: RadialProfile) -> dict[str, Any]:
    """The demo profile's falloff fitted to one channel by Xie 2020 appendix A.1: each of the three error
    functions (Eqs. 25-27, :func:`ssskit.kernels.burley_fit.fit_burley_channel`), keeping the fit that
    puts the least energy at a wrong radius (the metric of :func:`profile_error`)."""
    from ..kernels.burley_fit import ERROR_FUNCTIONS, _mixture
    from ..kernels.burley_fit import fit_burley_channel as xie_fit

    best = None
    for error in ERROR_FUNCTIONS:
        fit = xie_fit(channel, "jimenez2012", error)
        w, sig = _mixture("jimenez2012", np.array([fit["params"]["falloff"]]))
        density = lambda r, w=w, sig=sig: np.sum(w * r[:, None] / sig**2 * np.exp(-r[:, None] ** 2 / (2 * sig**2)),  # noqa: E731
                                                 axis=1)
        fit["misplaced"] = _misplaced(channel, density)
        if best is None or fit["misplaced"] < best["misplaced"]:
            best = fit
    assert best is not None  # ERROR_FUNCTIONS is not empty
    return best


def fit_burley(profile: RGBProfile) -> tuple[np.ndarray, np.ndarray]:
    """Per channel (A (3,), d (3,) mm) of :func:`fit_burley_channel`; a Burley channel is taken as is."""
    from ..profiles.burley import BurleyProfile

    a, d = np.zeros(3), np.zeros(3)
    for c, ch in enumerate(profile.channels):
        if isinstance(ch, BurleyProfile):
            a[c], d[c] = ch.albedo, ch.d
        else:
            a[c], d[c] = fit_burley_channel(ch)
    return a, d


# --------------------------------------------------------------------------------- engine formulas


def burley_scaling_dmfp(albedo: Any) -> np.ndarray:
    """s(A) = 3.5 + 100 (A - 0.33)^4: d = dmfp / s (Xie 2020 Eq. 5 Theta_3; Unreal's scaling factor)."""
    a = np.asarray(albedo, dtype=float)
    return 3.5 + 100.0 * (a - 0.33) ** 4


def burley_scaling_diffuse_transmission(albedo: Any) -> np.ndarray:
    """s(A) = 1.9 - A + 3.5 (A - 0.8)^2 (Xie 2020 Eq. 5 Theta_2; Cycles' bssrdf_burley_fitting)."""
    a = np.asarray(albedo, dtype=float)
    return 1.9 - a + 3.5 * (a - 0.8) ** 2


#: Unreal's SUBSURFACE_KERNEL_SIZE: kernel offsets -3..3 map to -ScatterRadius..ScatterRadius
UNREAL_KERNEL_SIZE = 3.0
#: Unreal clamps FalloffColor and MeanFreePathColor to at least this (SubsurfaceProfile.cpp, Bias)
UNREAL_COLOR_BIAS = 0.009
UNREAL_DEFAULT_WORLD_UNIT_SCALE = 0.1
#: HDRP's filter radius holds this fraction of the widest channel's energy
UNITY_FILTER_CDF = 0.997


def _colour(values: Any) -> tuple[list[float], float]:
    """(colour with max 1, its scale): engines store a length colour as an LDR colour times a distance."""
    v = np.asarray(values, dtype=float)
    m = float(np.max(v))
    return (v / m).tolist(), m


def _eta(material: Any, eta: float | None) -> float | None:
    """The index to write: ``eta`` where given (artists' terms, an engine file's), else the material's, else None."""
    if eta is not None:
        return float(eta)
    return float(material.eta) if material is not None and hasattr(material, "eta") else None


def _unreal(profile: RGBProfile, material: Any, eta: float | None = None) -> dict[str, Any]:
    from .unreal import details_text, unreal_parameters

    a, d = fit_burley(profile)
    eta = _eta(material, eta)
    out = unreal_parameters(a, d, eta)
    out["details_panel"] = {form: details_text(out[form]) for form in ("mfp", "dmfp")}
    # legacy separable: Xie A.1 fit of the demo profile's falloff (mm) to the source, per channel
    fits = [fit_separable_channel(ch) for ch in profile.channels]
    width = np.array([0.001 + f["params"]["falloff"] for f in fits])  # r' = r / (0.001 + falloff)
    k = float(np.max(width)) / 1.001  # widest channel -> FalloffColor 1
    raw = width / k - 0.001
    falloff = np.maximum(raw, UNREAL_COLOR_BIAS)
    for c in np.nonzero(raw < UNREAL_COLOR_BIAS)[0]:
        out["clamps"].append(f"separable FalloffColor[{'RGB'[c]}] {raw[c]:.4g} -> 0.009 (UE clamp)")
    out["separable_ue4_only"] = {
        "unreal_versions": "UE 4 only: UE 5 converts a separable profile to Burley on load (UpgradeSeparableToBurley) "
                           "and never renders it as written",
        "bEnableBurley": False,
        "SubsurfaceColor": [1.0, 1.0, 1.0],
        "FalloffColor": falloff.tolist(),
        "ScatterRadius": UNREAL_KERNEL_SIZE * k / 10.0,
        "units": "ScatterRadius in cm: kernel offset o (mm of the demo profile) lands at o * ScatterRadius / 3",
        "formula": "falloff_c fitted by Xie A.1 (Eqs. 25-27, the best of the three); s = max_c(0.001 + falloff_c) / "
                   "1.001; FalloffColor_c = (0.001 + falloff_c) / s - 0.001; ScatterRadius = 3 s mm",
        "fit_error_function": [f["error"] for f in fits],
    }
    out["IOR"] = eta if eta is not None else 1.4
    return out


def _unity(profile: RGBProfile, material: Any, eta: float | None = None) -> dict[str, Any]:
    from ..profiles.burley import burley_inverse_cdf
    from .unity import srgb_encode

    a, d = fit_burley(profile)
    colour, mult = _colour(d)
    given = _eta(material, eta)
    ior = given if given is not None else 1.4
    return {
        "engine": "unity",
        "asset": "DiffusionProfileSettings (HDRP)",
        "scatteringDistance": colour,
        "scatteringDistance_inspector_srgb": srgb_encode(colour).tolist(),
        "scatteringDistanceMultiplier": mult,
        "worldScale": 1.0,
        "ior": min(max(ior, 1.0), 2.0),
        "filterRadius": float(burley_inverse_cdf(UNITY_FILTER_CDF, mult)),
        "base_color": a.tolist(),
        "units": "scatteringDistance * multiplier in mm (worldScale 1: one unit is one metre); filterRadius in mm; "
                 "scatteringDistance is stored linear, the inspector shows scatteringDistance_inspector_srgb (type "
                 "those into the colour picker's hex/0-1 fields)",
        "formula": "scatteringDistance_c * scatteringDistanceMultiplier = d_c; filterRadius = CDF^-1(0.997; max_c d_c)",
    }


def _blender(profile: RGBProfile, material: Any, eta: float | None = None, unit_m: float = 1.0) -> dict[str, Any]:
    from .blender import blender_parameters

    a, d = fit_burley(profile)
    eta = _eta(material, eta)
    g = float(np.mean(material.g)) if material is not None and hasattr(material, "g") else None
    return blender_parameters(a, d, eta, g, unit_m)


ENGINE_BUILDERS: Registry = Registry("engine", ProfileError)
ENGINE_BUILDERS.register("unreal", _unreal)
ENGINE_BUILDERS.register("unity", _unity)
ENGINE_BUILDERS.register("blender", _blender)


#: engines with transmission fields (:mod:`ssskit.export.transmission`)
TRANSMISSION_ENGINES = ("unreal", "unity")


def engine_parameters(profile: RGBProfile, engine: str, material: Any = None, transmission: Any = None,
                      eta: float | None = None) -> dict[str, Any]:
    """The engine's material parameters for ``profile`` (module docstring), with units, formulas,
    sources and what is lost. ``material`` (optional) gives the IOR and anisotropy, ``eta`` (optional) the IOR
    where there is no material (artists' terms, an engine file) or another one; ``transmission`` (optional,
    a :class:`~ssskit.profiles.montecarlo.transmission.TransmissionTable` of the material) adds Unreal's or
    HDRP's transmission fields fitted to it under ``"transmission"`` (:mod:`ssskit.export.transmission`)."""
    key = engine.strip().lower()
    params = ENGINE_BUILDERS.get(key)(profile, material, eta)
    if transmission is not None and key in TRANSMISSION_ENGINES:
        from .transmission import hdrp_transmission, unreal_transmission

        a, d = fit_burley(profile)
        params["transmission"] = (unreal_transmission(transmission, a, d) if key == "unreal"
                                  else hdrp_transmission(transmission, d))
        if key == "unreal":
            from .unreal import details_text

            params["details_panel"] = {form: details_text(params[form], params["transmission"])
                                       for form in ("mfp", "dmfp")}
    params["source_profile"] = {"model": profile.model, "name": profile.name}
    models = [m for e, m in ENGINE_MODELS if e == key]
    params["sources"] = {m: ENGINE_SOURCES[f"{key}-{m}" if key == "unreal" else key] for m in models}
    params["lost"] = {m: LOST[f"{key}-{m}" if key == "unreal" else key] for m in models}
    return params


# ------------------------------------------------------------------------------------------ re-import


def _rgb(channels: Any, model: str, name: str, prov: dict) -> RGBProfile:
    from ..profiles.base import RGBProfile

    return RGBProfile(tuple(channels), model, name, prov)


def _burley_rgb(a: Any, d: Any, name: str, engine: str) -> RGBProfile:
    from ..profiles.burley import BurleyProfile

    # no clamp here: Unreal's reader clamps SurfaceAlbedo as UE does; another engine's albedo outside Burley's
    # (0, 1] is refused (ssskit.export.readers); one (A, d) per channel (an empty scatteringDistance was an IndexError)
    a, d = check_shape(a, "the albedo", (3,)), check_shape(d, "Burley's d", (3,))
    return _rgb([BurleyProfile(float(a[c]), float(d[c])) for c in range(3)], "burley", name, {"engine": engine})


def reimport(params: dict[str, Any], model: str = "burley", albedo: Any = None) -> RGBProfile:
    """ssskit's profile of an engine export, read the way the engine reads it (module docstring).

    ``model``: ``burley`` or, for Unreal, ``separable``. Engines whose profile carries no albedo (Unity,
    Unreal separable) take it from the export's ``base_color`` (or ``albedo``, if given).
    Values pass through float32, as the engines store them.
    """
    f32 = lambda v: np.asarray(v, dtype=np.float32).astype(float)  # noqa: E731
    engine = params.get("engine")
    name = params.get("source_profile", {}).get("name", "export")
    base = f32(params["base_color"] if albedo is None else albedo)
    if engine == "unreal" and model in ("burley", "dmfp"):
        from .unreal import unreal_d_mm

        block = params["mfp" if model == "burley" else "dmfp"]
        a = np.clip(f32(block["SurfaceAlbedo"]), UNREAL_COLOR_BIAS, 1.0)
        return _burley_rgb(a, unreal_d_mm(block), name, f"unreal-{'mfp' if model == 'burley' else 'dmfp'}")
    if engine == "unreal" and model == "separable":
        from ..kernels.burley_fit import _mixture
        from ..profiles.gaussians import GaussianSumProfile

        p = params["separable_ue4_only"]
        k = float(f32(p["ScatterRadius"])) * 10.0 / UNREAL_KERNEL_SIZE  # mm per kernel unit
        falloff = np.maximum(f32(p["FalloffColor"]), UNREAL_COLOR_BIAS)
        chans = []
        for c in range(3):
            # o = r_mm / k and r' = o / (0.001 + falloff): the demo profile with falloff k (0.001 + f) - 0.001
            w, sig = _mixture("jimenez2012", np.array([k * (0.001 + falloff[c]) - 0.001]))
            chans.append(GaussianSumProfile((base[c] * w).tolist(), (sig**2).tolist()))
        return _rgb(chans, "gaussians", name, {"engine": "unreal-separable"})
    if engine == "unity" and model == "burley":
        d = f32(params["scatteringDistance"]) * f32(params["scatteringDistanceMultiplier"])
        return _burley_rgb(base, d, name, "unity")
    if engine == "blender" and model == "burley":
        from .blender import blender_d_mm

        return _burley_rgb(base, blender_d_mm(params), name, "blender")
    raise ProfileError(f"no {model!r} model in a {engine!r} export (known: "
                       f"{', '.join(f'{e}/{m}' for e, m in ENGINE_MODELS)})")


def profile_error(source: RGBProfile, imported: RGBProfile, samples: int = 4096, fraction: float = 0.999) -> dict[str, list[float]]:
    """Per channel: ``relative_l1`` = int |p_src - p_imp| dr / int p_src dr with p = 2 pi r R(r) on
    (0, r_fraction of the source] (the share of the energy put at a wrong radius), ``total_ratio`` =
    A_imp / A_src, and ``r50_ratio``, the ratio of the radii holding half the energy."""
    rel, tot, r50 = [], [], []
    for cs, ci in zip(source.channels, imported.channels):
        r = _radial_grid(cs, samples, fraction)
        ps = 2.0 * np.pi * r * cs.eval(r)
        pi_ = 2.0 * np.pi * r * ci.eval(r)
        rel.append(float(np.sum(np.abs(ps - pi_)) / np.sum(ps)))
        tot.append(float(ci.total_rd() / cs.total_rd()))
        r50.append(float(ci.radius_at_fraction(0.5) / cs.radius_at_fraction(0.5)))
    return {"relative_l1": rel, "total_ratio": tot, "r50_ratio": r50}


def slab_material(name: str, model: str, folder: str | Path) -> tuple[dict[str, Any], Path, np.ndarray, np.ndarray]:
    """A preset's Blender export for the slab renders: (the parameters, the script written in ``folder``, A,
    d in mm as Cycles reads the script) for the preset ``name`` through the profile ``model``."""
    from ..materials import get_material
    from ..profiles import profile_for_material
    from .blender import blender_d_mm, blender_script

    material = get_material(name)
    params = engine_parameters(profile_for_material(material, model), "blender", material)
    script = Path(folder) / f"{name}.py"
    script.write_text(blender_script(params, name))
    return params, script, np.array(params["base_color"]), blender_d_mm(params)


__all__ = ["ENGINES", "ENGINE_MODELS", "ENGINE_SOURCES", "LOST", "slab_material", "burley_scaling_diffuse_transmission",
           "burley_scaling_dmfp", "engine_parameters", "fit_burley", "fit_burley_channel", "profile_error", "reimport"]
