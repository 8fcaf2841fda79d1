"""The global TAA resolve (Karis 2014): reprojection, YCoCg neighbourhood clamping, the blend weight and
disocclusion, checked against properties that follow from its definition (no stored outputs)."""

import numpy as np
import pytest

from ssskit.errors import PassError, SettingsError
from ssskit.screenspace import Camera, motion_vectors
from ssskit.screenspace.taa import (
    TAASettings,
    TemporalAA,
    fetch,
    neighbourhood_box,
    reprojection_valid,
    rgb_to_ycocg,
    taa_resolve,
    ycocg_to_rgb,
)

FETCHES = ("bilinear", "catmull-rom")


def test_ycocg_round_trip_and_luma(rng):
    rgb = rng.random((5, 7, 3))
    assert np.allclose(ycocg_to_rgb(rgb_to_ycocg(rgb)), rgb, atol=1e-12)
    grey = np.full((2, 2, 3), 0.3)
    assert np.allclose(rgb_to_ycocg(grey), [0.3, 0.0, 0.0])  # grey has no chroma, Y = the grey level


@pytest.mark.parametrize("filt", FETCHES)
def test_fetch_is_exact_at_pixel_centres_and_reproduces_a_linear_ramp(filt):
    h, w = 12, 16
    v, u = np.mgrid[0:h, 0:w] + 0.5
    ramp = np.stack([u, v, 2 * u - v], axis=-1)
    assert np.allclose(fetch(ramp, u, v, filt), ramp)
    # both filters reproduce linear functions exactly away from the clamped edges
    x, y = u + 0.37, v - 0.61
    inner = (slice(2, -2), slice(2, -2))
    got = fetch(ramp, x, y, filt)[inner]
    want = np.stack([x, y, 2 * x - y], axis=-1)[inner]
    assert np.allclose(got, want, atol=1e-12)


@pytest.mark.parametrize("filt", FETCHES)
def test_a_static_camera_skips_the_fetch_with_the_same_bits(filt, rng):
    """motion None (a static camera) takes the history at the pixel centres without a fetch: the very numbers
    of the fetch with zero motion, where each filter's weights are 0, 1, 0..."""
    cur, hist = rng.random((9, 13, 3)), rng.random((9, 13, 3))
    valid = rng.random((9, 13)) > 0.2
    s = TAASettings(fetch=filt)
    still = taa_resolve(cur, hist, None, valid, s)
    np.testing.assert_array_equal(still, taa_resolve(cur, hist, np.zeros((9, 13, 2)), valid, s))


@pytest.mark.parametrize("filt", FETCHES)
@pytest.mark.parametrize("kind", ("minmax", "variance", "none"))
def test_constant_image_stays_constant_under_camera_motion(filt, kind):
    h, w = 24, 32
    c0 = Camera.from_fov(w, h, 40.0)
    m = np.eye(4)
    m[:3, 3] = [1.5, -0.7, 0.3]
    c1 = Camera.from_fov(w, h, 40.0, world_to_camera=m)
    depth = np.full((h, w), 50.0)
    depth[8:16, 10:20] = 30.0  # a nearer box: the motion differs across it
    mv = motion_vectors(depth, c1, c0)
    assert np.abs(mv).max() > 0.5
    colour = np.array([0.2, 0.5, 0.9], np.float32)
    frame = np.broadcast_to(colour, (h, w, 3))
    taa = TemporalAA(TAASettings(alpha=0.1, neighbourhood=kind, fetch=filt))
    for _ in range(5):
        out = taa.resolve(frame, motion=mv)
    assert np.allclose(out, colour, atol=1e-6)


def test_motion_fetches_the_previous_position():
    """A surface moved one pixel right: each pixel's history comes from one pixel left."""
    rng = np.random.default_rng(3)
    h, w = 10, 12
    hist = rng.random((h, w, 3)).astype(np.float32)
    cur = rng.random((h, w, 3)).astype(np.float32)
    mv = np.zeros((h, w, 2))
    mv[..., 0] = -1.0
    a = 0.25
    for filt in FETCHES:
        out, weight = taa_resolve(cur, hist, mv, settings=TAASettings(alpha=a, neighbourhood="none", fetch=filt),
                                  return_weight=True)
        assert np.allclose(out[:, 1:], (1 - a) * hist[:, :-1] + a * cur[:, 1:], atol=1e-6)
        # column 0's previous position is off-screen: disocclusion, the current frame
        assert np.allclose(out[:, 0], cur[:, 0])
        assert np.all(weight[:, 0] == 1.0) and np.all(weight[:, 1:] == a)


