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


def _frame(seed=1, h=H, w=W, hs=HS, ws=WS):
    """Two profile ids, a map at ~100 mm with holes, points behind it (t in [0.01, 9] mm, none within 2x the
    bias of zero) or in front of it, some off the map."""
    H, W, HS, WS = h, w, hs, ws
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


def _parity(backend, plan, frame):
    """(out, oracle, bound): |backend - oracle| <= 16 float32 ulps of the result, plus what the rounding of the
    map's depth (4 ulps of ~100 mm) moves the oracle (t = z - D cancels, so a float32 D carries ulps of the
    depth, not of t), plus what the float32 rounding of wrap - N . L (the wrap constant and the difference,
    half an ulp of 1 each) moves it (it cancels where N . L is near the wrap), plus the float32 exponential's
    error at large |x| (:func:`_argument_bound`), plus float32 denormals (GLSL may flush them to zero)."""
    out = get_backend(backend).transmission(plan, *frame)
    ref = transmission_pass(plan, *frame)
    slots, uvz, shadow, ndl, light = frame
    eps = 4 * np.spacing(shadow.astype(np.float32)).astype(np.float64)
    hi = transmission_pass(plan, slots, uvz, np.where(np.isfinite(shadow), shadow + eps, shadow), ndl, light)
    lo = transmission_pass(plan, slots, uvz, np.where(np.isfinite(shadow), shadow - eps, shadow), ndl, light)
    dn = float(np.spacing(np.float32(1.0)))
    e_hi = transmission_pass(plan, slots, uvz, shadow, ndl.astype(np.float64) - dn, light)
    e_lo = transmission_pass(plan, slots, uvz, shadow, ndl.astype(np.float64) + dn, light)
    bound = (16 * np.spacing(np.abs(ref).astype(np.float32)).astype(np.float64) + np.abs(hi - lo) / 2
             + np.abs(e_hi - e_lo) / 2 + _argument_bound(plan, frame)
             + 8 * np.finfo(np.float32).tiny)  # GPUs may flush denormals
    return out, ref, bound


def test_backend_parity_in_ulps(backend, plan):
    """The backend against the float64 oracle within :func:`_parity`'s bound."""
    out, ref, bound = _parity(backend, plan, _frame())
    err = np.abs(np.asarray(out, np.float64) - ref)
    assert out.shape == (H, W, 3) and out.dtype == get_backend(backend).dtype
    assert np.all(err <= bound), f"{backend}: worst {float((err / np.maximum(bound, 1e-300)).max()):.3g}x the bound"
    assert np.count_nonzero(ref) > 0.2 * ref.size  # the frame exercises the pass


@pytest.mark.parametrize("h, w, hs, ws", [(2, 3, 40, 36), (3, 11, 1, 1), (70, 37, 1, 5), (37, 70, 5, 1),
                                          (64, 97, 40, 36)])
def test_parity_on_any_frame_and_map_shape(backend, plan, h, w, hs, ws):
    """Frames of fewer pixels than a lane block, widths no multiple of it, frames split over threads (>= 2048
    pixels), maps one texel wide or high (the numba kernel reads texels in pairs): the oracle's values
    within :func:`_parity`'s bound."""
    frame = _frame(seed=h + w, h=h, w=w, hs=hs, ws=ws)
    out, ref, bound = _parity(backend, plan, frame)
    err = np.abs(np.asarray(out, np.float64) - ref)
    assert out.shape == (h, w, 3)
    assert np.all(err <= bound), f"{backend}: worst {float((err / np.maximum(bound, 1e-300)).max()):.3g}x the bound"
    if hs * ws > 1:
        assert np.count_nonzero(ref) > 0.05 * ref.size


def test_numba_result_is_the_same_on_any_thread_count(plan):
    numba = pytest.importorskip("numba")
    frame = _frame(seed=11, h=64, w=97)
    b = get_backend("numba")
    prev = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = b.transmission(plan, *frame)
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        many = b.transmission(plan, *frame)
    finally:
        numba.set_num_threads(prev)
    np.testing.assert_array_equal(one, many)


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
    with pytest.raises(PassError, match="profile ids must be an integer, got 'a'"):
        build_transmission_plan({"a": _model()})
    with pytest.raises(PassError, match="profile id 1 must be SlotModel, got float"):
        build_transmission_plan({1: 3.0})
    with pytest.raises(PassError, match="must be a non-empty mapping"):
        build_transmission_plan({})
    assert build_transmission_plan({}, allow_empty=True).slots == 1  # a frame without SSS pixels (the pipeline's)


