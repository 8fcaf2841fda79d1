"""Image error metrics against a reference: RMSE, relative RMSE, PSNR, SSIM and FLIP, over whole
images or inside a region (:func:`region_metrics`).

RMSE / PSNR work on linear values. SSIM (scikit-image) and FLIP (NVIDIA's flip-evaluator, LDR
mode) expect display-referred images: both images are divided by the reference's peak, clipped
to [0, 1] and sRGB-encoded first (:func:`tonemap`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import SignalError
from .io import tonemap  # the display encoding images are written with
from .quantities import POSITIVE, check_choice, check_shape

#: ITU-R BT.709 luminance weights of linear RGB (Y = 0.2126 R + 0.7152 G + 0.0722 B)
BT709_LUMA = (0.2126, 0.7152, 0.0722)


def _pair(reference: ArrayLike, test: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    ref = check_shape(reference, "the reference image", ("H", "W", 3), SignalError, dtype=np.float64, finite=True)
    return ref, check_shape(test, "the test image", ref.shape, SignalError, dtype=np.float64, finite=True)


def rmse(reference: ArrayLike, test: ArrayLike) -> float:
    """Root-mean-square error over all pixels and channels (linear)."""
    ref, tst = _pair(reference, test)
    return float(np.sqrt(np.mean((ref - tst) ** 2)))


def relative_rmse(reference: ArrayLike, test: ArrayLike) -> float:
    """RMSE divided by the reference's RMS value; NaN (undefined, no warning) for an all-black reference."""
    ref, tst = _pair(reference, test)
    power = float(np.mean(ref**2))
    if power == 0.0:
        return float("nan")
    return float(np.sqrt(np.mean((ref - tst) ** 2) / power))


def psnr(reference: ArrayLike, test: ArrayLike, peak: float | None = None) -> float:
    """Peak signal-to-noise ratio in dB, 20 log10(peak / RMSE); peak defaults to the reference's maximum.
    NaN (undefined, no warning) when the peak is not positive (an all-black reference: no light)."""
    ref, tst = _pair(reference, test)
    peak = float(ref.max()) if peak is None else float(peak)
    if not peak > 0:
        return float("nan")
    err = rmse(ref, tst)
    return float("inf") if err == 0 else float(20.0 * np.log10(peak / err))


#: SSIM's Gaussian window (sigma 1.5 px): Wang et al.'s 11 x 11 window, scikit-image's 2 int(3.5 sigma + 0.5) + 1;
#: an image with a side shorter than it has no SSIM
SSIM_SIGMA_PX = 1.5
SSIM_MIN_SIDE = 2 * int(3.5 * SSIM_SIGMA_PX + 0.5) + 1


def check_ssim_size(height: int, width: int, what: str = "", hint: str = "") -> None:
    """A SignalError if an image of ``height`` x ``width`` is smaller than SSIM's window (:data:`SSIM_MIN_SIDE`
    pixels a side); ``what`` begins the message (e.g. the option that sized it), ``hint`` ends it. Callers check
    it before work."""
    if min(height, width) < SSIM_MIN_SIDE:
        raise SignalError(f"{what}SSIM needs images of at least {SSIM_MIN_SIDE} x {SSIM_MIN_SIDE} pixels (its Gaussian "
                          f"window, sigma {SSIM_SIGMA_PX} px), got {width} x {height}{hint}")


def ssim(reference: ArrayLike, test: ArrayLike) -> float:
    """Mean SSIM (scikit-image, Gaussian-weighted as in Wang et al.) of the tone-mapped images; a SignalError
    for an image smaller than the window (:data:`SSIM_MIN_SIDE` pixels a side)."""
    from skimage.metrics import structural_similarity

    ref, tst = _pair(reference, test)
    check_ssim_size(ref.shape[0], ref.shape[1])
    peak = float(ref.max()) or 1.0
    return float(structural_similarity(tonemap(ref, peak), tonemap(tst, peak), channel_axis=2, data_range=1.0,
                                       gaussian_weights=True, sigma=SSIM_SIGMA_PX,
                                       use_sample_covariance=False))


