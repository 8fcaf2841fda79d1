"""The transmittance pass: light entering the back of a thin part and leaving through the pixel, from a
translucency shadow map (Jimenez et al. 2010 [JWSG10], Sec. 3: the thickness a light sees is its own
depth map's distance between the first surface it meets and the shaded point).

Frame inputs (per camera pixel p, all pixel-aligned (H, W) unless noted):

* ``slots`` int32, the plan's profile slot (0 = no SSS: no transmission);
* ``light_uvz`` (H, W, 3): the pixel's surface point in the light's view, (x, y) in shadow-map texel
  coordinates (texel i covers [i, i + 1)) and z its depth along the light's axis in mm (the same
  measure as the map);
* ``shadow_mm`` (Hs, Ws): the light-space depth map in mm, the depth of the first surface the light
  meets (non-finite where it meets none);
* ``n_dot_l``: N . L with N the pixel's unit normal and L the unit direction towards the light;
* ``light_rgb`` (H, W, 3): the irradiance the light delivers at p on a surface facing it.

Per pixel p in slot s > 0 and channel c, the pass computes (every backend in this order):

1. D: the map's depth at (x, y), bilinear between the four texel centres around it (weights
   (1 - fx)(1 - fy) ... of the position x - 1/2, y - 1/2), texels off the map or non-finite left out and
   the others' weights renormalised; no texel with positive weight left: no transmission (0).
2. t = z - D, the chord through the medium along the light (mm). **Zero thickness** is no medium between
   the light and p: p is the first surface the light meets, lit directly (the reflectance pass has it), so
   t <= ``bias_mm`` (the map's depth precision) or a non-finite t gives 0. A slot whose ``normal`` is 1 then
   takes the thickness along the surface normal, t <- t clamp(-N . L, 0, 1) (a slab's, the back face parallel
   to the seen one): the light the medium scattered forgets its way in, and a slab lit at incidence theta
   transmits nearly what it transmits at normal incidence through its own thickness, not through the light's
   chord t / cos theta (MCML, docs/transmission.md "Against the path trace"); 0 keeps the chord (Jimenez et
   al. 2010's translucency shadow map as their shader uses it).
3. E_c = light_rgb_c clamp(wrap_s - N . L, 0, 1): the back surface's irradiance, its normal taken as the
   pixel's reversed (N . L of the back side is -N . L; ``wrap`` = 0 is the cosine law, Jimenez 2010's
   shader wraps it by 0.3, and ``wrap`` = 2 drops the cosine: E = light_rgb, as Unreal's transmission).
4. T_c(t) = sum_k a_sck exp(-b_sck u - c_sck u^2) with u = scale_s t: the slot's transmittance model,
   either the MCML fit of :mod:`ssskit.profiles.montecarlo.transmission` (scale 1) or Jimenez 2010's
   Gaussian sum (b = 0, c = 1 / v_k, scale = the effect's thickness scale); or, for a slot of model
   ``unreal`` (Unreal Engine 5's subsurface-profile transmission, [UE5]), a lookup in the slot's profile
   table L (3, ``LUT_SIZE``) of :func:`ssskit.screenspace.transmission.unreal_profile_table`:

   * the optical depth OD = clamp(od_per_mm_s t + od_offset_s, 0.15, 5) + 0.25 (UE's
     ``CalculateOpticalDepth``, TransmissionThickness.ush: thickness in cm times ExtinctionScale, plus
     NormalScale / 2; od_per_mm = ExtinctionScale / 10);
   * stored in the shadow mask as e = 1 - OD / 5 and squared there (``ApplyPCFOverBlurCorrection``,
     ShadowProjectionPixelShader.usf), read back as OD' = 5 (1 - e^2) (``DecodeOpticalDepthFromShadowMask``,
     TransmissionCommon.ush);
   * the texture's linear filter at x = OD' / 5 (``LUT_SIZE`` - 1) (``GetTransmissionProfile``): with
     i = min(floor(x), LUT_SIZE - 2) and f = x - i, T_c = (1 - f) L_c[i] + f L_c[i + 1].

   UE's shader averages OD over 31 Poisson taps of the map and shades with the profile at t = 0 too (its
   OD never drops below 0.4); here one bilinear depth (step 1) and step 2's zero thickness, as for every
   model.
5. out_c(p) = T_c(t) E_c, the light leaving p through the medium: added to the reflectance SSS result
   before the albedo multiply. out <= T(t) light_rgb always (E <= light_rgb).

Float32 backends differ from the float64 oracle by the rounding of steps 1 and 4 (a few ulps) and by
t = z - D, which carries the rounding of D (about one ulp of the depths, not of t) times |dT/dt|.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import PassError
from ..quantities import Choice, Quantity, check_fields
from .plan import LIGHT_VIEW, Array, check_arrays, check_plan_ids

#: the transmittance models a plan can hold (the MCML fit, Jimenez et al. 2010's skin Gaussians, Unreal Engine 5's
#: subsurface-profile transmission)
MODELS = ("mcml", "jimenez2010", "unreal")

#: how far |n_dot_l| may exceed 1 (the pass clamps it): the cosine of normals stored in half floats, whose length
#: is 1 only to about 1e-3, is still a cosine; a value beyond it is not one
N_DOT_L_TOLERANCE = 1e-2

#: the pass's quantities: a model's terms, factors and wrap (module docstring), the zero thickness of step 2, the
#: light's view of a pixel with SSS
TERM = Quantity("term", -math.inf, math.inf, "", "a fitted term's coefficient", lo_open=True, hi_open=True)
FACTOR = Quantity("scale", 0.0, math.inf, "", "a non-negative factor", hi_open=True)
LUT = Quantity("lut", 0.0, math.inf, "", "a profile table's transmittance", hi_open=True)
WRAP = Quantity("wrap", 0.0, 2.0, "", "the wrap of N . L (0: none)")
BIAS_MM = Quantity("bias_mm", 0.0, math.inf, "mm", "the zero thickness of step 2", hi_open=True)
SHADOW_MM = Quantity("shadow_mm", -math.inf, math.inf, "mm", "the light-space depth; +-inf marks a texel without "
                     "surface")
LIGHT_UVZ = Quantity("light_uvz", -math.inf, math.inf, "", "the light's view of a pixel", lo_open=True, hi_open=True)
N_DOT_L = Quantity("n_dot_l", -1.0 - N_DOT_L_TOLERANCE, 1.0 + N_DOT_L_TOLERANCE, "", "a cosine of rounded normals")
LIGHT_RGB = Quantity("light_rgb", 0.0, math.inf, "", "an irradiance", hi_open=True)

#: most terms of one slot's T(t)
MAX_TERMS = 8
TERMS = Quantity("terms", 0, MAX_TERMS, "", "terms of one slot's T(t)", integer=True)

#: entries of an ``unreal`` slot's profile table (UE's BSSS_TRANSMISSION_PROFILE_SIZE)
LUT_SIZE = 32

#: the largest optical depth of UE's transmission table (SSSS_MAX_TRANSMISSION_PROFILE_DISTANCE)
UE_MAX_OPTICAL_DEPTH = 5.0

#: a :class:`SlotModel`'s numbers and arrays: the model's name picks the pass's branch, its terms (3, K) share one
#: K (a term may subtract, the MCML model's scattered part is 0 at t = 0: a is any finite number)
MODEL_FIELDS: dict[str, Quantity | Choice] = {
    "model": Choice("model", MODELS), "scale": FACTOR, "wrap": WRAP,
    "od_per_mm": FACTOR.within(reason="an optical depth per mm", lo=0.0), "od_offset": FACTOR}
MODEL_ARRAYS = {"a": Array((3, "K"), "a", values=TERM), "b": Array((3, "K"), "b", values=TERM.within(lo=0.0)),
                "c": Array((3, "K"), "c", values=TERM.within(lo=0.0)),
                "lut": Array((3, LUT_SIZE), "the unreal profile table", values=LUT, optional=True)}
#: the pass's frame (module docstring): the light's view; on every pixel with SSS (the only ones the pass reads)
#: ``light_uvz`` finite, ``n_dot_l`` finite in [-1, 1] (within :data:`N_DOT_L_TOLERANCE`: a cosine of rounded
#: normals) and ``light_rgb`` finite and >= 0; ``shadow_mm`` without NaN (+-inf: no surface, the spec's
#: non-finite sentinel). Real array-likes are accepted (the backend converts them).
TRANSMISSION_FRAME = {
    **LIGHT_VIEW, "light_uvz": replace(LIGHT_VIEW["light_uvz"], values=LIGHT_UVZ, elements="pixels with SSS", sss=True),
    "shadow_mm": replace(LIGHT_VIEW["shadow_mm"], values=SHADOW_MM),
    "n_dot_l": Array(("H", "W"), "n_dot_l", values=N_DOT_L, elements="pixels with SSS", sss=True),
    "light_rgb": Array(("H", "W", 3), "light_rgb", values=LIGHT_RGB, elements="pixels with SSS", sss=True)}


@dataclass(frozen=True)
class SlotModel:
    """One profile id's T(t) = sum_k a_ck exp(-b_ck u - c_ck u^2), u = scale t (mm): ``a``, ``b``, ``c`` (3,
    K; b, c >= 0, a of either sign: a term may subtract, but T(t) itself must be >= 0, which the model's maker
    checks), the back irradiance's ``wrap`` (step 3) and ``along_normal``: the thickness along the surface
    normal rather than the light (step 2); a model ``unreal`` holds instead its profile table ``lut`` (3,
    LUT_SIZE) and the optical depth's ``od_per_mm`` and ``od_offset`` (step 4)."""

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    scale: float = 1.0
    wrap: float = 0.0
    model: str = "mcml"
    along_normal: bool = False
    lut: np.ndarray | None = None
    od_per_mm: float = 0.0
    od_offset: float = 0.0


