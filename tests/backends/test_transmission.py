"""The transmittance pass (backends.transmission_plan) on every backend: parity with the float64 oracle in
float32 ulps, zero thickness and zero back-light give zero, the result never exceeds T(t) x E, nothing
crosses profile ids, and Jimenez 2010's model is the shader's formula."""

import numpy as np
import pytest

from ssskit.backends import get_backend
from ssskit.backends.numpy_backend import transmission_pass
from ssskit.backends.transmission_plan import SlotModel, build_transmission_plan
from ssskit.errors import BackendError, PassError
from ssskit.screenspace.transmission import jimenez2010_model

H, W, HS, WS = 24, 32, 40, 36


def _model(scale=1.0, wrap=0.0, k=3, seed=0):
    r = np.random.default_rng(seed)
    return SlotModel(r.uniform(0.05, 0.4, (3, k)), r.uniform(0.1, 1.5, (3, k)), r.uniform(0.0, 0.05, (3, k)),
                     scale, wrap)


def _frame(seed=1):
    """Two profile ids, a map at ~100 mm with holes, points behind it (t in [0.01, 9] mm, none within 2x the
    bias of zero) or in front of it, some off the map."""
    r = np.random.default_rng(seed)
    shadow = (100.0 + r.uniform(0, 5, (HS, WS))).astype(np.float32)
    shadow[r.random((HS, WS)) < 0.05] = np.inf
    slots = r.integers(0, 3, (H, W)).astype(np.int32)
    x = r.uniform(-1.0, WS + 1.0, (H, W))
    y = r.uniform(-1.0, HS + 1.0, (H, W))
    t = r.uniform(0.01, 9.0, (H, W))
    t[r.random((H, W)) < 0.1] = -r.uniform(0.01, 3.0)  # in front of the map's surface: lit directly
    uvz = np.stack([x, y, np.zeros((H, W))], -1).astype(np.float32)
    from ssskit.backends.numpy_backend import shadow_depth

    d = shadow_depth(shadow.astype(np.float64), uvz[..., 0].astype(np.float64), uvz[..., 1].astype(np.float64))
    uvz[..., 2] = np.where(np.isfinite(d), d + t, 100.0).astype(np.float32)
    ndl = r.uniform(-1, 1, (H, W)).astype(np.float32)
    light = r.uniform(0.5, 3.0, (H, W, 3)).astype(np.float32)
    return slots, uvz, shadow, ndl, light


@pytest.fixture
def plan():
    return build_transmission_plan({1: _model(seed=3), 2: jimenez2010_model(sss_width_mm=None)}, bias_mm=1e-3)


def _argument_bound(plan, frame):
    """sum_k |term_k| |x_k| 2^-20 E: a float32 exp(x) of an argument x rounded in float32 is off by ~|x| ulps
    relative (GLSL 4.30 allows exp 3 + 2|x| ulps), which matters for the deep tail (|x| ~ 60)."""
    from ssskit.backends.numpy_backend import shadow_depth

    slots, uvz, shadow, ndl, light = frame
    t = uvz[..., 2] - shadow_depth(shadow.astype(np.float64), uvz[..., 0].astype(np.float64),
                                   uvz[..., 1].astype(np.float64))
    t = np.where(np.isfinite(t), np.maximum(t, 0.0), 0.0)
    u = (plan.scale[slots] * t)[..., None, None]
    x = -plan.b[slots] * u - plan.c[slots] * u * u
    e = np.clip(plan.wrap[slots] - ndl, 0, 1)[..., None] * light
    return np.sum(plan.a[slots] * np.exp(x) * (np.abs(x) + 1) * 2.0**-20, axis=-1) * e


def test_backend_parity_in_ulps(backend, plan):
    """|backend - oracle| <= 16 float32 ulps of the result, plus what the rounding of the map's depth (4 ulps
    of ~100 mm) moves the oracle (t = z - D cancels, so a float32 D carries ulps of the depth, not of t),
    plus the float32 exponential's error at large |x| (:func:`_argument_bound`), plus float32 denormals
    (GLSL may flush them to zero)."""
    frame = _frame()
    out = get_backend(backend).transmission(plan, *frame)
    ref = transmission_pass(plan, *frame)
    slots, uvz, shadow, ndl, light = frame
    eps = 4 * np.spacing(shadow.astype(np.float32)).astype(np.float64)
    hi = transmission_pass(plan, slots, uvz, np.where(np.isfinite(shadow), shadow + eps, shadow), ndl, light)
    lo = transmission_pass(plan, slots, uvz, np.where(np.isfinite(shadow), shadow - eps, shadow), ndl, light)
    bound = (16 * np.spacing(np.abs(ref).astype(np.float32)).astype(np.float64) + np.abs(hi - lo) / 2
             + _argument_bound(plan, frame) + 8 * np.finfo(np.float32).tiny)  # GPUs may flush denormals
    err = np.abs(np.asarray(out, np.float64) - ref)
    assert out.shape == (H, W, 3) and out.dtype == get_backend(backend).dtype
    assert np.all(err <= bound), f"{backend}: worst {float((err / np.maximum(bound, 1e-300)).max()):.3g}x the bound"
    assert np.count_nonzero(ref) > 0.2 * ref.size  # the frame exercises the pass


