"""Light through thin parts: the transmittance models a plan holds (:mod:`ssskit.backends.transmission_plan`
has the pass), and the light-space geometry that feeds it.

Models (one per profile id, :data:`~ssskit.backends.transmission_plan.MODELS`):

* ``mcml``: the material's own MCML slab transmittance, through the fit of
  :func:`ssskit.profiles.montecarlo.transmission.fit_transmission` (t in mm, scale 1, the cosine law at the
  back: wrap 0) of its scattered part T_s(t) = Tt(t) - T_ballistic(t) by default: the unscattered beam leaves
  along the light's own direction (the light source seen through the part), which a camera away from it never
  sees and a path tracer renders only there; ``part="total"`` keeps MCML's whole Tt (the model before). Its
  thickness is the one along the surface normal (the pass's step 2 with ``along_normal``): a slab lit at an
  angle transmits the light it scatters nearly as at normal incidence through its own thickness;
* ``jimenez2010``: Jimenez et al. 2010's skin transmittance [JWSG10] as their shader ships it ([Jim12],
  SeparableSSS.h, ``SSSSTransmittance``): T(d) = sum_i w_i exp(-d^2 / v_i) over d'Eon et al. 2007's six
  skin Gaussians (variances v_i in mm^2, RGB weights w_i; [dLE07]) with d = scale x thickness, scale =
  8.25 (1 - translucency) / sssWidth, and the back irradiance wrapped: saturate(0.3 + dot(L, -N)) (wrap 0.3).
  With ``scale`` = 1 the thickness is in mm, the unit of d'Eon's variances;
* ``unreal``: Unreal Engine 5's subsurface-profile transmission as the engine computes it ([UE58]):
  the profile table of ``ComputeTransmissionProfileBurley`` (BurleyNormalizedSSS.cpp, :func:`unreal_profile_table`),
  read at the optical depth of ``CalculateOpticalDepth`` (TransmissionThickness.ush) through the shadow mask's
  encoding (:mod:`ssskit.backends.transmission_plan` step 4), no cosine at the back (wrap 2; UE's
  ``SubsurfaceProfileBxDF`` has none), the light scaled per pixel by UE's phase function
  (:func:`unreal_phase`, applied by the pipeline) and the exit multiplied by the base colour (UE's
  recombine pass), not Lambertian.

Light-space geometry (:class:`LightView`): an orthographic view for a directional light (a translucency
shadow map of Jimenez 2010, Sec. 3): world point P -> texel coordinates (x, y) and depth z along the light
(mm); :meth:`LightView.depth_map` renders the map of a set of surface points (the first surface the light
meets per texel), and :func:`thickness_from_map` evaluates step 1-2 of the pass for given points, for the
measurement of the map's thickness against the ray-cast chord.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from numbers import Real
from typing import TYPE_CHECKING, Any

import numpy as np

from ..backends.plan import Array, check_arrays
from ..backends.spread_plan import SlotSpread
from ..backends.transmission_plan import LUT_SIZE, UE_MAX_OPTICAL_DEPTH, SlotModel, TransmissionPlan, build_transmission_plan
from ..errors import PassError, SsskitError
from ..materials import Material
from ..quantities import LENGTH_MM, Quantity, check_choice, check_fields, check_keys, check_shape, checks
from ..profiles.gaussians import DEON2007_SKIN_VARIANCES, DEON2007_SKIN_WEIGHTS

if TYPE_CHECKING:
    from ..profiles.montecarlo.transmission import TransmissionTable

#: Jimenez 2010's wrap of the back irradiance (SeparableSSS.h: saturate(0.3 + dot(light, -normal)))
JIMENEZ2010_WRAP = 0.3
#: UE's positive scales (WorldUnitScale, DistanceScale, ExtinctionScale) and its non-negative factors (a tint
#: channel, NormalScale); Jimenez 2010's translucency (1 would scale the thickness to 0)
UE_SCALE = Quantity("scale", 0.0, math.inf, "", "a positive scale", lo_open=True, hi_open=True)
TINT = Quantity("tint", 0.0, math.inf, "", "a non-negative factor", hi_open=True)
TRANSLUCENCY = Quantity("translucency", 0.0, 1.0, "", "1 would pass all light through", hi_open=True)
_UNREAL = {"ExtinctionScale": UE_SCALE, "NormalScale": TINT}  # unreal_model's factors
#: unreal_profile_table's arrays: the Burley d (mm) and UE's tint per channel
_UNREAL_ARRAYS = {"d_mm": Array((3,), "the Burley d", dtype=np.float64, values=LENGTH_MM),
                  "tint": Array((3,), "TransmissionTintColor", dtype=np.float64, values=TINT)}


@checks(PassError, translucency=TRANSLUCENCY, sss_width_mm=(LENGTH_MM, "the SSS width"))
def jimenez2010_model(translucency: float = 0.0, sss_width_mm: float | None = None) -> SlotModel:
    """Jimenez et al. 2010's skin transmittance (module docstring): scale 8.25 (1 - translucency) /
    sss_width_mm, or 1 (thickness in mm) when ``sss_width_mm`` is None."""
    if sss_width_mm is None:
        scale = 1.0
    else:
        scale = 8.25 * (1.0 - translucency) / sss_width_mm
    w = np.asarray(DEON2007_SKIN_WEIGHTS, float).T  # (3, 6)
    v = np.asarray(DEON2007_SKIN_VARIANCES, float)
    return SlotModel(w, np.zeros_like(w), np.broadcast_to(1.0 / v, w.shape).copy(), scale, JIMENEZ2010_WRAP,
                     "jimenez2010")


@lru_cache(maxsize=32)
def _mcml_table(material: Material, photons: int, seed: int) -> TransmissionTable:
    from ..profiles.montecarlo.transmission import transmission_table

    return transmission_table(material, photons=photons, seed=seed)


@lru_cache(maxsize=32)
def _mcml_fit(material: Material, photons: int, seed: int, terms: int | None,
              part: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    from ..profiles.montecarlo.transmission import fit_transmission

    fit = fit_transmission(_mcml_table(material, photons, seed), terms=terms, part=part)
    return fit.amplitudes, fit.rates_per_mm, fit.gauss_per_mm2


def mcml_model(material: Material, photons: int = 200_000, seed: int = 101, terms: int | None = None,
               part: str = "diffuse", along_normal: bool = True) -> SlotModel:
    """The material's MCML slab transmittance as a model (module docstring): the fit of its ``part`` (the
    scattered light by default, or MCML's whole Tt) with ``terms`` terms (the fit's default), at the thickness
    along the surface normal (``along_normal``, the default) or along the light; the table's simulations are
    cached on disk, the table and the fit in memory. A material that does not scatter has no scattered part
    (:func:`~ssskit.profiles.domain.check_scatters`, before any simulation)."""
    from ..profiles.domain import check_scatters

    check_scatters("mcml transmission", material)
    a, b, c = _mcml_fit(material, int(photons), int(seed), None if terms is None else int(terms), part)
    return SlotModel(a.copy(), b.copy(), c.copy(), 1.0, 0.0, "mcml", along_normal=along_normal)


def mcml_spread(material: Material, photons: int = 200_000, seed: int = 101) -> SlotSpread:
    """The lateral spread of the material's scattered transmitted light (:mod:`ssskit.backends.spread_plan`):
    the MCML table's widths (:attr:`~ssskit.profiles.montecarlo.transmission.TransmissionTable.spread_mm`) at its
    thicknesses; where a channel's is not resolved (its light below 3 SE, deep in the tail) it keeps the last
    resolved width."""
    from ..profiles.domain import check_scatters

    check_scatters("mcml transmission spread", material)
    tab = _mcml_table(material, int(photons), int(seed))
    assert tab.spread_mm is not None
    w = np.array(tab.spread_mm, float).T  # (3, N)
    for c in range(3):
        ok = np.isfinite(w[c])
        if not ok.any():
            raise PassError(f"{material.name}: no resolved spread of the transmitted light in channel {c}")
        first = int(np.argmax(ok))
        w[c, :first] = w[c, first]
        for i in range(first + 1, w.shape[1]):
            if not np.isfinite(w[c, i]):
                w[c, i] = w[c, i - 1]
    return SlotSpread(np.asarray(tab.thickness_mm, float).copy(), w)


#: UE's ProfileRadiusOffset (BurleyNormalizedSSS.cpp), cm
UE_PROFILE_RADIUS_OFFSET_CM = 0.06
#: FSubsurfaceProfileStruct's transmission defaults (Classes/Engine/SubsurfaceProfile.h, UE 5.8)
UE_TRANSMISSION_DEFAULTS: dict[str, Any] = {"ExtinctionScale": 1.0, "NormalScale": 0.08, "ScatteringDistribution": 0.93, "IOR": 1.55,
                            "TransmissionTintColor": (1.0, 1.0, 1.0), "WorldUnitScale": 0.1, "DistanceScale": 1.0}


def unreal_profile_distances_mm(world_unit_scale: float = 0.1, distance_scale: float = 1.0) -> np.ndarray:
    """(LUT_SIZE,) the radii (mm) at which UE tabulates its transmission profile: r_i = (i / N 5 cm + 0.06 cm) 10
    mm/cm / u, u = WorldUnitScale DistanceScale / 0.1 ([UE58] BurleyNormalizedSSS.cpp, ComputeTransmissionProfileBurley,
    called with WorldUnitScale x DistanceScale by SubsurfaceProfile.cpp)."""
    for name, v in (("WorldUnitScale", world_unit_scale), ("DistanceScale", distance_scale),
                    ("WorldUnitScale x DistanceScale", world_unit_scale * distance_scale)):
        UE_SCALE.check(v, name, PassError)
    inv_unit = 0.1 / (world_unit_scale * distance_scale)
    i = np.arange(LUT_SIZE)
    return (i / LUT_SIZE * UE_MAX_OPTICAL_DEPTH + UE_PROFILE_RADIUS_OFFSET_CM) * 10.0 * inv_unit


def unreal_profile_table(d_mm: Any, tint: Any = (1.0, 1.0, 1.0), world_unit_scale: float = 0.1,
                         distance_scale: float = 1.0) -> np.ndarray:
    """(3, LUT_SIZE) UE's transmission profile table ([UE58] ComputeTransmissionProfileBurley): per channel
    tint_c (e^(-r / d_c) + 3 e^(-r / (3 d_c))) / 4 at the radii of :func:`unreal_profile_distances_mm`, the last
    entry black. UE writes it as 0.25 A (e^(-S r / L) + 3 e^(-S r / (3 L))) with A = 1 (UE 5.8: white; the base
    colour comes in the recombine pass), S = s_sl(SurfaceAlbedo) and L = DMFP = d s_sl (SubsurfaceScatteringMath.h),
    so S / L = 1 / d, the Burley profile's d (Christensen and Burley 2015, [CB15])."""
    d, w = check_arrays(_UNREAL_ARRAYS, {"d_mm": d_mm, "tint": tint}).values()
    r = unreal_profile_distances_mm(world_unit_scale, distance_scale)[None, :]
    table = w[:, None] * 0.25 * (np.exp(-r / d[:, None]) + 3.0 * np.exp(-r / (3.0 * d[:, None])))
    table[:, -1] = 0.0  # bMakeLastPixelBlack
    return np.asarray(table)


