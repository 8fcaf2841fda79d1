"""Ground truth on G-buffers: the exact screen-space 2D convolution (paper Eq. 1 with the pass's
boundary rule)."""

import numpy as np
import pytest
from scipy.signal import fftconvolve

from ssskit.errors import SignalError
from ssskit.profiles import profile_for_material
from ssskit.screenspace import Camera, GBuffer
from ssskit.truth import exact_screen_space


@pytest.fixture(scope="module")
def skin():
    return profile_for_material("skin1", "dipole")


def _gbuffer(pid, diffuse=None, depth=600.0, fx=900.0, fy=None, units_per_mm=1.0):
    h, w = pid.shape
    cam = Camera(w, h, fx, fx if fy is None else fy, w / 2, h / 2, world_units_per_mm=units_per_mm)
    rng = np.random.default_rng(5)
    return GBuffer(diffuse=rng.random((h, w, 3)).astype(np.float32) if diffuse is None else diffuse,
                   albedo=np.ones((h, w, 3), np.float32), depth=np.full((h, w), depth, np.float32),
                   profile_id=pid.astype(np.uint32), camera=cam)


def _oracle(gb, profile, pixel_mm, fraction=0.999):
    """M = (m E) * K + E (1 - m * K) per channel and region, written out channel by channel."""
    e = gb.diffuse.astype(np.float64)
    out = e.copy()
    radius = float(np.max(profile.radius_at_fraction(fraction)))
    half = int(min(np.ceil(radius / pixel_mm), max(gb.shape)))
    cells = profile.discretize_2d(pixel_mm, 2 * half + 1)
    cells = cells / cells.sum(axis=(0, 1))
    for pid in np.unique(gb.profile_id[gb.profile_id > 0]):
        m = (gb.profile_id == pid).astype(np.float64)
        for c in range(3):
            k = cells[..., c]
            res = fftconvolve(m * e[..., c], k, mode="same") + e[..., c] * (1.0 - fftconvolve(m, k, mode="same"))
            out[..., c][m > 0] = res[m > 0]
    return out


def test_matches_the_channelwise_formula_with_pixels_per_mm(skin):
    pid = np.zeros((40, 56), np.uint32)
    pid[5:35, 8:50] = 1
    # 1200 world units at 2 units per mm = 600 mm; fx = 900 px -> 1.5 px per mm
    gb = _gbuffer(pid, depth=1200.0, units_per_mm=2.0)
    got = exact_screen_space(gb, skin)
    np.testing.assert_allclose(got, _oracle(gb, skin, 600.0 / 900.0), rtol=1e-5, atol=1e-6)
    np.testing.assert_array_equal(got[pid == 0], gb.diffuse[pid == 0])


def test_constant_region_unchanged_and_regions_do_not_mix(skin):
    pid = np.ones((32, 32), np.uint32)
    pid[:, 16:] = 2
    diffuse = np.ones((32, 32, 3), np.float32)
    diffuse[:, 16:] = 3.0
    gb = _gbuffer(pid, diffuse)
    apple = profile_for_material("apple", "dipole")
    got = exact_screen_space(gb, {1: skin, 2: apple})
    np.testing.assert_allclose(got, diffuse, rtol=1e-5)


def test_non_square_pixels_and_missing_profiles(skin):
    pid = np.ones((16, 16), np.uint32)
    assert exact_screen_space(_gbuffer(pid, fy=450.0), skin) is None
    with pytest.raises(SignalError, match="profile id 1"):
        exact_screen_space(_gbuffer(pid), {2: skin})


def test_wrong_profile_fraction_and_pixel_size_are_refused(skin):
    """A material or a name where a profile is expected, a fraction outside (0, 1), a pixel size that is not
    a finite positive number: each a precise SsskitError, not an AttributeError, a ZeroDivisionError or the
    input returned unchanged."""
    from ssskit.errors import ProfileError
    from ssskit.kernels import build_kernel
    from ssskit.materials import get_material
    from ssskit.truth import apply_separable

    gb = _gbuffer(np.ones((16, 16), np.uint32))
    for wrong in (get_material("skin1"), "skin1", {1: "skin1"}):
        with pytest.raises(ProfileError, match="needs an RGBProfile"):
            exact_screen_space(gb, wrong)
    for fraction in (0.0, -0.5, 1.0, float("nan")):
        with pytest.raises(SignalError, match=r"fraction .* must lie in \(0, 1\)"):
            exact_screen_space(gb, skin, fraction=fraction)
    gb.diffuse[3, 4, 1] = np.nan  # after the G-buffer's own check: every output pixel was NaN, no error
    with pytest.raises(SignalError, match="diffuse layer must be finite"):
        exact_screen_space(gb, skin)
    k = build_kernel("svd", skin, 0.1, 21)
    for pixel_mm in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(SignalError, match="pixel_mm"):
            apply_separable(np.ones((8, 8, 3)), k, pixel_mm)
