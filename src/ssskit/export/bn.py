"""The pre-integrated kernel as a ``.bn`` file (the binary kernel files of the 2015 separable-SSS code).

Layout (as the public loaders read it: the float count read as a float and floored, then that many
floats, four per sample): float32 little-endian throughout,

    [count]  then  count / 4 records (r, g, b, x)

with x the sample position in mm on a uniform grid symmetric about 0, increasing; r, g, b the 1D
kernel function there. Engines interpolate it linearly at their tap offsets, weight each tap by
its spacing and normalise per channel, so only the shape matters; ssskit writes the kernel's 1D
function a(x) (cell averages, mm^-1, separable-SSS paper Eq. 2 with rank 1) at the cell centres.

Only a rank-1 tabulated kernel with a positive sign fits the format (the pre-integrated kernel,
paper Eqs. 4-5, is one): a rank-N or signed kernel, or an engine tap kernel whose taps are not on a
uniform grid, is refused with the reason.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..errors import KernelError
from ..io import atomic_output, check_suffix, read_input
from ..quantities import Quantity, check_finite, check_shape

#: relative tolerance on the grid spacing and its symmetry about 0 when reading (float32 positions)
GRID_RTOL = 1e-4
#: the part of every channel's kernel mass a cropped grid keeps (:func:`crop_to_support`)
SAMPLES = Quantity(".bn samples", 2, 2**31 - 1, "", "a grid of two positions at least", integer=True)
SUPPORT = Quantity("the .bn support fraction", 0.0, 1.0, "", "a part of the kernel's mass", lo_open=True)


def bn_bytes(x_mm: Any, rgb: Any) -> bytes:
    """The file contents for samples at ``x_mm`` (n,) with values ``rgb`` (n, 3) (module docstring)."""
    x = check_shape(x_mm, ".bn positions", ("n",), KernelError, dtype=float)
    v = check_shape(rgb, ".bn values", (x.size, 3), KernelError, dtype=float, finite=True)
    SAMPLES.check(x.size, error=KernelError)
    _check_grid(x, "kernel")
    records = np.column_stack([v, x]).astype("<f4").ravel()
    return np.array([records.size], dtype="<f4").tobytes() + records.tobytes()


def _check_grid(x: np.ndarray, what: str) -> float:
    check_finite(x, f"{what}: sample positions", KernelError)
    steps = np.diff(x)
    h = float(np.mean(steps))
    if not (h > 0 and np.all(np.abs(steps - h) <= GRID_RTOL * h)):
        raise KernelError(f"{what}: sample positions must increase on a uniform grid")
    if abs(x[0] + x[-1]) > GRID_RTOL * h * max(1.0, x.size):
        raise KernelError(f"{what}: the grid must be symmetric about 0 (from {x[0]:.6g} to {x[-1]:.6g} mm)")
    return h


def crop_to_support(x_mm: np.ndarray, rgb: np.ndarray, support: float) -> tuple[np.ndarray, np.ndarray]:
    """The symmetric part of the grid that holds at least ``support`` of every channel's kernel mass (the
    public loaders take the file's extent as the tap range: a grid wider than the kernel wastes taps)."""
    SUPPORT.check(support, error=KernelError)
    mass = np.abs(np.asarray(rgb, dtype=float))
    total = mass.sum(axis=0)
    drop = 0
    while x_mm.size - 2 * (drop + 1) >= 3:
        kept = mass[drop + 1: x_mm.size - drop - 1].sum(axis=0)
        if np.any(kept < support * total):
            break
        drop += 1
    return x_mm[drop: x_mm.size - drop], rgb[drop: x_mm.size - drop]


def refuse_unfit(kernel: str, taps: bool, rank: int, positive: bool = True) -> None:
    """The format's rule (module docstring), stated once for a kernel (:func:`save_bn`) and for an export request's
    kernel spec before any work (:func:`ssskit.export.readers.material_source`): a :class:`KernelError` where
    ``kernel`` (its name in the message) is a list of taps (``taps``), or not one (``rank``) positive term."""
    if taps:
        raise KernelError(f"the .bn format holds a tabulated kernel on a uniform grid; {kernel} is a list of taps "
                          "(export it as hlsl, glsl or json)")
    if rank != 1 or not positive:
        raise KernelError(f"the .bn format holds one positive separable term; {kernel} has rank {rank} (use a rank-1 "
                          "method such as preintegrated, or export hlsl/glsl)")


def save_bn(kernel: Any, path: str | Path, support: float | None = None) -> None:
    """Write a rank-1 tabulated kernel (e.g. ``preintegrated``) as ``.bn`` (atomic); ``support`` (e.g.
    0.999): crop the grid symmetrically to the part holding that fraction of each channel's mass
    (:func:`crop_to_support`), since the engines' loaders tap the file's whole extent."""
    from ..kernels.base import Kernel

    check_suffix(path, (".bn",), "kernel output")
    tabulated = isinstance(kernel, Kernel)
    positive = not tabulated or bool(np.all(kernel.signs == 1))
    refuse_unfit(f"the {kernel.method} kernel", not tabulated, kernel.rank, positive)
    x, rgb = kernel.x_mm, kernel.components[:, 0, :].T
    if support is not None:
        x, rgb = crop_to_support(x, rgb, support)
    data = bn_bytes(x, rgb)
    with atomic_output(path) as tmp:
        tmp.write_bytes(data)


def read_bn(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """(x_mm (n,), rgb (n, 3)) of a ``.bn`` file, checked: size, record count, uniform symmetric grid."""
    p = Path(path)
    raw = read_input(p, ".bn file", KernelError)
    if len(raw) < 4 or len(raw) % 4:
        raise KernelError(f"{str(p)!r} is not a .bn kernel: {len(raw)} bytes is not a float count and float32 records")
    head = float(np.frombuffer(raw[:4], dtype="<f4")[0])
    body = np.frombuffer(raw[4:], dtype="<f4")
    if not np.isfinite(head) or int(np.floor(head)) != body.size or body.size % 4 or body.size < 8:
        raise KernelError(f"{str(p)!r} is not a .bn kernel: it announces {head:.6g} floats and holds {body.size} "
                          "(need a multiple of 4, at least two (r, g, b, x) records)")
    rec = body.reshape(-1, 4).astype(float)
    x, rgb = rec[:, 3], rec[:, :3]
    _check_grid(x, str(p))
    check_finite(rgb, f"{str(p)!r}: kernel values", KernelError)
    return x, rgb


def load_bn(path: str | Path) -> Any:
    """A ``.bn`` file as a rank-1 :class:`~ssskit.kernels.Kernel` (cell size: the grid spacing).

    The grid needs a centre sample (an odd count), as every ssskit kernel grid has.
    """
    from ..kernels.base import Kernel

    x, rgb = read_bn(path)
    if x.size % 2 == 0:
        raise KernelError(f"{str(path)!r}: {x.size} samples have no centre sample at 0 (ssskit kernels need an odd "
                          "grid); read_bn gives the raw samples")
    h = float((x[-1] - x[0]) / (x.size - 1))
    return Kernel(h, rgb.T[:, None, :], np.ones((3, 1)), "bn", {"samples": int(x.size)}, {"file": str(path)})


__all__ = ["bn_bytes", "load_bn", "read_bn", "save_bn"]