def test_bad_models_and_an_empty_map_are_refused(plan):
    """A SlotModel's arrays and numbers (transmission_plan.MODEL_ARRAYS, MODEL_FIELDS): a, b and c (3, K) of one
    K (a 1-D term or another K raised IndexError and a numpy broadcast error before), a model among MODELS,
    the unreal model with its profile table and only it; and a light-space depth map of no texel."""
    m = _model(k=2)
    for model, match in ((SlotModel(m.a[0], m.b, m.c), r"profile id 1: a must be a real array of shape \(3, K\)"),
                         (SlotModel(m.a, np.ones((3, 3)), m.c), r"profile id 1: b must be a real array of shape "
                                                                r"\(3, 2\), got shape \(3, 3\)"),
                         (SlotModel(m.a, m.b, m.c, model="x"), r"profile id 1: model must be one of mcml, "
                                                               r"jimenez2010, unreal, got 'x'"),
                         (SlotModel(m.a, m.b, m.c, model="unreal"), "the unreal model, and only it, holds a profile"),
                         (SlotModel(m.a, m.b, m.c, lut=np.ones((3, 32))), "the unreal model, and only it")):
        with pytest.raises(PassError, match=match):
            build_transmission_plan({1: model})
    slots, uvz, shadow, ndl, light = _frame()
    with pytest.raises(PassError, match=r"shadow_mm \(the light-space depth\) must be a non-empty image, got shape "
                                        r"\(0, 36\)"):
        get_backend("numpy").transmission(plan, slots, uvz, shadow[:0], ndl, light)


def test_bad_values_are_refused(plan, backend):
    """Values outside the spec (module docstring of transmission_plan) on a pixel with SSS: NaN or negative
    irradiance, a cosine beyond [-1, 1], a NaN point; NaN in the light-space depth (+inf marks no surface and
    passes); float slots: a PassError on every backend, never NaN or negative output."""
    slots, uvz, shadow, ndl, light = _frame()
    b = get_backend(backend)
    y, x = np.argwhere(slots > 0)[0]
    for name, arr, value, match in (("light", light, np.nan, "light_rgb"), ("light", light, -1.0, "light_rgb"),
                                    ("ndl", ndl, 5.0, "n_dot_l"), ("ndl", ndl, np.nan, "n_dot_l"),
                                    ("ndl", ndl, -1.02, "n_dot_l"), ("uvz", uvz, np.nan, "light_uvz"),
                                    ("shadow", shadow, np.nan, "shadow_mm")):
        args = {"uvz": uvz, "shadow": shadow, "ndl": ndl, "light": light}
        bad = arr.copy()
        bad[(y, x) if arr.ndim == 2 else (y, x, 1)] = value
        args[name] = bad
        with pytest.raises(PassError, match=match):
            b.transmission(plan, slots, args["uvz"], args["shadow"], args["ndl"], args["light"])
    with pytest.raises(PassError, match=r"slots must be an integer array of shape \(H, W\), got shape \(\d+, \d+\) float32"):
        b.transmission(plan, slots.astype(np.float32), uvz, shadow, ndl, light)
    edge = ndl.copy()
    edge[y, x] = 1.0 + 1e-6  # a rounded cosine passes and is clamped
    outside = np.argwhere(slots == 0)[0]
    far = light.copy()
    far[tuple(outside)] = np.nan  # a pixel without SSS is not read
    out = b.transmission(plan, slots, uvz, shadow, edge, far)
    assert np.all(np.isfinite(out)) and np.all(out >= 0)
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


# ---- Unreal Engine 5's transmission (model "unreal") ---------------------------------------------------------


