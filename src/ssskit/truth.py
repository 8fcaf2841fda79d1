"""Ground truth and separable application of kernels on images in physical units.

Images are (H, W, 3) float arrays of irradiance E on a pixel grid of ``pixel_mm`` mm per pixel.
The exact result is the 2D convolution of the paper's Eq. 1, M_e = E * Rd, with Rd discretised
into exact cell integrals on the pixel grid (:meth:`RGBProfile.discretize_2d`), computed by FFT.
A separable kernel runs as 2N 1D convolutions (Eq. 2). Both extend the image by repeating its
border pixels, so on the same grid they agree exactly wherever the kernel is exact.

On a G-buffer, :func:`exact_screen_space` is the screen-space pass's ground truth: the same 2D
convolution on each SSS region, with the pass's own boundary rule.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from .errors import SignalError
from .quantities import LENGTH_MM, TYPE, Quantity, check_finite, check_shape, fail

#: the fraction of the kernel's energy its radius holds
RADIUS_FRACTION = Quantity("fraction", 0.0, 1.0, "", "", lo_open=True, hi_open=True)

if TYPE_CHECKING:  # imported where used: truth loads without them
    from .kernels.base import AnyKernel, Kernel
    from .profiles.base import RGBProfile
    from .screenspace.gbuffer import GBuffer


def check_image(image: np.ndarray, what: str = "image") -> np.ndarray:
    """An (H, W, 3) finite float64 copy-free view of ``image`` or a precise error."""
    img = check_shape(image, what, ("H", "W", 3), SignalError, "f", finite=True)
    if not img.size:
        raise fail(SignalError, TYPE, name=what, kind="a non-empty image", actual=f"shape {img.shape}")
    return img.astype(np.float64, copy=False)


def convolve_2d(image: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """E * K per channel by FFT with border replication; cells (n, n, 3), n odd; returns (H, W, 3)."""
    from .compute.fft import fft_convolve

    img = check_image(image)
    k = np.asarray(cells, dtype=float)
    if k.ndim != 3 or k.shape[0] != k.shape[1] or k.shape[0] % 2 != 1 or k.shape[2] != 3:
        raise SignalError(f"2D kernel must have shape (n, n, 3) with n odd, got {k.shape}")
    pad = k.shape[0] // 2
    padded = np.pad(img, ((pad, pad), (pad, pad), (0, 0)), mode="edge")
    return np.stack([fft_convolve(padded[..., c], k[..., c], "valid") for c in range(3)], axis=-1)


def kernel_on_pixels(kernel: AnyKernel, pixel_mm: float) -> Kernel:
    """The kernel as a tabulated :class:`Kernel` on the pixel grid (resampled or tap-deposited)."""
    from .kernels.base import TapKernel

    pixel_mm = LENGTH_MM.check(pixel_mm, "pixel_mm (the pixel's size in mm)", SignalError)
    if isinstance(kernel, TapKernel):
        return kernel.to_kernel(pixel_mm)
    if abs(kernel.cell_mm - pixel_mm) <= 1e-12 * pixel_mm:
        return kernel
    return kernel.resample(pixel_mm)


def apply_separable(image: np.ndarray, kernel: AnyKernel, pixel_mm: float) -> np.ndarray:
    """E * A for A = sum_i s_i a_i(x) a_i(y) as 2N 1D convolutions (paper Eq. 2), per channel.

    Horizontal then vertical pass per term, border pixels repeated (scipy.ndimage.convolve1d,
    mode 'nearest'); (H, W, 3) in and out.
    """
    from scipy.ndimage import convolve1d

    img = check_image(image)
    k = kernel_on_pixels(kernel, pixel_mm)
    w = k.cell_weights()
    out = np.zeros_like(img)
    for c in range(3):
        for i in range(k.rank):
            tmp = convolve1d(img[..., c], w[c, i], axis=1, mode="nearest")
            out[..., c] += k.signs[c, i] * convolve1d(tmp, w[c, i], axis=0, mode="nearest")
    return out


def exact_screen_space(gbuffer: GBuffer, profile: RGBProfile | Mapping[int, RGBProfile], fraction: float = 0.999) -> np.ndarray | None:
    """The exact 2D convolution (paper Eq. 1) of a G-buffer's diffuse layer on each SSS region,
    (H, W, 3) float32; None if the pixels are not square (the profile's cells are square).

    ``profile``: one :class:`RGBProfile` for every region, or a mapping profile id -> profile. Per
    region m (the pixels with one profile id) the pass's boundary rule is kept: samples off the region
    or off the image take the centre value, so

        M = (m E) * K + E (1 - m * K)

    with K the profile's exact cell integrals normalised to 1 (the albedo layer carries the total
    reflectance), on the pixel grid at the region's median depth: pixel size 1 / pixels_per_mm
    (:meth:`Camera.pixels_per_mm`), kernel radius the largest channel's ``fraction`` radius. Exact for a
    fronto-parallel surface (the slab scene); on curved surfaces it ignores the footprint's change with
    depth, which the pass does not. Pixels without SSS keep their diffuse value.
    """
    from .compute.fft import fft_convolve
    from .errors import ProfileError
    from .profiles.base import RGBProfile

    expected = "an RGBProfile (profile_for_material(material, model) makes one) or a mapping profile id -> RGBProfile"
    given = list(profile.values()) if isinstance(profile, Mapping) else [profile]
    bad = [type(p).__name__ for p in given if not isinstance(p, RGBProfile)]
    if bad:
        raise ProfileError(f"exact_screen_space needs {expected}, got {bad[0]}")
    fraction = RADIUS_FRACTION.check(fraction, "fraction (of the energy the kernel's radius holds)", SignalError)
    check_finite(gbuffer.diffuse, "the G-buffer's diffuse layer", SignalError, "colour values")
    cam = gbuffer.camera
    if abs(cam.fx - cam.fy) > 1e-6 * cam.fx:
        return None
    e = gbuffer.diffuse.astype(np.float64)
    out = e.copy()
    ids = [int(i) for i in np.unique(gbuffer.profile_id[gbuffer.profile_id > 0])]
    for pid in ids:
        prof = profile.get(pid) if isinstance(profile, Mapping) else profile
        if prof is None:
            raise SignalError(f"no profile given for profile id {pid}")
        m = (gbuffer.profile_id == pid).astype(np.float64)
        z = float(np.median(gbuffer.depth[m > 0]))  # world units, as pixels_per_mm takes it
        pixel_mm = 1.0 / float(cam.pixels_per_mm(z)[0])
        radius = float(np.max(prof.radius_at_fraction(fraction)))
        half = int(min(np.ceil(radius / pixel_mm), max(gbuffer.shape)))
        cells = prof.discretize_2d(pixel_mm, 2 * half + 1)
        cells = cells / cells.sum(axis=(0, 1))
        spread = fft_convolve(np.broadcast_to(m[..., None], e.shape), cells, "same", axes=(0, 1))
        res = fft_convolve(m[..., None] * e, cells, "same", axes=(0, 1)) + e * (1.0 - spread)
        out[m > 0] = res[m > 0]
    return out.astype(np.float32)


__all__ = [
    "apply_separable",
    "check_image",
    "convolve_2d",
    "exact_screen_space",
    "kernel_on_pixels",
]
