"""Display copies of noisy path-traced images (the numbers are never measured on them): box means of pixel
blocks, only for showing (issue 35, Build 6: "Never filter the reference used for the numbers")."""

from __future__ import annotations

import numpy as np

#: the largest relative noise (RMS standard error over the mean, over the SSS mask) a path-traced image is shown with;
#: a noisier one is shown as a display copy of block means (:func:`display_copy`), never the numbers' reference
DISPLAY_REL_SE = 0.1
#: the block sizes a display copy may average (pixels per side)
DISPLAY_BLOCKS = (1, 2, 3, 4, 6, 8)


def display_copy(image: np.ndarray, pixel_se: np.ndarray, mask: np.ndarray,
                 target: float = DISPLAY_REL_SE) -> tuple[np.ndarray, int, float]:
    """A path-traced image as shown: (image, block, its relative noise over ``mask``: the RMS of the shown pixels'
    standard errors over their mean, so that fireflies count). Where the image's own noise is above ``target``
    the display copy is the mean of ``block`` x ``block`` pixel blocks (the smallest of :data:`DISPLAY_BLOCKS`
    at or below ``target``, else the largest; a block mean's standard error: sqrt(sum se^2) / block^2 of
    independent pixels), repeated back to the frame's size. Only for showing: the numbers are measured on the
    reference itself, never on this copy."""
    img, se = np.asarray(image, float), np.asarray(pixel_se, float)
    h, w = img.shape[:2]
    shown, rel, b = img, float("inf"), 1
    for b in DISPLAY_BLOCKS:
        hb, wb = h // b * b, w // b * b
        if hb == 0 or wb == 0:
            break
        mean = img[:hb, :wb].reshape(hb // b, b, wb // b, b, 3).mean(axis=(1, 3))
        err = np.sqrt((se[:hb, :wb] ** 2).reshape(hb // b, b, wb // b, b, 3).sum(axis=(1, 3))) / b ** 2
        m = mask[:hb, :wb].reshape(hb // b, b, wb // b, b).any(axis=(1, 3))
        level = float(mean[m].mean()) if m.any() else 0.0
        rel = float(np.sqrt(np.mean(err[m] ** 2)) / level) if level > 0 else 0.0
        shown = img.copy()
        shown[:hb, :wb] = np.repeat(np.repeat(mean, b, axis=0), b, axis=1)
        if rel <= target:
            break
    return shown, b, rel