def ema_variance(a, frames):
    """Variance of an EMA of iid unit-variance values started from the first value, after ``frames``
    values: (1 - a)^(2(f-1)) + a^2 * sum_{k<f-1} (1 - a)^(2k)."""
    f = frames - 1
    return (1 - a) ** (2 * f) + a * a * (1 - (1 - a) ** (2 * f)) / (1 - (1 - a) ** 2)


def test_static_noisy_sequence_variance_falls_like_an_ema():
    rng = np.random.default_rng(11)
    h, w, sd, mean = 64, 64, 0.05, np.array([0.4, 0.5, 0.3])
    a = 0.1
    taa = TemporalAA(TAASettings(alpha=a, neighbourhood="none"))
    for f in range(1, 121):
        out = taa.resolve(mean + sd * rng.standard_normal((h, w, 3)))
        if f in (1, 5, 20, 120):
            var = out.astype(np.float64).var(axis=(0, 1)) / sd**2
            # 4096 independent pixels: the sample variance has ~2.2 % relative spread
            assert np.allclose(var, ema_variance(a, f), rtol=0.1), (f, var, ema_variance(a, f))
    assert np.allclose(out.mean(axis=(0, 1)), mean, atol=4 * sd * np.sqrt(a / (2 - a) / (h * w)))


@pytest.mark.parametrize("kind", ("minmax", "variance"))
def test_clamped_static_noisy_sequence_converges_towards_its_mean(kind):
    """With the clamp the noise still falls well below a single frame's (the box of 9 noisy neighbours
    holds the mean), and the mean stays put: a symmetric noise is clamped symmetrically."""
    rng = np.random.default_rng(12)
    h, w, sd, mean = 64, 64, 0.05, np.array([0.4, 0.5, 0.3])
    taa = TemporalAA(TAASettings(alpha=0.1, neighbourhood=kind))
    for _ in range(60):
        out = taa.resolve(mean + sd * rng.standard_normal((h, w, 3)))
    var = out.astype(np.float64).var(axis=(0, 1)) / sd**2
    assert np.all(var < 0.1), var  # a single frame: 1; the unclamped EMA: a / (2 - a) = 0.053
    assert np.allclose(out.mean(axis=(0, 1)), mean, atol=0.01 * sd * 10)


def test_clamping_bounds_the_output_by_the_neighbourhood():
    rng = np.random.default_rng(5)
    h, w = 20, 24
    cur = (0.5 + 0.5 * rng.random((h, w, 3))).astype(np.float32)  # every box corner is a non-negative colour
    hist = (3.0 * rng.random((h, w, 3)) - 1.0).astype(np.float32)  # far outside it
    low, high = neighbourhood_box(rgb_to_ycocg(cur.astype(np.float64)), "minmax")
    out = taa_resolve(cur, hist, settings=TAASettings(alpha=0.1, neighbourhood="minmax"))
    y = rgb_to_ycocg(out.astype(np.float64))
    assert np.all(y >= low - 1e-6) and np.all(y <= high + 1e-6)
    # without clamping the same history leaves the box
    free = rgb_to_ycocg(taa_resolve(cur, hist, settings=TAASettings(alpha=0.1, neighbourhood="none")).astype(float))
    assert np.any((free < low - 1e-3) | (free > high + 1e-3))
    # the variance box lies inside the min/max box
    vlow, vhigh = neighbourhood_box(rgb_to_ycocg(cur.astype(np.float64)), "variance", 1.0)
    assert np.all(vlow >= low) and np.all(vhigh <= high) and np.all(vlow <= vhigh)
    # "none" clamps nothing, so it is no box: refused by name ("none" is TAASettings' choice, not a box)
    with pytest.raises(PassError, match="neighbourhood must be one of minmax, variance, got 'none'"):
        neighbourhood_box(rgb_to_ycocg(cur.astype(np.float64)), "none")


