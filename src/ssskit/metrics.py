"""Image error metrics against a reference: RMSE, relative RMSE, PSNR, SSIM and FLIP, over whole
images or inside a region (:func:`region_metrics`).

RMSE / PSNR work on linear values. SSIM (scikit-image) and FLIP (NVIDIA's flip-evaluator, LDR
mode) expect display-referred images: both images are divided by the reference's peak, clipped
to [0, 1] and sRGB-encoded first (:func:`tonemap`).
"""

from __future__ import annotations

import numpy as np

from .errors import SignalError
from .io import tonemap  # the display encoding images are written with


def _pair(reference, test) -> tuple[np.ndarray, np.ndarray]:
    ref = np.asarray(reference, dtype=np.float64)
    tst = np.asarray(test, dtype=np.float64)
    if ref.shape != tst.shape:
        raise SignalError(f"images differ in shape: reference {ref.shape} vs test {tst.shape}")
    if ref.ndim != 3 or ref.shape[2] != 3:
        raise SignalError(f"images must have shape (H, W, 3), got {ref.shape}")
    if not (np.all(np.isfinite(ref)) and np.all(np.isfinite(tst))):
        raise SignalError("images contain NaN or infinity")
    return ref, tst


def rmse(reference, test) -> float:
    """Root-mean-square error over all pixels and channels (linear)."""
    ref, tst = _pair(reference, test)
    return float(np.sqrt(np.mean((ref - tst) ** 2)))


def relative_rmse(reference, test) -> float:
    """RMSE divided by the reference's RMS value."""
    ref, tst = _pair(reference, test)
    return float(np.sqrt(np.mean((ref - tst) ** 2) / np.mean(ref**2)))


def psnr(reference, test, peak: float | None = None) -> float:
    """Peak signal-to-noise ratio in dB, 20 log10(peak / RMSE); peak defaults to the reference's maximum."""
    ref, tst = _pair(reference, test)
    peak = float(ref.max()) if peak is None else float(peak)
    err = rmse(ref, tst)
    return float("inf") if err == 0 else float(20.0 * np.log10(peak / err))


def ssim(reference, test) -> float:
    """Mean SSIM (scikit-image, Gaussian-weighted as in Wang et al.) of the tone-mapped images."""
    from skimage.metrics import structural_similarity

    ref, tst = _pair(reference, test)
    peak = float(ref.max()) or 1.0
    return float(structural_similarity(tonemap(ref, peak), tonemap(tst, peak), channel_axis=2, data_range=1.0,
                                       gaussian_weights=True, sigma=1.5, use_sample_covariance=False))


def flip(reference, test, ppd: float = 67.0) -> float:
    """Mean LDR-FLIP error (NVIDIA flip-evaluator) of the tone-mapped images, 0 = identical."""
    import flip_evaluator

    ref, tst = _pair(reference, test)
    peak = float(ref.max()) or 1.0
    a = np.ascontiguousarray(tonemap(ref, peak), dtype=np.float32)
    b = np.ascontiguousarray(tonemap(tst, peak), dtype=np.float32)
    _, mean, _ = flip_evaluator.evaluate(a, b, "LDR", inputsRGB=True, applyMagma=False, computeMeanError=True,
                                         parameters={"ppd": float(ppd)})
    return float(mean)


#: the perceptual metrics, on tone-mapped images
PERCEPTUAL = ("ssim", "flip")


def all_metrics(reference, test, perceptual: bool | tuple[str, ...] = True) -> dict[str, float]:
    """rmse, relative_rmse, psnr and the ``perceptual`` metrics: True for ssim and flip, False for
    none, or a tuple of names from :data:`PERCEPTUAL` (e.g. ``("flip",)`` when SSIM is not shown)."""
    names = PERCEPTUAL if perceptual is True else (() if perceptual is False else tuple(perceptual))
    unknown = [n for n in names if n not in PERCEPTUAL]
    if unknown:
        raise SignalError(f"unknown perceptual metric(s) {', '.join(map(repr, unknown))}; choose from "
                          f"{', '.join(PERCEPTUAL)}")
    out = {"rmse": rmse(reference, test), "relative_rmse": relative_rmse(reference, test),
           "psnr": psnr(reference, test)}
    if "ssim" in names:
        out["ssim"] = ssim(reference, test)
    if "flip" in names:
        out["flip"] = flip(reference, test)
    return out


def region_metrics(reference, test, mask, perceptual: bool = True) -> dict[str, float]:
    """Errors of ``test`` against ``reference`` (both (H, W, 3), linear) inside ``mask`` (H, W) bool:
    ``rmse``, ``relative_rmse`` and ``psnr`` (peak = the reference's maximum inside the mask) over the
    masked pixels, and with ``perceptual`` ``flip`` over the whole image (FLIP needs the image
    context). An empty mask gives NaN errors (and the FLIP of the whole image)."""
    ref, tst = _pair(reference, test)
    m = np.asarray(mask, dtype=bool)
    if m.shape != ref.shape[:2]:
        raise SignalError(f"mask has shape {m.shape}, the images {ref.shape[:2]}")
    if m.any():
        r, t = ref[m][None], tst[m][None]  # the masked pixels as a (1, N, 3) image
        out = {"rmse": rmse(r, t), "relative_rmse": relative_rmse(r, t), "psnr": psnr(r, t)}
    else:
        out = {"rmse": float("nan"), "relative_rmse": float("nan"), "psnr": float("nan")}
    if perceptual:
        out["flip"] = flip(ref, tst)
    return out
