"""ssskit.compute.fft: the FFT convolution of the exact 2D convolutions against the direct sum and against
scipy.signal.fftconvolve (the routine it replaces, whose import costs a first render seconds)."""

import numpy as np
import pytest

from ssskit.compute.fft import fft_convolve


def _direct(a: np.ndarray, k: np.ndarray) -> np.ndarray:
    """The full 2D linear convolution by its definition, sum_j a[i - j] k[j]."""
    out = np.zeros((a.shape[0] + k.shape[0] - 1, a.shape[1] + k.shape[1] - 1) + a.shape[2:])
    for y in range(k.shape[0]):
        for x in range(k.shape[1]):
            out[y:y + a.shape[0], x:x + a.shape[1]] += a * k[y, x]
    return out


@pytest.mark.parametrize("shape_a, shape_k", [((9, 13), (5, 3)), ((6, 7, 3), (11, 11, 3)), ((17, 8, 3), (3, 5, 1))])
def test_the_full_convolution_is_the_direct_sum(shape_a, shape_k):
    rng = np.random.default_rng(1)
    a, k = rng.random(shape_a), rng.random(shape_k)
    axes = (0, 1) if len(shape_a) == 3 else None
    direct = _direct(a, k)
    np.testing.assert_allclose(fft_convolve(a, k, "full", axes), direct, rtol=1e-12, atol=1e-12 * np.abs(direct).max())


@pytest.mark.parametrize("mode", ["full", "same", "valid"])
@pytest.mark.parametrize("shape_a, shape_k", [((20, 15), (7, 5)), ((12, 9, 3), (21, 21, 3)), ((30, 31, 3), (9, 9, 3))])
def test_every_mode_is_scipy_signals(mode, shape_a, shape_k):
    from scipy.signal import fftconvolve

    rng = np.random.default_rng(2)
    a, k = rng.random(shape_a), rng.random(shape_k)
    axes = (0, 1) if len(shape_a) == 3 else None
    if mode == "valid" and any(n < m for n, m in zip(shape_a[:2], shape_k[:2])):
        with pytest.raises(ValueError, match="at least as large"):
            fft_convolve(a, k, mode, axes)
        return
    want = fftconvolve(a, k, mode=mode, axes=axes)
    got = fft_convolve(a, k, mode, axes)
    assert got.shape == want.shape
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13 * np.abs(want).max())


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="mode must be one of full, same, valid"):
        fft_convolve(np.ones((3, 3)), np.ones((3, 3)), "circular")
    with pytest.raises(ValueError, match="same number of dimensions"):
        fft_convolve(np.ones((3, 3)), np.ones(3))
    with pytest.raises(ValueError, match="axis 2 is not convolved and its sizes differ"):
        fft_convolve(np.ones((3, 3, 3)), np.ones((3, 3, 2)), axes=(0, 1))