def test_disocclusion_takes_the_current_frame():
    rng = np.random.default_rng(6)
    h, w = 8, 9
    cur = rng.random((h, w, 3)).astype(np.float32)
    hist = rng.random((h, w, 3)).astype(np.float32)
    valid = rng.random((h, w)) < 0.5
    out, weight = taa_resolve(cur, hist, valid=valid, settings=TAASettings(alpha=0.1, neighbourhood="none"),
                              return_weight=True)
    assert np.array_equal(out[~valid], cur[~valid])
    assert np.allclose(out[valid], 0.9 * hist[valid] + 0.1 * cur[valid], atol=1e-6)
    assert np.all(weight[~valid] == 1.0) and np.all(weight[valid] == 0.1)
    assert np.array_equal(taa_resolve(cur, None), cur)  # the first frame


def test_reprojection_valid_finds_disoccluded_and_off_screen_pixels():
    h, w = 20, 30
    cam = Camera.from_fov(w, h, 50.0)
    before = np.full((h, w), 100.0)
    before[5:12, 8:18] = 40.0  # an occluder that has gone this frame
    now = np.full((h, w), 100.0)
    ok = reprojection_valid(now, cam, before, cam)
    assert not ok[5:12, 8:18].any()
    ok[5:12, 8:18] = True
    assert ok.all()
    # the camera slides right: the pixels entering on the right were off-screen before
    m = np.eye(4)
    m[0, 3] = -10.0  # camera at x = +10
    moved = Camera.from_fov(w, h, 50.0, world_to_camera=m)
    ok = reprojection_valid(now, moved, np.full((h, w), 100.0), cam)
    shift = 10.0 * cam.fx / 100.0  # pixels
    assert not ok[:, -int(shift) + 1:].any() and ok[:, : w - int(np.ceil(shift)) - 1].all()
    # no surface now and none before: background, valid
    assert reprojection_valid(np.full((h, w), np.inf), cam, np.full((h, w), np.inf), cam).all()


def test_bad_inputs_raise():
    with pytest.raises(SettingsError):
        TAASettings(alpha=0.0)
    with pytest.raises(SettingsError):
        TAASettings(alpha=1.5)
    with pytest.raises(SettingsError):
        TAASettings(neighbourhood="box")
    with pytest.raises(SettingsError):
        TAASettings(fetch="nearest")
    with pytest.raises(SettingsError):
        TAASettings(gamma=0.0)
    cur = np.zeros((4, 5, 3))
    with pytest.raises(PassError):
        taa_resolve(cur, np.zeros((5, 4, 3)))
    with pytest.raises(PassError):
        taa_resolve(cur, cur, motion=np.zeros((4, 5)))
    with pytest.raises(PassError):
        taa_resolve(np.full((4, 5, 3), np.nan))
    taa = TemporalAA()
    taa.resolve(cur)
    with pytest.raises(PassError):
        taa.resolve(np.zeros((3, 3, 3)))


def test_taa_jitter_is_the_halton_2_3_sequence_less_a_half():
    """Karis 2014's jittered projection, Unreal's 8 samples: frame f takes Halton point f mod 8 + 1 in bases 2 and 3
    (the radical inverse: 1 -> 1/2 and 1/3, 2 -> 1/4 and 2/3, 3 -> 3/4 and 1/9, 8 -> 1/16 and 8/9), less 1/2; the
    offsets repeat every 8 frames and are distinct within them."""
    from fractions import Fraction

    from ssskit.screenspace.taa import halton, taa_jitter

    for i, b, want in ((1, 2, Fraction(1, 2)), (2, 2, Fraction(1, 4)), (3, 2, Fraction(3, 4)), (8, 2, Fraction(1, 16)),
                       (1, 3, Fraction(1, 3)), (2, 3, Fraction(2, 3)), (3, 3, Fraction(1, 9)), (8, 3, Fraction(8, 9))):
        assert halton(i, b) == pytest.approx(float(want), abs=1e-15)
    offs = [taa_jitter(f) for f in range(8)]
    assert offs[0] == pytest.approx((0.0, 1 / 3 - 0.5)) and taa_jitter(8) == offs[0]
    assert len(set(offs)) == 8 and all(-0.5 <= x < 0.5 for o in offs for x in o)