def _ue_table_written_out(surface_albedo, dmfp_mm, tint, world_unit_scale=0.1, distance_scale=1.0):
    """BurleyNormalizedSSS.cpp (UE 5.8), ComputeTransmissionProfileBurley, line by line: 32 entries, the profile
    0.25 A (exp(-S r / L) + 3 exp(-S r / (3 L))) with A = white, S = GetSearchLightDiffuseScalingFactor(albedo),
    L the DMFP in mm, tinted, the last entry black."""
    unit_scale = world_unit_scale * distance_scale / 0.1  # SubsurfaceScatteringUnitInCm = 0.1
    inv_unit_scale = 1.0 / unit_scale
    out = np.zeros((32, 3))
    for i in range(32):
        distance_mm = i * (1.0 / 32) * (5.0 * 10.0) * inv_unit_scale  # MaxTransmissionProfileDistance * CmToMm
        offset_mm = (0.06 * 10.0) * inv_unit_scale  # ProfileRadiusOffset * CmToMm
        r = distance_mm + offset_mm
        for c in range(3):
            s = 3.5 + 100 * (surface_albedo[c] - 0.33) ** 4
            ell = dmfp_mm[c]
            out[i, c] = 0.25 * 1.0 * (np.exp(-s * r / ell) + 3 * np.exp(-s * r / (3 * ell))) * tint[c]
    out[31] = 0.0
    return out


def _ue_transmission_written_out(table, thickness_mm, extinction_scale, normal_scale):
    """The shaders (UE 5.8): CalculateOpticalDepth (TransmissionThickness.ush, NoL = 1, thickness in cm), the shadow
    mask's EncodeOpticalDepthToShadowMask squared by ApplyPCFOverBlurCorrection (ShadowProjectionPixelShader.usf),
    DecodeOpticalDepthFromShadowMask and GetTransmissionProfile's uv (TransmissionCommon.ush) through a GPU linear
    filter with clamp-to-edge addressing (texel k centred at k + 0.5)."""
    out = []
    for t in thickness_mm:
        od = (t / 10.0) * extinction_scale
        ns = normal_scale * 0.5
        od = np.clip(abs(od + ns if od > 0 else max(0.0, od * 1.0 + ns)), 0.15, 5) + 0.25
        encoded = (1 - od / 5.0) ** 2
        decoded = (1 - encoded) * 5.0
        coord = decoded / 5.0 * (32 - 1) + 0.5  # texel units along the table
        k = int(np.floor(coord - 0.5))
        f = coord - 0.5 - k
        k0, k1 = min(max(k, 0), 31), min(max(k + 1, 0), 31)
        out.append((1 - f) * table[k0] + f * table[k1])
    return np.array(out)


def test_unreal_model_is_ues_computation_written_out():
    """The unreal slot's T(t) is UE 5.8's profile table read at UE's optical depth, written out from the files
    (helpers above), for a skin-like profile with a tint, ExtinctionScale and NormalScale away from their defaults,
    at thicknesses across the clamps; UE's table from SurfaceAlbedo and DMFP equals ssskit's from d = DMFP / S."""
    from ssskit.screenspace.transmission import unreal_model, unreal_profile_table

    albedo, d = np.array([0.8, 0.5, 0.3]), np.array([1.2, 0.5, 0.23])
    dmfp = d * (3.5 + 100 * (albedo - 0.33) ** 4)
    tint, ext, ns = np.array([1.0, 0.8, 0.6]), 2.5, 0.3
    table = _ue_table_written_out(albedo, dmfp, tint)
    np.testing.assert_allclose(unreal_profile_table(d, tint).T, table, rtol=1e-12, atol=1e-300)
    wide = _ue_table_written_out(albedo, dmfp, tint, world_unit_scale=0.5, distance_scale=2.0)
    np.testing.assert_allclose(unreal_profile_table(d, tint, 0.5, 2.0).T, wide, rtol=1e-12, atol=1e-300)
    plan = build_transmission_plan({1: unreal_model(d, tint, ext, ns)}, bias_mm=0.0)
    thick = np.concatenate([np.linspace(0.001, 3.0, 97), np.linspace(3.0, 400.0, 101)])
    np.testing.assert_allclose(plan.transmittance(1, thick), _ue_transmission_written_out(table, thick, ext, ns),
                               rtol=1e-12, atol=1e-300)
    assert plan.wrap[1] == 2.0 and plan.models == ("unreal",)
    # no cosine at the back (wrap 2): the same light whatever N . L, unlike the other models
    shadow = np.full((4, 4), 10.0)
    uvz = np.array([[[2.0, 2.0, 10.0 + thick[10]]] * 3])
    out = transmission_pass(plan, np.ones((1, 3), np.int32), uvz, shadow, np.array([[0.9, 0.0, -0.5]]),
                            np.ones((1, 3, 3)))
    np.testing.assert_allclose(out[0], np.broadcast_to(plan.transmittance(1, thick[10:11])[0], (3, 3)), rtol=1e-13)