def unreal_model(d_mm: Any, tint: Any = (1.0, 1.0, 1.0), extinction_scale: float = 1.0, normal_scale: float = 0.08,
                 world_unit_scale: float = 0.1, distance_scale: float = 1.0) -> SlotModel:
    """UE 5's transmission of a subsurface profile with Burley ``d_mm`` (3,) as a pass model (module docstring):
    its profile table, od_per_mm = ExtinctionScale / 10 (the thickness in cm, UE's world unit), od_offset =
    NormalScale / 2 ([UE58] TransmissionThickness.ush, CalculateEncodedOpticalDepth), wrap 2 (no cosine).
    Defaults: FSubsurfaceProfileStruct's (:data:`UE_TRANSMISSION_DEFAULTS`)."""
    check_fields({"ExtinctionScale": extinction_scale, "NormalScale": normal_scale}, _UNREAL, error=PassError)
    table = unreal_profile_table(d_mm, tint, world_unit_scale, distance_scale)
    zero = np.zeros((3, 1))
    return SlotModel(zero, zero, zero, 1.0, 2.0, "unreal", lut=table, od_per_mm=extinction_scale / 10.0,
                     od_offset=normal_scale / 2.0)


def approximate_hg(cos_theta: Any, g: float) -> np.ndarray:
    """UE's ``ApproximateHG`` (ShadingModels.ush, [UE58]): 0.5 (1 - g^2) / max(1e-5, (1 - g cos)^2)."""
    c = np.asarray(cos_theta, float)
    return np.asarray(0.5 * (1.0 - g * g) / np.maximum(1e-5, (1.0 - g * c) ** 2))