def flip(reference: ArrayLike, test: ArrayLike, ppd: float = 67.0) -> float:
    """Mean LDR-FLIP error (NVIDIA flip-evaluator) of the tone-mapped images, 0 = identical."""
    import flip_evaluator

    ref, tst = _pair(reference, test)
    peak = float(ref.max()) or 1.0
    a = np.ascontiguousarray(tonemap(ref, peak), dtype=np.float32)
    b = np.ascontiguousarray(tonemap(tst, peak), dtype=np.float32)
    _, mean, _ = flip_evaluator.evaluate(a, b, "LDR", inputsRGB=True, applyMagma=False, computeMeanError=True,
                                         parameters={"ppd": float(ppd)})
    return float(mean)


#: PSNRs at or above this are equality to float64 rounding (an exact method reaches ~300 dB)
EXACT_PSNR_DB = 150.0


def psnr_text(value: float | None, digits: int = 1) -> str:
    """A PSNR for people: "exact" for an infinite one (None: an infinite one made JSON-ready) or one at
    float64 rounding level (>= :data:`EXACT_PSNR_DB`), "no light" for NaN (the reference is black:
    :func:`region_metrics`), else the dB value."""
    if value is not None and np.isnan(value):
        return "no light"
    if value is None or not np.isfinite(value) or value >= EXACT_PSNR_DB:
        return "exact"
    return f"{value:.{digits}f}"


#: the perceptual metrics, on tone-mapped images
PERCEPTUAL = ("ssim", "flip")


def all_metrics(reference: ArrayLike, test: ArrayLike, perceptual: bool | tuple[str, ...] = True) -> dict[str, float]:
    """rmse, relative_rmse, psnr and the ``perceptual`` metrics: True for ssim and flip, False for
    none, or a tuple of names from :data:`PERCEPTUAL` (e.g. ``("flip",)`` when SSIM is not shown)."""
    names = PERCEPTUAL if perceptual is True else (() if perceptual is False else tuple(perceptual))
    names = tuple(check_choice("perceptual metric", n, PERCEPTUAL, SignalError) for n in names)
    out = {"rmse": rmse(reference, test), "relative_rmse": relative_rmse(reference, test),
           "psnr": psnr(reference, test)}
    if "ssim" in names:
        out["ssim"] = ssim(reference, test)
    if "flip" in names:
        out["flip"] = flip(reference, test)
    return out


def region_metrics(reference: ArrayLike, test: ArrayLike, mask: ArrayLike, perceptual: bool = True) -> dict[str, float]:
    """Errors of ``test`` against ``reference`` (both (H, W, 3), linear) inside ``mask`` (H, W) bool:
    ``rmse``, ``relative_rmse`` and ``psnr`` (peak = the reference's maximum inside the mask) over the
    masked pixels, and with ``perceptual`` ``flip`` over the whole image (FLIP needs the image
    context). An empty mask gives NaN errors (and the FLIP of the whole image). A reference black inside
    the mask (no light reached it: e.g. a back-lit scene without the transmittance pass) has no relative
    error and no PSNR: both NaN, and ``no_light`` is True (:func:`no_light`)."""
    ref, tst = _pair(reference, test)
    m = check_shape(mask, "the mask", ref.shape[:2], SignalError, "iufb", bool)
    if m.any():
        r, t = ref[m][None], tst[m][None]  # the masked pixels as a (1, N, 3) image
        out = {"rmse": rmse(r, t), "relative_rmse": relative_rmse(r, t), "psnr": psnr(r, t)}
        if not r.max() > 0:
            out["no_light"] = True
    else:
        out = {"rmse": float("nan"), "relative_rmse": float("nan"), "psnr": float("nan")}
    if perceptual:
        out["flip"] = flip(ref, tst)
    return out


def no_light(metrics: dict[str, float]) -> bool:
    """Whether ``metrics`` (:func:`region_metrics`') say ``no_light``: the reference is black inside a non-empty
    mask, so the relative error and the PSNR are undefined (NaN) and the rest measures nothing to be shown as a
    match."""
    return bool(metrics.get("no_light", False))


#: what :func:`no_light` metrics are, for people
NO_LIGHT_TEXT = "no light: no front light reaches the SSS mask, so this comparison measures nothing, no relative error or PSNR"


# ---- region-wise comparison of diffuse parts -----------------------------------------------------------
#
# A screen-space pass conserves energy inside the SSS mask, so a mean over the whole mask sees only the
# albedo level, the lighting and the noise: it is blind to the lateral transport SSS is about. The
# comparison is therefore made per region, on diffuse parts (specular subtracted on both sides) divided
# by the white diffuse layer E / pi, with the level (albedo, on the lit plateau) and the shape (across
# the shadow edge, normalised by the plateau) compared apart.