def test_unreal_phase_is_ues_approximate_hg():
    """ShadingModels.ush: ApproximateHG(dot(-L, refract(V, -N, 1 / IOR)), g). Straight through (V = N, the light
    behind along -N) the refracted ray is V and the phase is its peak 0.5 (1 + g) / (1 - g); g = 0 is the
    constant 0.5; refract is HLSL's (zero on total internal reflection)."""
    from ssskit.screenspace.transmission import approximate_hg, refract, unreal_phase

    n = np.array([0.0, 0.0, 1.0])
    for g in (0.0, 0.5, 0.93):
        assert unreal_phase(n, n, -n, g, 1.55) == pytest.approx(0.5 * (1 + g) / (1 - g), rel=1e-12)
    v = np.array([np.sin(0.7), 0.0, np.cos(0.7)])
    assert unreal_phase(n, v, -n, 0.0, 1.3) == pytest.approx(0.5, rel=1e-12)
    # refract(i, n, eta) = eta i - (eta (n.i) + sqrt(k)) n, k = 1 - eta^2 (1 - (n.i)^2): Snell's law for i pointing in
    i = -v
    r = refract(i, n, 1.0 / 1.5)
    assert np.linalg.norm(r) == pytest.approx(1.0)
    assert np.hypot(r[0], r[1]) == pytest.approx(np.sin(0.7) / 1.5)  # n1 sin(theta1) = n2 sin(theta2)
    assert not np.any(refract(np.array([np.sin(1.2), 0.0, -np.cos(1.2)]), n, 1.5))  # beyond the critical angle
    assert approximate_hg(1.0, 1.0) == pytest.approx(0.0)  # the max(1e-5, ...) guards g cos = 1


def _unreal_plan():
    from ssskit.screenspace.transmission import unreal_model

    return build_transmission_plan({1: unreal_model((2.5, 1.0, 0.5), (1.0, 0.7, 0.5), 8.0, 0.08),
                                    2: _model(seed=3)}, bias_mm=1e-3)


def test_unreal_slots_on_every_backend(backend):
    """An unreal slot beside an exponential one (blocks that straddle both) on each backend: the oracle's values
    within :func:`_parity`'s bound plus the float32 rounding of the table coordinate x (about 8 roundings, each
    amplified at most 6.5x by 1 - e^2 >= 0.154: 64 ulps of 31) times the table's slope."""
    plan = _unreal_plan()
    frame = _frame(seed=21, h=64, w=97)
    out, ref, bound = _parity(backend, plan, frame)
    slots, uvz, shadow, ndl, light = frame
    from ssskit.backends.numpy_backend import shadow_depth

    t = uvz[..., 2] - shadow_depth(shadow.astype(np.float64), uvz[..., 0].astype(np.float64),
                                   uvz[..., 1].astype(np.float64))
    t = np.where(np.isfinite(t), np.maximum(t, 0.0), 0.0)
    from ssskit.backends.transmission_plan import unreal_lut_coordinate

    x = unreal_lut_coordinate(plan.od_per_mm[1] * t + plan.od_offset[1])
    i = np.minimum(np.floor(x), 30).astype(int)
    slope = np.abs(plan.lut[1][:, i + 1] - plan.lut[1][:, i]).transpose(1, 2, 0)
    e = np.clip(plan.wrap[slots] - ndl, 0, 1)[..., None] * light
    bound = bound + np.where((slots == 1)[..., None], slope * 64 * float(np.spacing(np.float32(31.0))) * e, 0.0)
    err = np.abs(np.asarray(out, np.float64) - ref)
    assert np.all(err <= bound), f"{backend}: worst {float((err / np.maximum(bound, 1e-300)).max()):.3g}x the bound"
    assert np.count_nonzero(ref[slots == 1]) > 0.3 * ref[slots == 1].size
    changed = get_backend(backend).transmission(build_transmission_plan(
        {1: _other_unreal(), 2: _model(seed=3)}, bias_mm=1e-3), *frame)
    np.testing.assert_array_equal(changed[slots == 2], out[slots == 2])  # nothing crosses profile ids


def _other_unreal():
    from ssskit.screenspace.transmission import unreal_model

    return unreal_model((1.0, 0.4, 0.2), extinction_scale=1.0)