def refract(i: np.ndarray, n: np.ndarray, eta: float) -> np.ndarray:
    """HLSL's ``refract(i, n, eta)`` on (..., 3) unit vectors: eta i - (eta (n . i) + sqrt(k)) n with k = 1 - eta^2
    (1 - (n . i)^2), the zero vector where k < 0 (total internal reflection)."""
    ni = np.sum(n * i, axis=-1, keepdims=True)
    k = 1.0 - eta * eta * (1.0 - ni * ni)
    out = eta * i - (eta * ni + np.sqrt(np.maximum(k, 0.0))) * n
    return np.asarray(np.where(k < 0, 0.0, out))


def unreal_phase(normal: np.ndarray, to_camera: np.ndarray, to_light: np.ndarray, g: float = 0.93,
                 ior: float = 1.55) -> np.ndarray:
    """(...,) UE's phase factor of the transmitted light ([UE58] ShadingModels.ush, SubsurfaceProfileBxDF):
    ApproximateHG(dot(-L, refract(V, -N, 1 / IOR)), ScatteringDistribution), with V (``to_camera``) and L
    (``to_light``) unit vectors from the surface point and N its unit normal, written as UE writes it."""
    r = refract(np.asarray(to_camera, float), -np.asarray(normal, float), 1.0 / ior)
    return approximate_hg(np.sum(-np.asarray(to_light, float) * r, axis=-1), g)