#: the regions of :func:`region_masks`, in table order
REGIONS = ("plateau", "shadow_edge", "terminator", "silhouette")


def _distance_to(region: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Euclidean distance (pixels) of every pixel to the nearest pixel of ``region`` (inf if none)."""
    from scipy import ndimage

    if not region.any():
        return np.full(region.shape, np.inf)
    return ndimage.distance_transform_edt(~region)


def region_masks(e_over_pi: ArrayLike, mask: ArrayLike, radius_px: float,
                 sharp: float = 0.3) -> dict[str, NDArray[np.bool_]]:
    """The comparison regions inside ``mask`` (H, W) bool, from the white diffuse layer ``e_over_pi``
    ((H, W) or (H, W, 3): irradiance / pi) and the profile's reach ``radius_px`` (pixels):

    * ``silhouette``: mask pixels within radius_px of the mask's border (light from behind the
      silhouette, missing neighbours);
    * ``shadow_edge``: the rest within radius_px of a sharp edge of the light (a step between
      neighbours of more than ``sharp`` x the lit level: cast shadows);
    * ``terminator``: the rest where the light fades smoothly (between 0.5% and 25% of the lit level:
      the surface turning away from the light);
    * ``plateau``: the rest that is lit (more than half the lit level) and farther than radius_px from
      every pixel that is not.

    The lit level is the 98th percentile of the light inside the mask.
    """
    e = np.asarray(e_over_pi, dtype=np.float64)
    e = e.mean(axis=2) if e.ndim == 3 else e
    m = np.asarray(mask, dtype=bool)
    check_shape(e, "the light layer", m.shape, SignalError)
    POSITIVE.check(radius_px, "radius_px (pixels)", SignalError)
    empty = {name: np.zeros_like(m) for name in REGIONS}
    if not m.any():
        return empty
    level = float(np.percentile(e[m], 98))
    if not level > 0:
        return empty
    silhouette = m & (_distance_to(~m) <= radius_px)
    step = np.zeros_like(m)
    for axis in (0, 1):
        d = np.abs(np.diff(np.where(m, e, np.nan), axis=axis)) > sharp * level
        d = np.nan_to_num(d, nan=0).astype(bool)
        if axis == 0:
            step[1:] |= d
            step[:-1] |= d
        else:
            step[:, 1:] |= d
            step[:, :-1] |= d
    shadow = m & ~silhouette & (_distance_to(step) <= radius_px)
    rest = m & ~silhouette & ~shadow
    terminator = rest & (e > 0.005 * level) & (e < 0.25 * level)
    lit = e > 0.5 * level
    plateau = rest & lit & (_distance_to(~lit) > radius_px)
    return {"plateau": plateau, "shadow_edge": shadow, "terminator": terminator, "silhouette": silhouette}


def region_level(diffuse_part: ArrayLike, e_over_pi: ArrayLike, region: ArrayLike,
                 pixel_se: ArrayLike | None = None) -> dict[str, object]:
    """The effective albedo of a region: mean(diffuse part) / mean(E / pi) per channel over ``region``,
    with its standard error when ``pixel_se`` (the diffuse part's per-pixel standard errors from
    independent pixels) is given: sqrt(sum se^2) / N / mean(E / pi). On the lit plateau of a flat
    surface this is the total diffuse reflectance; near edges it measures the light carried across."""
    d = np.asarray(diffuse_part, dtype=np.float64)
    e = np.asarray(e_over_pi, dtype=np.float64)
    r = np.asarray(region, dtype=bool)
    n = int(r.sum())
    if n == 0:
        return {"pixels": 0, "level": [float("nan")] * 3, "se": None}
    ebar = e[r].mean(axis=0)
    ebar = np.broadcast_to(ebar, (3,)) if np.ndim(ebar) == 0 else ebar
    level = d[r].mean(axis=0) / np.maximum(ebar, 1e-300)
    se = None
    if pixel_se is not None:
        s = np.asarray(pixel_se, dtype=np.float64)
        se = (np.sqrt(np.sum(s[r] ** 2, axis=0)) / n / np.maximum(ebar, 1e-300)).tolist()
    return {"pixels": n, "level": level.tolist(), "se": se}


def edge_profile(diffuse_part: ArrayLike, region: ArrayLike, plateau_level: ArrayLike,
                 pixel_se: ArrayLike | None = None,
                 axis: int = 0) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """The profile across a straight edge: the mean of the diffuse part over ``region``'s pixels along
    ``axis`` (0: down the columns, for a vertical edge), divided by the plateau's level (so a profile
    of the same shape but another albedo compares equal). Returns (profile (W, 3), standard error
    (W, 3) or None); columns without region pixels are NaN."""
    d = np.asarray(diffuse_part, dtype=np.float64)
    r = np.asarray(region, dtype=bool)
    cnt = r.sum(axis=axis).astype(float)
    lev = np.asarray(plateau_level, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        prof = np.where(r[..., None], d, 0.0).sum(axis=axis) / cnt[:, None] / lev
        se = None
        if pixel_se is not None:
            s = np.asarray(pixel_se, dtype=np.float64)
            se = np.sqrt(np.where(r[..., None], s**2, 0.0).sum(axis=axis)) / cnt[:, None] / lev
    return prof, se


def profile_rmse(test: ArrayLike, reference: ArrayLike, reference_se: ArrayLike | None = None) -> dict[str, float]:
    """RMSE between two normalised profiles (over the entries both hold), with the part of it that the
    reference's own noise explains: ``noise`` = rms of its standard errors, ``rmse_se`` the standard
    error of the RMSE (delta method: se(rmse^2) = 2 sqrt(sum d^2 se^2) / N), and ``resolved`` whether
    the RMSE exceeds the noise by more than 3 standard errors."""
    a = np.asarray(test, dtype=np.float64)
    b = np.asarray(reference, dtype=np.float64)
    ok = np.isfinite(a) & np.isfinite(b)
    d = (a - b)[ok]
    n = d.size
    if n == 0:
        return {"rmse": float("nan"), "noise": float("nan"), "rmse_se": float("nan"), "resolved": False}
    rmse = float(np.sqrt(np.mean(d**2)))
    if reference_se is None:
        return {"rmse": rmse, "noise": 0.0, "rmse_se": 0.0, "resolved": True}
    s = np.asarray(reference_se, dtype=np.float64)[ok]
    noise = float(np.sqrt(np.mean(s**2)))
    se2 = 2.0 * np.sqrt(np.sum(d**2 * s**2)) / n
    rmse_se = float(se2 / (2.0 * rmse)) if rmse > 0 else noise
    return {"rmse": rmse, "noise": noise, "rmse_se": rmse_se,
            "resolved": bool(rmse**2 - noise**2 > 3.0 * se2)}
def display_psnr(reference: ArrayLike | None, image: ArrayLike, mask: ArrayLike, gamma: float = 2.2) -> float | None:
    """Gray-scale PSNR on the display (Xie 2020 Sec. 6 reports "gray-scale PSNR"), inside ``mask``: both
    images mapped by g(x) = clip(Y(x) / P, 0, 1)^(1/gamma), Y the BT.709 luminance and P the reference's
    largest luminance inside the mask (so the reference spans [0, 1] like a display frame), then
    PSNR = 20 log10(1 / RMSE). This is the scale the sampler's history measures (gamma-corrected
    luminance, Sec. 4.1.2), where dark pixels weigh as much as on a screen; the linear ``psnr`` is
    dominated by the brightest pixels. None without a reference or mask."""
    if reference is None or not np.any(mask):
        return None
    w = np.asarray(BT709_LUMA)
    m = np.asarray(mask, dtype=bool)
    y_ref = np.asarray(reference, np.float64)[m] @ w
    y_img = np.asarray(image, np.float64)[m] @ w
    peak = float(y_ref.max())
    if peak <= 0:
        return None
    g = 1.0 / gamma
    err = np.sqrt(np.mean((np.clip(y_ref / peak, 0, 1) ** g - np.clip(y_img / peak, 0, 1) ** g) ** 2))
    return float("inf") if err == 0 else float(-20.0 * np.log10(err))


__all__ = [
    "BT709_LUMA",
    "EXACT_PSNR_DB",
    "NO_LIGHT_TEXT",
    "PERCEPTUAL",
    "REGIONS",
    "SSIM_MIN_SIDE",
    "SSIM_SIGMA_PX",
    "all_metrics",
    "check_ssim_size",
    "display_psnr",
    "edge_profile",
    "flip",
    "no_light",
    "profile_rmse",
    "psnr",
    "psnr_text",
    "region_level",
    "region_masks",
    "region_metrics",
    "relative_rmse",
    "rmse",
    "ssim",
]