@dataclass(frozen=True, eq=False)
class TransmissionPlan:
    """What a backend needs besides the frame's images: per slot (slot 0 empty) the model's (S, 3, K)
    tables, (S,) scale, wrap and normal (1: step 2's thickness along the surface normal, 0: along the light),
    the zero-thickness bias (module docstring), and for ``unreal`` slots (``lut_slot`` (S,) true) their
    (S, 3, LUT_SIZE) profile tables and (S,) optical-depth scale and offset (zeros elsewhere)."""

    ids: tuple[int, ...]
    a: NDArray[np.float64]
    b: NDArray[np.float64]
    c: NDArray[np.float64]
    scale: NDArray[np.float64]
    wrap: NDArray[np.float64]
    bias_mm: float
    models: tuple[str, ...]
    lut_slot: NDArray[np.bool_]
    lut: NDArray[np.float64]
    od_per_mm: NDArray[np.float64]
    od_offset: NDArray[np.float64]
    normal: NDArray[np.float64]

    @property
    def slots(self) -> int:
        return len(self.ids) + 1

    @property
    def terms(self) -> int:
        return int(self.a.shape[2])

    @property
    def has_lut(self) -> bool:
        """Whether some slot is an ``unreal`` table."""
        return bool(self.lut_slot.any())

    def transmittance(self, slot: int, thickness_mm: np.ndarray) -> np.ndarray:
        """(..., 3) T(t) of one slot at thicknesses (mm), step 4 in float64 (for tests and tables)."""
        t = np.asarray(thickness_mm, float)
        if self.lut_slot[slot]:
            x = unreal_lut_coordinate(self.od_per_mm[slot] * t + self.od_offset[slot])
            i = np.minimum(np.floor(x), LUT_SIZE - 2).astype(int)
            f = (x - i)[..., None]
            return np.asarray((1.0 - f) * self.lut[slot].T[i] + f * self.lut[slot].T[i + 1])
        u = self.scale[slot] * t[..., None, None]
        return np.asarray(np.sum(self.a[slot] * np.exp(-self.b[slot] * u - self.c[slot] * u * u), axis=-1))