def test_zero_thickness_and_zero_back_light_give_zero(backend, plan):
    slots, uvz, shadow, ndl, light = _frame()
    b = get_backend(backend)
    from ssskit.backends.numpy_backend import shadow_depth

    on_surface = uvz.copy()  # every point on the first surface the light meets: t = 0, no medium
    d = shadow_depth(shadow.astype(np.float64), uvz[..., 0].astype(np.float64), uvz[..., 1].astype(np.float64))
    on_surface[..., 2] = np.where(np.isfinite(d), d, 50.0)
    assert not np.any(b.transmission(plan, slots, on_surface, shadow, ndl, light))
    assert not np.any(b.transmission(plan, slots, uvz, shadow, ndl, np.zeros_like(light)))
    facing = np.ones_like(ndl)  # N . L = 1: the back faces away from the light (beyond both wraps)
    assert not np.any(b.transmission(plan, slots, uvz, shadow, facing, light))
    assert not np.any(b.transmission(plan, np.zeros_like(slots), uvz, shadow, ndl, light))


def test_energy_never_exceeds_t_times_e(backend, plan):
    slots, uvz, shadow, ndl, light = _frame(seed=5)
    out = np.asarray(get_backend(backend).transmission(plan, slots, uvz, shadow, ndl, light), np.float64)
    from ssskit.backends.numpy_backend import shadow_depth

    t = uvz[..., 2] - shadow_depth(shadow.astype(np.float64), uvz[..., 0].astype(np.float64),
                                   uvz[..., 1].astype(np.float64))
    # T(t) decreases in t (all terms >= 0): T at t less 4 ulps of the depth bounds the float32 result's T
    t = np.where(np.isfinite(t), np.maximum(t - 4 * np.spacing(np.float32(105.0)), 0.0), 0.0)
    tr = np.zeros((H, W, 3))
    for s in (1, 2):
        m = slots == s
        tr[m] = plan.transmittance(s, t[m])
    assert np.all(out >= 0)
    assert np.all(out <= tr * light * (1 + 1e-5) + 1e-30)


def test_nothing_crosses_profile_ids(backend, plan):
    frame = _frame(seed=7)
    b = get_backend(backend)
    base = b.transmission(plan, *frame)
    other = build_transmission_plan({1: _model(seed=3), 2: _model(seed=9, k=6)}, bias_mm=1e-3)
    changed = b.transmission(other, *frame)
    one = frame[0] == 1
    np.testing.assert_array_equal(changed[one], base[one])
    assert np.any(changed[frame[0] == 2] != base[frame[0] == 2])


def test_jimenez2010_is_the_shaders_formula():
    """SeparableSSS.h's SSSSTransmittance, written out: profile(d) with dd = -d^2, times saturate(0.3 +
    dot(light, -normal)); here with scale 8.25 (1 - translucency) / sssWidth."""
    translucency, width = 0.4, 3.0
    m = jimenez2010_model(translucency, width)
    plan = build_transmission_plan({1: m}, bias_mm=0.0)
    thick = np.linspace(0.01, 2.0, 50)
    d = 8.25 * (1.0 - translucency) / width * thick
    dd = (-d * d)[:, None]
    shader = (np.array([0.233, 0.455, 0.649]) * np.exp(dd / 0.0064) + np.array([0.1, 0.336, 0.344]) * np.exp(dd / 0.0484)
              + np.array([0.118, 0.198, 0.0]) * np.exp(dd / 0.187) + np.array([0.113, 0.007, 0.007]) * np.exp(dd / 0.567)
              + np.array([0.358, 0.004, 0.0]) * np.exp(dd / 1.99) + np.array([0.078, 0.0, 0.0]) * np.exp(dd / 7.41))
    np.testing.assert_allclose(plan.transmittance(1, thick), shader, rtol=1e-13)
    # one pixel through the pass: N . L = 0.5 on the front, so saturate(0.3 - 0.5) = 0; N . L = -0.5: 0.8
    shadow = np.full((4, 4), 10.0)
    uvz = np.array([[[2.0, 2.0, 10.0 + thick[10]], [2.0, 2.0, 10.0 + thick[10]]]])
    out = transmission_pass(plan, np.ones((1, 2), np.int32), uvz, shadow, np.array([[0.5, -0.5]]), np.ones((1, 2, 3)))
    np.testing.assert_allclose(out[0, 0], 0.0)
    np.testing.assert_allclose(out[0, 1], 0.8 * shader[10], rtol=1e-13)