def transmission_plan(models: dict[int, SlotModel], bias_mm: float = 1e-3, *,
                      allow_empty: bool = False) -> TransmissionPlan:
    """:func:`~ssskit.backends.transmission_plan.build_transmission_plan` (re-exported for the pipeline)."""
    return build_transmission_plan(models, bias_mm, allow_empty=allow_empty)


UNIT_TOL = 1e-3
"""How far the light projection's axes may be from an orthonormal frame (|length - 1| and |dot|): a file's
frame written in float32 or rounded to 6 digits passes, a meaningless one (a zero or an unnormalised vector,
skewed axes) does not."""
#: the light frame's axes: unit lengths and pairwise dot products within UNIT_TOL (an orthonormal frame)
UNIT_LENGTH = Quantity("length", 1.0 - UNIT_TOL, 1.0 + UNIT_TOL, "", "a unit vector, within 1e-3")
ORTHOGONAL = Quantity("dot", -UNIT_TOL, UNIT_TOL, "", "orthogonal axes, within 1e-3")


def _is_number(x: Any) -> bool:
    return isinstance(x, Real) and not isinstance(x, bool)


def _is_integral(x: Any) -> bool:
    return _is_number(x) and math.isfinite(x) and float(x).is_integer()


def _three_finite(name: str, value: Any, error: type[SsskitError]) -> tuple[float, float, float]:
    """A projection field of 3 finite numbers [x, y, z] (a list, tuple or 1D array), or ``error`` naming it."""
    label = f"the light projection's {name!r}"
    x, y, z = check_shape(value, label, (3,), error, finite=True, dtype=float).tolist()
    return x, y, z


#: the light map's sides (texels)
MAP_SIDE = Quantity("size", 1, 2**31 - 1, "texels", "a light map's side [W, H]", integer=True)


