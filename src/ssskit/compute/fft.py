"""Linear convolution by FFT, the engine of the exact 2D convolutions (:mod:`ssskit.truth`, the Burley pass's
exact limit in :mod:`ssskit.pipeline.burley_frame`).

The arithmetic of ``scipy.signal.fftconvolve`` for real arrays (the convolution theorem: real FFTs of both
inputs zero-padded to the next fast length at or above the full size a + k - 1, their product, the inverse
FFT, the part the mode keeps), through :mod:`scipy.fft` alone: importing ``scipy.signal`` takes 2-3 s on a
fresh start (most of a first ``ssskit render``'s imports), ``scipy.fft`` a tenth of that.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

MODES = ("full", "same", "valid")


def fft_convolve(a: ArrayLike, k: ArrayLike, mode: str = "full",
                 axes: Sequence[int] | None = None) -> NDArray[np.float64]:
    """The linear convolution a * k of two real arrays of the same number of dimensions along ``axes`` (default:
    every axis), float64; along the other axes the sizes must agree or one be 1 (broadcast). ``mode``:
    ``full`` (size a + k - 1 along ``axes``), ``same`` (a's size, the centre of the full result, as
    ``scipy.signal.fftconvolve`` centres it) or ``valid`` (a - k + 1: where k lies inside a; a must be at
    least k along ``axes``)."""
    from scipy import fft

    x = np.asarray(a, dtype=np.float64)
    y = np.asarray(k, dtype=np.float64)
    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
    if x.ndim != y.ndim:
        raise ValueError(f"the arrays must have the same number of dimensions, got {x.ndim} and {y.ndim}")
    ax = sorted({int(i) % x.ndim for i in (range(x.ndim) if axes is None else axes)})
    for i in range(x.ndim):
        if i not in ax and x.shape[i] != y.shape[i] and 1 not in (x.shape[i], y.shape[i]):
            raise ValueError(f"axis {i} is not convolved and its sizes differ: {x.shape[i]} and {y.shape[i]}")
    if mode == "valid" and any(x.shape[i] < y.shape[i] for i in ax):
        raise ValueError(f"mode 'valid' needs the first array at least as large as the second along {ax}")
    full = [x.shape[i] + y.shape[i] - 1 if i in ax else max(x.shape[i], y.shape[i]) for i in range(x.ndim)]
    fshape = [fft.next_fast_len(full[i], True) for i in ax]
    out = fft.irfftn(fft.rfftn(x, fshape, axes=ax) * fft.rfftn(y, fshape, axes=ax), fshape, axes=ax)
    out = out[tuple(slice(n) for n in full)]
    if mode == "full":
        return np.array(out)
    keep = [(x.shape[i] if mode == "same" else x.shape[i] - y.shape[i] + 1) if i in ax else full[i]
            for i in range(x.ndim)]
    start = [(n - m) // 2 for n, m in zip(full, keep)]
    return np.array(out[tuple(slice(s, s + m) for s, m in zip(start, keep))])


__all__ = ["MODES", "fft_convolve"]
