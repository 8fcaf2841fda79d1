"""The Burley Monte Carlo pass's plan: per-id parameters and EXACTLY what every backend computes.

Xie et al. 2020 (Sec. 3.1, 4.2, 5): screen-space SSS by per-pixel Monte Carlo sampling of Burley's
normalized diffusion

    R_c(r) = A_c (exp(-r/d_c) + exp(-r/(3 d_c))) / (8 pi d_c r)          (Xie 2020, Eq. 4; mm^-2, per area)

with the bilateral, self-normalised estimator of Eq. 24. A backend (numpy oracle, numba, GLSL) must
compute the following, in this order, for every pixel p = (x, y) with slot s = slots[y, x] > 0
(slot 0: no SSS, the diffuse value is copied). Integers are uint32 (all arithmetic mod 2^32); the
oracle computes positions and weights in float64; the numba backend computes them in float32 but
finds the texel of every sample whose float32 position lies near a texel edge again in float64 (so
the texel every sample lands on is the oracle's); a plain float32 port (GLSL) may differ in the texel
of a sample whose position lies within float32 rounding of a texel edge, so its parity test counts
pixels, not maxima.

1. **Pixel key.** ``mix`` is lowbias32 (:func:`ssskit.sampling.hashes.mix32`)::

       base = mix(mix(seed ^ 0x9E3779B9) ^ F)        F = frame, or 0 with a stable pattern
       h    = mix(mix(base ^ y) ^ x)                 (ssskit.sampling.hashes.pixel_hashes)
       h    = mix(h ^ bits(float32(z_p)))            only with a stable pattern (HDRP: pixel and depth)
       h1 = h,  h2 = mix(h ^ 0x6A09E667)

2. **Sample count** n(p) = spp (one number, or the (H, W) count image at p). Sampler ``golubev``
   caps it by the footprint: n = max(1, min(spp, floor(pi r997^2 sx sy / 4))) with r997 the radius
   (mm) holding 0.997 of the sampling channel's energy (Eq. 20) and sx, sy below (Golubev 2018).
   n = 0 outputs the diffuse value E(p).

3. **Uniforms** of sample j = 0 .. n-1, as 32-bit integers U1, U2, each turned into
   xi = (float(U >> 8) + 0.5) * 2^-24, which lies in (0, 1) and is exact in float32:

   * sequence ``r2`` (default; samplers exact and xie): the R2 sequence (Roberts 2018, plastic
     number g = 1.324717957...) with a Cranley-Patterson rotation by the pixel key:
     U1 = h1 + j * 0xC13FA9A9, U2 = h2 + j * 0x91E10DA6 (the constants are round(2^32 / g) and
     round(2^32 / g^2));
   * sequence ``random`` (plain Monte Carlo, independent samples): U1 = mix(h1 ^ (j * 0x9E3779B9)),
     U2 = mix(h2 ^ (j * 0x9E3779B9));
   * sampler ``golubev`` (any sequence): xi1 = (j + 0.5) / n (stratified radius, Golubev 2018 /
     Unity HDRP), U2 = h2 + j * 0x9E3779B9 (golden-ratio angles, 0x9E3779B9 = round(2^32 / phi),
     rotated by the pixel key).

4. **Radius** r (mm) in the sampling channel k(s) = the channel with the largest d (HDRP, Unreal),
   d_s = d[s, k]:

   * ``exact`` and ``golubev``: the exact inverse of Eq. 20, cdf(r) = 1 - exp(-r/d)/4 - 3 exp(-r/(3d))/4,
     to float64 precision. Everything scales with d_s, so r = d_s rho(xi1) with rho the inverse for
     d = 1. The oracle calls :func:`ssskit.profiles.burley.burley_inverse_cdf` (Cardano in hyperbolic
     form + three Newton steps); the numba backend (and a port) computes the same root (measured
     relative difference < 1e-15 over (0, 1)) with five transcendental calls:

       - xi1 >= 1e-3: eta = 1 - xi1, c = exp(log(2 eta + sqrt(4 eta^2 + 1)) / 3), rho0 = -3 log(c - 1/c)
         (Cardano: u = exp(-rho/3) is the real root of u^3 + 3u = 4 eta);
       - xi1 < 1e-3: rho0 = 2 xi1 + 4 xi1^2 / 3 + 28 xi1^3 / 27 (series, relative error < 1e-9);
       - one Newton step: t = expm1(-rho0/3), e = 1 + t, p = (e^3 + e)/4 (density per unit radius,
         d = 1); for xi1 <= 1/2 rho = rho0 - (-(t^3 + 3t^2 + 3t)/4 - 3t/4 - xi1) / p, else
         rho = rho0 - (eta - e^3/4 - 3e/4) / p.

     In float32 the Cardano start loses relative precision near xi1 = 0 and 1; two Newton steps
     then bring it to float32 rounding;
   * ``xie``: Eq. 21, r = d_s ((2 - c) xi1 - 2) log(1 - xi1) (log1p(-xi1)), c default 2.5715.
     Its samples do not follow p(r) exactly, but the weights use p(r) as Xie and Unreal do: the
     sampler is biased (measured in benchmarks/RESULTS.md).

5. **Position.** phi = 2 pi xi2; pixels per mm at the centre's depth z_p (mm): sx = fx / z_p,
   sy = fy / z_p; the sample lies at (x + 0.5 + r cos(phi) sx, y + 0.5 + r sin(phi) sy) in pixels,
   i.e. at distance r in the plane through p perpendicular to the view axis. Its texel is
   (i, j) = (floor(.), floor(.)). Without mips the sample's value is E(i, j) (a nearest-texel fetch,
   so the estimator's expectation is the convolution with R's exact cell integrals: the ground truth
   of :func:`ssskit.pipeline.burley_frame.burley_exact`).

5b. **Prefiltered irradiance** (``mips``; Xie 2020 Eqs. 22-23, after Krivanek and Colbert 2008).
   Per slot s a pyramid of the diffuse layer restricted to the slot (:func:`mip_pyramid`): level 0
   holds (E [slots = s], [slots = s]) per texel (premultiplied colour and coverage), level k the
   mean of the 2 x 2 children of level k-1 (children off the image count 0; level k is
   ceil(H / 2^k) x ceil(W / 2^k)), k = 0 .. MAX_MIP = 5. The sample's level is

       m = min(MAX_MIP, 0.5 max(-log2(a n p(r) / (ell_s^2 t)), 0))              (Eq. 22)
       t = (sx / W) (sy / H)                                                     (Eq. 23)

   in the paper's own units, which are those of Unreal Engine 4.25+'s SubsurfaceBurleyNormalized.ush,
   the code Xie's pass shipped in (its level is one half of max(-log2(a x samples x Pdf / (dmfp^2 x
   texSize)), 0) with a = MIP_CONSTANT_FACTOR = 0.0625, Pdf from GetPdf and texSize the product of
   the two components of BurleyScale, the UV offset per mm of radius):

   * a = ``mip_scale`` (Xie: 1/16, :data:`XIE_MIP_SCALE`); n the pixel's count;
   * p(r) the **radial** density of the sample, per mm: the derivative of Eq. 20,
     (exp(-r/d_s) + exp(-r/(3 d_s))) / (4 d_s) (Eq. 19 integrates 2 pi r R(r) over dr, so its pdf
     is per unit radius; Unreal's ``GetPdf`` = ``GetCDFDeriv1``) -- not the area density
     p(r) / (2 pi r) per mm^2;
   * ell_s = :attr:`BurleyPlan.dmfp_max_mm`, the slot's largest diffuse mean free path (mm), the
     surface dmfp ell_c = d_c (3.5 + 100 (A_c - 0.33)^4) of Eq. 5 configuration 3 -- not d;
   * t the squared screen-space scale at the centre's depth: (w / D)^2 x aspect ratio of Eq. 23 with
     w / D = sx / W the **viewport UV units** (image widths) per mm (Unreal's ``BurleyScale``, whose
     y is x times the aspect ratio W / H), i.e. t = (sx / W)(sy / H) in UV^2 per mm^2 with W x H
     the frame size (level 0) -- not the texel's area in mm^2.

   The argument is not dimensionless (mm^-1 / UV^2) and does not depend on the resolution (sx / W is
   fixed by the field of view): a = 1/16 means Xie's a only in these units. With it, the level rises
   above 0 only for samples whose radial pdf is below ell^2 t / (a n), i.e. far in the profile's
   tail; the bias and the gain are measured (benchmarks/RESULTS.md). The value is the trilinear,
   coverage-normalised fetch of slot s' = slots[j, i]'s pyramid: at level
   L = floor(m) and L + 1 with f = m - L, bilinear weights at (u, v) = (qx / 2^L - 1/2, qy / 2^L - 1/2)
   (qx, qy the continuous position of step 5; texels off the level are 0), C = sum of weight x
   premultiplied colour, K = sum of weight x coverage, and value = ((1-f) C_L + f C_(L+1)) /
   ((1-f) K_L + f K_(L+1)). (Unreal rounds m up and fetches the nearest texel of that level.)
   Constant irradiance stays constant and nothing crosses slots, but the estimator is no longer the
   exact convolution: the bias is measured (benchmarks/RESULTS.md).

6. **Indicator** I (Eq. 24's 1_s): 0 off the image or where slots[j, i] = 0; 1 where
   slots[j, i] = s; ``bleed`` (in [0, 1], default 0; Unreal's BoundaryColorBleed) on another profile id.

7. **Weight** per channel c (Eq. 24: w_c = r' R_c(r') / pdf(r), constant factors dropped since they
   cancel in the ratio): with dz = z[j, i] - z_p (mm) and r' = sqrt(r^2 + dz^2),

       w_c = (d_s / d_c) (exp(-r'/d_c) + exp(-r'/(3 d_c))) / (exp(-r/d_s) + exp(-r/(3 d_s)))

   (= 2 pi r' R_c(r') / (A_c p(r)), the area measure of the sample being p(r) / (2 pi r) per mm^2
   for a uniform angle). For the exact sampler, c = k and dz = 0 every weight is 1. (The numba
   backend evaluates exp(-x/d) as a^3 with a = exp(-x/(3d)): four exps per sample, not eight.)

8. **Result** per channel: out_c(p) = sum_j I w_c V_c / sum_j I w_c (Eq. 24), V = E(i, j) or, with
   mips, step 5b's value, or E_c(p) when
   the denominator is 0 (every sample rejected). The albedo layer multiplies it afterwards, as for
   the separable pass (:meth:`ssskit.screenspace.GBuffer.composite`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, TypeAlias

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import PassError
from ..quantities import BURLEY_ALBEDO, FRACTION, MFP_MM, SCALE, Choice, Quantity, check_fields
from .plan import SEPARABLE_FRAME, Array, check_plan_ids

if TYPE_CHECKING:
    from ..profiles.base import RGBProfile

#: the Burley pass's samples per pixel: one count for every pixel, or an (H, W) integer image
SampleCounts: TypeAlias = "int | np.integer[Any] | NDArray[np.integer[Any]]"
#: :func:`mip_pyramid`'s levels 0..MAX_MIP, each (S, H_k, W_k, 4) float64
MipPyramid: TypeAlias = "list[NDArray[np.float64]]"
#: what a backend's ``burley_prefilter`` gives its ``burley``: the oracle's :data:`MipPyramid`, or the backend's
#: own layout of it (the numba backend's float32 ``NumbaMips``)
Prefiltered: TypeAlias = Any

#: samplers of the radius (module docstring, step 4)
SAMPLERS = ("exact", "xie", "golubev")
#: 2D sequences of the uniforms (step 3)
SEQUENCES = ("r2", "random")
#: Xie 2020's least-squares constant of Eq. 21 (Unreal ships 2.6)
XIE_C = 2.5715
#: c must lie in this open interval (Eq. 21 stays increasing for c >= 2; the issue's range)
C_RANGE = (2.0, 3.0)
#: the most samples per pixel
MAX_SPP = 1 << 16
#: the Burley sampler (Xie 2020 Sec. 4.2), its samples per pixel (a per-pixel count may be 0: no SSS) and Eq. 21's
#: damping c: the quantities the pass's plan and settings (ssskit.screenspace.burley) both take
SAMPLER = Choice("sampler", SAMPLERS)
BURLEY_SPP = Quantity("spp", 1, MAX_SPP, "", "samples per pixel of the Burley pass", integer=True)
COUNTS = BURLEY_SPP.within(lo=0, reason="samples per pixel of the Burley pass; 0 on a pixel without SSS")
XIE_C_RANGE = Quantity("c", C_RANGE[0], C_RANGE[1], "", "Eq. 21's damping (Xie 2020)", lo_open=True, hi_open=True)
#: an (H, W) image of the pass's sample counts (:data:`COUNTS`)
COUNT_IMAGE = Array(("H", "W"), "the sample counts", "iu", np.int64, COUNTS, "pixels")
#: the pass's frame: the separable pass's and ``spp``, one count for every pixel (:data:`BURLEY_SPP`) or a count
#: image (checked: an int, or an (H, W) int64 image)
BURLEY_FRAME = {**SEPARABLE_FRAME, "spp": replace(COUNT_IMAGE, scalar=BURLEY_SPP)}
#: the sampler's arguments of :func:`build_burley_plan`
_PLAN_FIELDS: dict[str, Quantity | Choice] = {"sampler": SAMPLER, "sequence": Choice("sequence", SEQUENCES),
                                             "c": XIE_C_RANGE, "bleed": FRACTION, "mip_scale": SCALE}
#: the coarsest mip level of step 5b, and Xie 2020's a of Eq. 22 (Unreal's MIP_CONSTANT_FACTOR), in the
#: units of step 5b
MAX_MIP = 5
XIE_MIP_SCALE = 1.0 / 16.0
#: energy fraction of the radius that sets golubev's sample cap (Golubev 2018)
GOLUBEV_FRACTION = 0.997

# uint32 constants of step 1 and 3
GOLDEN32 = 0x9E3779B9  # round(2^32 / phi)
KEY2 = 0x6A09E667  # second stream of the pixel key
R2_A1 = 0xC13FA9A9  # round(2^32 / g), g the plastic number
R2_A2 = 0x91E10DA6  # round(2^32 / g^2)


@dataclass(frozen=True, eq=False)
class BurleyParams:
    """One profile id's Burley parameters per RGB channel: surface albedo A and length d (mm).

    Build with :meth:`from_dmfp` (albedo + diffuse mean free path, Eq. 5 configuration 3 as Unreal
    and Xie use), :meth:`from_profile` (an existing Burley :class:`~ssskit.profiles.RGBProfile`) or
    :func:`ssskit.screenspace.burley.burley_params_for_material` (a preset or Material through
    :func:`ssskit.profiles.burley_profile`, any Eq. 5 configuration).
    """

    albedo: tuple[float, float, float]
    d_mm: tuple[float, float, float]

    def __post_init__(self) -> None:
        from ..profiles.domain import BURLEY_D

        object.__setattr__(self, "albedo", BURLEY_ALBEDO.check_rgb(self.albedo, "Burley albedo", PassError))
        object.__setattr__(self, "d_mm", BURLEY_D.check_rgb(self.d_mm, "Burley length d", PassError))

    @classmethod
    def from_dmfp(cls, albedo: ArrayLike, dmfp_mm: ArrayLike) -> "BurleyParams":
        """d = dmfp / (3.5 + 100 (A - 0.33)^4) per channel (Xie 2020, Eq. 5, configuration 3)."""
        a = np.asarray(BURLEY_ALBEDO.check_rgb(albedo, "Burley albedo", PassError))
        ell = np.asarray(MFP_MM.check_rgb(dmfp_mm, "diffuse mean free path", PassError))
        d = ell / (3.5 + 100.0 * (a - 0.33) ** 4)
        return cls((a[0], a[1], a[2]), (d[0], d[1], d[2]))

    @classmethod
    def from_profile(cls, profile: object) -> "BurleyParams":
        """A and d of a Burley RGBProfile's three channels (:class:`~ssskit.profiles.BurleyProfile`)."""
        chans = getattr(profile, "channels", None)
        if chans is None or len(chans) != 3 or any(getattr(c, "model", "") != "burley" for c in chans):
            raise PassError(f"the Burley pass needs a Burley profile (three BurleyProfile channels), got "
                            f"{getattr(profile, 'model', type(profile).__name__)!r}")
        return cls(tuple(c.albedo for c in chans), tuple(c.d for c in chans))

    @property
    def dmfp_mm(self) -> tuple[float, float, float]:
        """The surface diffuse mean free path per channel, ell = d (3.5 + 100 (A - 0.33)^4) (mm): Eq. 5
        configuration 3 solved for ell (the inverse of :meth:`from_dmfp`, whatever made d)."""
        a = np.asarray(self.albedo)
        r, g, b = (float(v) for v in np.asarray(self.d_mm) * (3.5 + 100.0 * (a - 0.33) ** 4))
        return r, g, b

    def profile(self) -> RGBProfile:
        """The RGBProfile of these parameters (for ground truth and figures)."""
        from ..profiles.base import RGBProfile
        from ..profiles.burley import BurleyProfile

        r, g, b = (BurleyProfile(a, d) for a, d in zip(self.albedo, self.d_mm))
        return RGBProfile((r, g, b), "burley", "burley", {"albedo": list(self.albedo), "d_mm": list(self.d_mm)})

    @property
    def sampling_channel(self) -> int:
        """The channel with the largest d (the first of equal ones)."""
        return int(np.argmax(self.d_mm))




