"""The lateral spread of the transmitted light (backends.spread_plan) on every backend: parity with the float64
oracle, a uniform light stays uniform, a constant width conserves energy and spreads a point as the Gaussian
of that width, narrower than min_px leaves the frame alone, nothing crosses profile ids, and the checks."""

import math

import numpy as np
import pytest

from ssskit.backends import get_backend
from ssskit.backends.numpy_backend import spread_pass
from ssskit.backends.spread_plan import SlotSpread, build_spread_plan, taps
from ssskit.errors import PassError

H, W, HS, WS = 30, 40, 24, 28
FX = FY = 200.0


def _spread(sigma_mm, knots=(0.0,)):
    w = np.broadcast_to(np.asarray(sigma_mm, float).reshape(3, -1), (3, len(knots))).copy()
    return SlotSpread(np.asarray(knots, float), w)


def _frame(seed=1, depth=None, h=H, w=W, ids=2):
    """Two profile ids in blocks (or one) with a depth step, a map at ~100 mm, points 0-5 mm behind it; exitance
    random."""
    r = np.random.default_rng(seed)
    slots = np.ones((h, w), np.int32)
    if ids == 2:
        slots[:, w // 2:] = 2
    slots[:3] = 0
    z = np.full((h, w), 100.0) if depth is None else np.asarray(depth, float)
    if depth is None:
        z[h // 2:, :] += 6.0  # a depth step inside both ids
        z += r.uniform(0, 0.3, (h, w))
    shadow = (100.0 + r.uniform(0, 1, (HS, WS))).astype(np.float32)
    x = r.uniform(0.0, WS, (h, w))
    y = r.uniform(0.0, HS, (h, w))
    from ssskit.backends.numpy_backend import shadow_depth

    d = shadow_depth(shadow.astype(np.float64), x, y)
    uvz = np.stack([x, y, d + r.uniform(0.0, 5.0, (h, w))], -1).astype(np.float32)
    ex = r.uniform(0.0, 1.0, (h, w, 3)).astype(np.float32)
    ex[slots == 0] = 0.0
    return ex, z.astype(np.float32), slots, uvz, shadow


@pytest.fixture
def plan():
    """Widths growing with thickness (mm), one pixel ~ 0.5 mm at 100 mm: 1 to 12 pixels, the taps strided."""
    knots = (0.0, 1.0, 2.5, 5.0)
    return build_spread_plan({1: _spread([[0.1, 0.4, 1.0, 3.0], [0.1, 0.3, 0.6, 1.5], [0.05, 0.2, 0.4, 0.8]], knots),
                              2: _spread([[0.3, 0.8, 1.2, 2.0]] * 3, knots)}, FX, FY)


@pytest.mark.parametrize("shape", [(H, W, 2), (24, 70, 1), (20, 13, 2)], ids=["two-ids", "one-id", "narrow"])
def test_backend_parity(backend, plan, shape):
    """|backend - oracle| <= 3e-5 of the frame's largest exitance: float32 weights rounded to ~1e-7 relative,
    summed over at most 2 x 33 taps in two passes. Frames with two ids side by side, with one (blocks of one id:
    the numba kernel's sweep over the knots), and narrower than the numba kernel's blocks of pixels."""
    h, w, ids = shape
    frame = _frame(h=h, w=w, ids=ids)
    out = np.asarray(get_backend(backend).transmission_spread(plan, *frame), np.float64)
    ref = spread_pass(plan, *frame)
    assert out.shape == (h, w, 3)
    assert np.max(np.abs(out - ref)) <= 3e-5 * float(np.max(frame[0]))
    assert np.max(np.abs(ref - frame[0])) > 0.05  # the frame is spread


def test_uniform_light_stays_uniform_and_nothing_crosses_ids(backend, plan):
    ex, z, slots, uvz, shadow = _frame(seed=2)
    b = get_backend(backend)
    flat = np.broadcast_to(np.where((slots > 0)[..., None], np.float32(0.7), np.float32(0.0)), ex.shape)
    flat = np.ascontiguousarray(flat, np.float32)
    np.testing.assert_allclose(b.transmission_spread(plan, flat, z, slots, uvz, shadow), flat, rtol=2e-6, atol=0)
    base = b.transmission_spread(plan, ex, z, slots, uvz, shadow)
    other = ex.copy()
    other[slots == 2] *= 3.0
    changed = b.transmission_spread(plan, other, z, slots, uvz, shadow)
    np.testing.assert_array_equal(changed[slots == 1], base[slots == 1])
    np.testing.assert_array_equal(changed[slots == 0], ex[slots == 0])


def test_constant_width_conserves_energy_and_spreads_a_point_as_its_gaussian():
    """A fronto-parallel frame (one depth), one width: the weights are symmetric, so the spread moves light and
    never makes or loses it; a point's light spreads with variance sigma^2 along each axis (the Gaussian
    sampled to 3 sigma, which holds 97.3 % of its variance; 4.2 pixels, so that no tap sits on the support's edge,
    where float32 and float64 may decide apart)."""
    sigma_mm = 2.1
    n = 101
    plan = build_spread_plan({1: _spread([sigma_mm] * 3)}, FX, FY)
    z = np.full((n, n), 100.0, np.float32)
    slots = np.ones((n, n), np.int32)
    uvz = np.zeros((n, n, 3), np.float32)
    shadow = np.full((4, 4), np.inf, np.float32)  # no map: t = 0 everywhere, the width of t = 0
    ex = np.zeros((n, n, 3), np.float32)
    ex[n // 2, n // 2] = 1.0
    rng = np.random.default_rng(4)
    noise = rng.uniform(0, 1, (n, n, 3)).astype(np.float32)
    for name in ("numpy", "numba"):
        b = get_backend(name)
        out = np.asarray(b.transmission_spread(plan, ex, z, slots, uvz, shadow), np.float64)
        assert out.sum() == pytest.approx(3.0, rel=1e-5)
        px = sigma_mm * FX / 100.0  # 4.2 pixels
        ys, xs = np.mgrid[0:n, 0:n] - n // 2
        w = out[..., 0]
        var_x = float(np.sum(w * xs ** 2) / w.sum())
        var_y = float(np.sum(w * ys ** 2) / w.sum())
        assert var_x == pytest.approx(0.973 * px ** 2, rel=0.01) and var_y == pytest.approx(var_x, rel=1e-6)
        spread = np.asarray(b.transmission_spread(plan, noise, z, slots, uvz, shadow), np.float64)
        assert spread.sum() == pytest.approx(float(noise.astype(np.float64).sum()), rel=1e-5)


def test_narrower_than_min_px_leaves_the_frame_alone(backend):
    frame = _frame(seed=3)
    plan = build_spread_plan({1: _spread([0.2] * 3), 2: _spread([0.1] * 3)}, FX, FY)  # <= 0.4 px at 100 mm
    np.testing.assert_array_equal(get_backend(backend).transmission_spread(plan, *frame), frame[0])


def test_taps_and_checks(plan):
    assert taps(4.0, 16) == (1, 12) and taps(10.0, 16) == (2, 15) and taps(0.6, 16) == (1, 2)
    ex, z, slots, uvz, shadow = _frame()
    b = get_backend("numpy")
    with pytest.raises(PassError, match="exitance"):
        b.transmission_spread(plan, ex[:, :-1], z, slots, uvz, shadow)
    with pytest.raises(PassError, match="slots"):
        b.transmission_spread(plan, ex, z, slots + 5, uvz, shadow)
    with pytest.raises(PassError, match="depth"):
        b.transmission_spread(plan, ex, np.where(slots > 0, -1.0, z), slots, uvz, shadow)
    with pytest.raises(PassError, match="ascending"):
        build_spread_plan({1: SlotSpread(np.array([1.0, 0.5]), np.ones((3, 2)))}, FX, FY)
    with pytest.raises(PassError, match=r"^profile id 1: the spread's knots_mm must lie in \[0, inf\) mm, got -1"):
        build_spread_plan({1: SlotSpread(np.array([-1.0, 0.5]), np.ones((3, 2)))}, FX, FY)
    with pytest.raises(PassError, match=r"^profile id 1: the spread's sigma_mm must be a real array of shape \(3, 2\)"):
        build_spread_plan({1: SlotSpread(np.array([0.0, 0.5]), np.ones((3, 3)))}, FX, FY)
    with pytest.raises(PassError, match="focal"):
        build_spread_plan({1: _spread([1.0] * 3)}, math.nan, FY)
    with pytest.raises(PassError, match="profile ids"):
        build_spread_plan({0: _spread([1.0] * 3)}, FX, FY)


def test_a_noisy_width_moves_light_without_losing_it(backend):
    """Each pixel's thickness (so its width, 0.8 to 4.8 pixels) drawn at random, and the light brighter where
    thicker, as a G-buffer's noisy depth makes it: the pair weights give back what they take, so the frame's
    light changes by 0.6 % (where each receiver used its own width alone: 5.1 % lost); a smooth width loses none."""
    n = 80
    plan = build_spread_plan({1: SlotSpread(np.array([0.0, 4.0]), np.array([[0.4, 2.4]] * 3))}, FX, FY)
    z = np.full((n, n), 100.0, np.float32)
    slots = np.ones((n, n), np.int32)
    shadow = np.full((8, 8), 100.0, np.float32)
    b = get_backend(backend)
    noisy = np.random.default_rng(3).uniform(0.0, 4.0, (n, n))
    smooth = np.broadcast_to(np.linspace(0.0, 4.0, n), (n, n))
    for t, bound, moved in ((noisy, 0.01, 0.05), (smooth, 1e-5, 0.005)):
        uvz = np.stack([np.full((n, n), 4.0), np.full((n, n), 4.0), 100.0 + t], -1).astype(np.float32)
        v = np.repeat((0.1 + 0.2 * t)[..., None], 3, -1).astype(np.float32)
        out = np.asarray(b.transmission_spread(plan, v, z, slots, uvz, shadow), np.float64)
        change = out.sum() / v.astype(np.float64).sum() - 1.0
        assert abs(change) < bound, change
        assert np.abs(out - v).max() > moved


def test_numba_result_is_the_same_on_any_thread_count(plan):
    """Rows split among threads (frames of 64 rows or more) give the image of one thread, bit for bit."""
    numba = pytest.importorskip("numba")
    r = np.random.default_rng(5)
    h, w = 70, 97
    slots = np.where(r.uniform(size=(h, w)) < 0.9, 1, 2).astype(np.int32)
    slots[:, :5] = 0
    z = (100.0 + r.uniform(0, 3, (h, w))).astype(np.float32)
    shadow = (100.0 + r.uniform(0, 1, (HS, WS))).astype(np.float32)
    uvz = np.stack([r.uniform(0, WS, (h, w)), r.uniform(0, HS, (h, w)), 101.0 + r.uniform(0, 4, (h, w))],
                   -1).astype(np.float32)
    ex = r.uniform(0.0, 1.0, (h, w, 3)).astype(np.float32)
    b = get_backend("numba")
    prev = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = b.transmission_spread(plan, ex, z, slots, uvz, shadow)
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        many = b.transmission_spread(plan, ex, z, slots, uvz, shadow)
    finally:
        numba.set_num_threads(prev)
    np.testing.assert_array_equal(one, many)
    assert np.max(np.abs(one - ex)) > 0.05