def unreal_lut_coordinate(od: Any) -> np.ndarray:
    """Step 4 (``unreal``): the profile table's coordinate x in [0, LUT_SIZE - 1] of the optical depth
    od_per_mm t + od_offset, through UE's clamp, its shadow-mask encoding squared and its decoding (module
    docstring), float64."""
    d = np.clip(np.asarray(od, float), 0.15, UE_MAX_OPTICAL_DEPTH) + 0.25
    e = 1.0 - d / UE_MAX_OPTICAL_DEPTH
    return np.asarray((1.0 - e * e) * (LUT_SIZE - 1))


def build_transmission_plan(models: dict[int, SlotModel], bias_mm: float = 1e-3, *,
                            allow_empty: bool = False) -> TransmissionPlan:
    """The plan of profile ids (integers >= 1) -> their :class:`SlotModel`; ``bias_mm`` > 0 is step 2's zero
    thickness. An empty mapping is refused unless ``allow_empty`` (a frame without SSS pixels: its plan has
    no slot but 0, and the pass gives 0 everywhere)."""
    bias_mm = BIAS_MM.check(bias_mm, "bias_mm", PassError)
    ids = check_plan_ids(models, SlotModel, allow_empty=allow_empty)
    names = []
    for pid in ids:
        m = models[pid]
        names.append(check_fields(vars(m), MODEL_FIELDS, f"profile id {pid}", PassError)["model"])
        check_arrays(MODEL_ARRAYS, vars(m), where=f"profile id {pid}")
        if (names[-1] == "unreal") != (m.lut is not None):
            raise PassError(f"profile id {pid}: the unreal model, and only it, holds a profile table (lut)")
    k = max((np.shape(models[i].a)[1] for i in ids), default=1)
    TERMS.check(k, "a transmittance model's terms", PassError)
    s = len(ids) + 1
    a, b, c = (np.zeros((s, 3, k)) for _ in range(3))
    scale, wrap, normal = np.ones(s), np.zeros(s), np.zeros(s)
    lut_slot = np.zeros(s, bool)
    lut = np.zeros((s, 3, LUT_SIZE))
    od_per_mm, od_offset = np.zeros(s), np.zeros(s)
    for slot, pid in enumerate(ids, start=1):
        m = models[pid]
        if m.lut is not None:
            lut_slot[slot], lut[slot] = True, m.lut
            od_per_mm[slot], od_offset[slot] = m.od_per_mm, m.od_offset
        n = np.shape(m.a)[1]
        a[slot, :, :n], b[slot, :, :n], c[slot, :, :n] = m.a, m.b, m.c
        scale[slot], wrap[slot], normal[slot] = m.scale, m.wrap, 1.0 if m.along_normal else 0.0
    return TransmissionPlan(ids, a, b, c, scale, wrap, float(bias_mm), tuple(names), lut_slot, lut, od_per_mm,
                            od_offset, normal)


__all__ = ["LUT_SIZE", "MAX_TERMS", "MODELS", "N_DOT_L_TOLERANCE", "SlotModel", "TransmissionPlan",
           "TRANSMISSION_FRAME", "UE_MAX_OPTICAL_DEPTH", "build_transmission_plan",
           "unreal_lut_coordinate"]