@dataclass(frozen=True, eq=False)
class BurleyPlan:
    """Everything a backend needs besides the frame's images (module docstring); arrays per slot
    (slot 0 = no SSS, unused rows)."""

    ids: tuple[int, ...]  # profile id of slot 1, 2, ...
    d_mm: np.ndarray  # (S, 3) float64
    channel: np.ndarray  # (S,) int64: the sampling channel k(s)
    r997_mm: np.ndarray  # (S,) float64: golubev's 0.997-energy radius of channel k(s)
    sampler: str
    sequence: str
    c: float
    bleed: float
    fx: float
    fy: float
    frame: int
    seed: int
    stable: bool
    #: (S,) float64: each slot's largest diffuse mean free path ell (mm), Eq. 22's ell_max (slot 0: 1), > 0:
    #: set by :func:`build_burley_plan` from the parameters (checked BurleyParams: A in (0, 1], d > 0)
    dmfp_max_mm: np.ndarray
    mips: bool = False
    mip_scale: float = XIE_MIP_SCALE

    @property
    def slots(self) -> int:
        return len(self.ids) + 1

    @property
    def d_sample(self) -> np.ndarray:
        """(S,) d of each slot's sampling channel (slot 0: 1)."""
        out = self.d_mm[np.arange(self.slots), self.channel]
        out[0] = 1.0
        return out

    def slot_map(self, profile_id: np.ndarray) -> np.ndarray:
        """(H, W) int32 slots of a profile-id layer: 0 where the id has no SSS or no entry here."""
        pid = np.asarray(profile_id)
        out = np.zeros(pid.shape, np.int32)
        for s, i in enumerate(self.ids, start=1):
            out[pid == i] = s
        return out


