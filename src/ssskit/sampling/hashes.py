"""Counter-based per-pixel random numbers: the same seed gives the same numbers on any thread count
and on every backend (numpy, numba, GLSL), because each pixel's value is a pure function of
(x, y, frame, seed), not a draw from a shared stream.

The mixing function is Wellons' ``lowbias32`` (an integer hash with near-ideal avalanche):

    h ^= h >> 16;  h *= 0x7FEB352D;  h ^= h >> 15;  h *= 0x846CA68B;  h ^= h >> 16      (mod 2^32)

chained over the inputs: base = mix(mix(seed ^ 0x9E3779B9) ^ frame), row = mix(base ^ y),
pixel = mix(row ^ x). A pixel's value u = pixel / 2^32 lies in [0, 1).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

MASK32 = 0xFFFFFFFF
GOLDEN32 = 0x9E3779B9


def mix32(value: ArrayLike) -> NDArray[np.uint64]:
    """lowbias32 on uint64 values holding 32-bit integers (module docstring)."""
    h = np.asarray(value, dtype=np.uint64)
    h = h ^ (h >> np.uint64(16))
    h = (h * np.uint64(0x7FEB352D)) & np.uint64(MASK32)
    h = h ^ (h >> np.uint64(15))
    h = (h * np.uint64(0x846CA68B)) & np.uint64(MASK32)
    return h ^ (h >> np.uint64(16))


def frame_base(frame: int, seed: int) -> int:
    """mix(mix(seed ^ golden) ^ frame): the per-frame key every pixel hash starts from."""
    base = mix32(np.uint64((int(seed) ^ GOLDEN32) & MASK32))
    return int(mix32(base ^ np.uint64(int(frame) & MASK32)))


def pixel_hashes(height: int, width: int, frame: int = 0, seed: int = 0) -> NDArray[np.uint64]:
    """(H, W) uint64 hashes mix(mix(base ^ y) ^ x), each a 32-bit value."""
    rows = mix32(np.uint64(frame_base(frame, seed)) ^ np.arange(height, dtype=np.uint64))
    return mix32(rows[:, None] ^ np.arange(width, dtype=np.uint64)[None, :])


def jitter_angles(height: int, width: int, frame: int = 0, seed: int = 0) -> NDArray[np.float64]:
    """theta(x, y, frame, seed) = 2 pi u in [0, 2 pi), (H, W) float64: the jitter rotation of the
    separable pass (separable-SSS paper section 6)."""
    return pixel_hashes(height, width, frame, seed).astype(np.float64) * (2.0 * math.pi / 4294967296.0)