@dataclass(frozen=True)
class LightView:
    """An orthographic light view: ``direction`` the unit vector the light travels along (from the light
    into the scene), ``origin`` a world point (mm) on the map's plane, (``u``, ``v``) the map's unit axes,
    ``texel_mm`` the texel size and ``size`` (W, H) the map's texels; texel (0, 0)'s corner at the origin
    minus half the map."""

    direction: tuple[float, float, float]
    origin: tuple[float, float, float]
    u: tuple[float, float, float]
    v: tuple[float, float, float]
    texel_mm: float
    size: tuple[int, int]

    @classmethod
    def looking_along(cls, direction: np.ndarray, centre: np.ndarray, extent_mm: float, resolution: int | tuple[int, int],
                      distance_mm: float = 1000.0) -> LightView:
        """A map of ``resolution`` texels (n: n x n; or (W, H)) whose shorter side covers ``extent_mm`` around
        ``centre``, the light placed ``distance_mm`` back along ``direction``."""
        d = np.asarray(direction, float)
        d = d / np.linalg.norm(d)
        up = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
        u = np.cross(up, d)
        u /= np.linalg.norm(u)
        v = np.cross(d, u)
        origin = np.asarray(centre, float) - distance_mm * d
        w, h = (resolution, resolution) if isinstance(resolution, int) else resolution
        def t3(a: np.ndarray) -> tuple[float, float, float]:
            return float(a[0]), float(a[1]), float(a[2])

        return cls(t3(d), t3(origin), t3(u), t3(v), float(extent_mm) / min(w, h), (int(w), int(h)))

    def to_dict(self) -> dict:
        """The JSON form (the G-buffer's ``ssskit_light`` header attribute)."""
        return {"type": "orthographic", "direction": list(self.direction), "origin": list(self.origin),
                "u": list(self.u), "v": list(self.v), "texel_mm": self.texel_mm, "size": list(self.size)}

    @classmethod
    def from_dict(cls, d: dict, error: type[SsskitError] = PassError) -> LightView:
        """:meth:`to_dict`'s form back, or ``error`` (a PassError; the G-buffer's reader: a GBufferError) naming the field that is wrong and its valid domain:
        ``direction``, ``u``, ``v`` 3 finite numbers each, unit vectors (|x| within :data:`UNIT_TOL` of 1) and
        mutually orthogonal (|dot| <= :data:`UNIT_TOL`: an orthonormal frame, what :meth:`looking_along` writes
        and what :meth:`project` assumes); ``origin`` 3 finite numbers; ``size`` 2 positive integers;
        ``texel_mm`` a finite number > 0; ``type`` (optional) orthographic."""
        check_keys(d, "the light projection", None, ("direction", "origin", "u", "v", "texel_mm", "size"), error)
        check_choice("the light projection's 'type'", d.get("type", "orthographic"), ("orthographic",), error)
        vecs = [_three_finite(k, d[k], error) for k in ("direction", "origin", "u", "v")]
        axes = {"direction": vecs[0], "u": vecs[2], "v": vecs[3]}
        for k, x in axes.items():
            UNIT_LENGTH.check(math.sqrt(sum(c * c for c in x)), f"the light projection's {k!r}: its length", error)
        for a, b in (("direction", "u"), ("direction", "v"), ("u", "v")):
            dot = sum(p * q for p, q in zip(axes[a], axes[b], strict=True))
            ORTHOGONAL.check(dot, f"the light projection's {a!r} . {b!r}", error)
        label = "the light projection's 'size'"
        size = d["size"].tolist() if isinstance(d["size"], np.ndarray) else d["size"]
        check_shape(size, label, (2,), error)
        w, h = (MAP_SIDE.check(int(x) if _is_integral(x) else x, label, error) for x in size)
        texel = LENGTH_MM.check(d["texel_mm"], "the light projection's 'texel_mm'", error)
        return cls(vecs[0], vecs[1], vecs[2], vecs[3], float(texel), (int(w), int(h)))

    def project(self, points: np.ndarray) -> np.ndarray:
        """(..., 3) world points (mm) -> (..., 3) (x, y) texel coordinates and z the depth along the light (mm)."""
        p = np.asarray(points, float) - np.asarray(self.origin)
        w, h = self.size
        x = p @ np.asarray(self.u) / self.texel_mm + 0.5 * w
        y = p @ np.asarray(self.v) / self.texel_mm + 0.5 * h
        return np.stack([x, y, p @ np.asarray(self.direction)], axis=-1)

    def texel_rays(self) -> tuple[np.ndarray, np.ndarray]:
        """(H, W, 3) origins and the direction of the rays through the texel centres (for a ray-cast map)."""
        w, h = self.size
        ys, xs = np.mgrid[0:h, 0:w].astype(float)
        o = (np.asarray(self.origin) + ((xs + 0.5 - 0.5 * w) * self.texel_mm)[..., None] * np.asarray(self.u)
             + ((ys + 0.5 - 0.5 * h) * self.texel_mm)[..., None] * np.asarray(self.v))
        return o, np.asarray(self.direction)


def thickness_from_map(view: LightView, shadow_mm: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(N,) thickness (mm) at world points (N, 3) from a light-space depth map: steps 1-2 of the pass
    (the oracle's bilinear lookup, NaN where the map has no finite texel around the point)."""
    from ..backends.numpy_backend import shadow_depth

    uvz = view.project(points)
    return np.asarray(uvz[..., 2] - shadow_depth(np.asarray(shadow_mm, float), uvz[..., 0], uvz[..., 1]))


__all__ = ["JIMENEZ2010_WRAP", "UE_TRANSMISSION_DEFAULTS", "LightView", "approximate_hg", "jimenez2010_model",
           "mcml_model", "mcml_spread", "refract", "thickness_from_map", "transmission_plan", "unreal_model",
           "unreal_phase", "unreal_profile_distances_mm", "unreal_profile_table"]