def build_burley_plan(params_by_id: Mapping[int, BurleyParams], fx: float, fy: float, *, sampler: str = "exact", sequence: str = "r2",
                      c: float = XIE_C, bleed: float = 0.0, frame: int = 0, seed: int = 0,
                      stable: bool = False, mips: bool = False, mip_scale: float = XIE_MIP_SCALE) -> BurleyPlan:
    """The plan for profile ids -> :class:`BurleyParams` (module docstring)."""
    v = check_fields({"sampler": sampler, "sequence": sequence, "c": c, "bleed": bleed, "mip_scale": mip_scale},
                     _PLAN_FIELDS, error=PassError)
    ids = check_plan_ids(params_by_id, BurleyParams, fx, fy)
    n = len(ids) + 1
    d = np.ones((n, 3))
    ch = np.zeros(n, np.int64)
    r997 = np.zeros(n)
    ell = np.ones(n)
    from ..profiles.burley import burley_inverse_cdf

    for s, pid in enumerate(ids, start=1):
        p = params_by_id[pid]
        d[s] = p.d_mm
        ch[s] = p.sampling_channel
        r997[s] = float(burley_inverse_cdf(GOLUBEV_FRACTION, d[s, ch[s]]))
        ell[s] = float(np.max(p.dmfp_mm))
    return BurleyPlan(ids, d, ch, r997, v["sampler"], v["sequence"], float(v["c"]), float(v["bleed"]), float(fx),
                      float(fy), int(frame), int(seed), bool(stable), ell, bool(mips), float(v["mip_scale"]))


def mip_pyramid(diffuse: ArrayLike, slots: np.ndarray, n_slots: int, levels: int = MAX_MIP) -> MipPyramid:
    """Step 5b's pyramids: a list over levels 0..levels of (S, H_k, W_k, 4) float64 arrays holding, per
    slot, the mean premultiplied colour (RGB) and coverage of the level's 2^k x 2^k block (slot 0 unused)."""
    e = np.asarray(diffuse, dtype=np.float64)
    h, w = slots.shape
    base = np.zeros((n_slots, h, w, 4))
    for s in range(1, n_slots):
        m = (slots == s).astype(np.float64)
        base[s, ..., :3] = e * m[..., None]
        base[s, ..., 3] = m
    out = [base]
    for _ in range(levels):
        prev = out[-1]
        ph, pw = prev.shape[1:3]
        pad = np.zeros((n_slots, ph + ph % 2, pw + pw % 2, 4))
        pad[:, :ph, :pw] = prev
        out.append(0.25 * (pad[:, 0::2, 0::2] + pad[:, 1::2, 0::2] + pad[:, 0::2, 1::2] + pad[:, 1::2, 1::2]))
    return out