def test_bad_inputs_are_refused(plan):
    slots, uvz, shadow, ndl, light = _frame()
    b = get_backend("numpy")
    with pytest.raises(PassError, match="light_uvz"):
        b.transmission(plan, slots, uvz[:, :-1], shadow, ndl, light)
    with pytest.raises(PassError, match="light-space depth"):
        b.transmission(plan, slots, uvz, shadow[0], ndl, light)
    with pytest.raises(PassError, match="slots"):
        b.transmission(plan, slots + 5, uvz, shadow, ndl, light)
    with pytest.raises(PassError, match="profile ids"):
        build_transmission_plan({0: _model()})
    with pytest.raises(PassError, match="translucency"):
        jimenez2010_model(1.0)


def _signed_model(along_normal):
    """A model with a subtracting term, 0 at t = 0 (the MCML model's scattered part has this form):
    0.5 (e^-0.3t - e^-2t) + 0.2 (e^(-0.8t - 0.01t^2) - e^-2t) >= 0 for t < 120 mm."""
    a = np.tile([0.5, 0.2, -0.7], (3, 1)) * np.array([[1.0], [0.8], [0.6]])
    b = np.tile([0.3, 0.8, 2.0], (3, 1))
    c = np.tile([0.0, 0.01, 0.0], (3, 1))
    return SlotModel(a, b, c, 1.0, 0.0, "mcml", along_normal)


def _at_normal_thickness(frame):
    """The frame with every point moved along the light to the thickness t clamp(-N . L, 0, 1)."""
    from ssskit.backends.numpy_backend import shadow_depth

    slots, uvz, shadow, ndl, light = frame
    d = shadow_depth(shadow.astype(np.float64), uvz[..., 0].astype(np.float64), uvz[..., 1].astype(np.float64))
    t = uvz[..., 2].astype(np.float64) - d
    moved = uvz.astype(np.float64).copy()
    moved[..., 2] = np.where(np.isfinite(t) & (t > 1e-3), d + t * np.clip(-ndl, 0.0, 1.0), moved[..., 2])
    return slots, moved, shadow, ndl, light


def test_thickness_along_the_normal(backend):
    """A slot with ``along_normal`` (step 2) evaluates T at t clamp(-N . L, 0, 1): the oracle equals the same
    model along the light at that thickness, and every backend equals the oracle within 16 float32 ulps of the
    terms' magnitudes (they subtract) plus the map's depth rounding, as the parity test bounds it."""
    frame = _frame(seed=11)
    plan_n = build_transmission_plan({1: _signed_model(True), 2: _signed_model(True)}, bias_mm=1e-3)
    plan_l = build_transmission_plan({1: _signed_model(False), 2: _signed_model(False)}, bias_mm=1e-3)
    assert list(plan_n.normal) == [0.0, 1.0, 1.0] and not plan_l.normal.any()
    ref = transmission_pass(plan_n, *frame)
    moved = _at_normal_thickness(frame)
    want = transmission_pass(plan_l, *moved)
    lit = want > 0  # a point moved to t <= bias is unlit either way
    np.testing.assert_allclose(ref[lit], want[lit], rtol=1e-9, atol=1e-15)
    assert np.all(ref >= 0) and np.count_nonzero(ref) > 0.2 * ref.size
    out = np.asarray(get_backend(backend).transmission(plan_n, *frame), np.float64)
    slots, uvz, shadow, ndl, light = frame
    eps = 4 * np.spacing(shadow.astype(np.float32)).astype(np.float64)
    hi = transmission_pass(plan_n, slots, uvz, np.where(np.isfinite(shadow), shadow + eps, shadow), ndl, light)
    lo = transmission_pass(plan_n, slots, uvz, np.where(np.isfinite(shadow), shadow - eps, shadow), ndl, light)
    from ssskit.backends.numpy_backend import shadow_depth

    t = uvz[..., 2] - shadow_depth(shadow.astype(np.float64), uvz[..., 0].astype(np.float64),
                                   uvz[..., 1].astype(np.float64))
    t = np.where(np.isfinite(t), np.maximum(t, 0.0), 0.0) * np.clip(-ndl, 0.0, 1.0)
    x = -plan_n.b[slots] * t[..., None, None] - plan_n.c[slots] * (t * t)[..., None, None]
    e = np.clip(-ndl, 0, 1)[..., None] * light
    terms = np.sum(np.abs(plan_n.a[slots]) * np.exp(x) * (np.abs(x) + 1) * 2.0**-20, axis=-1) * e
    bound = np.abs(hi - lo) / 2 + terms + 8 * np.finfo(np.float32).tiny
    err = np.abs(out - ref)
    assert np.all(err <= bound), f"{backend}: worst {float((err / np.maximum(bound, 1e-300)).max()):.3g}x the bound"
