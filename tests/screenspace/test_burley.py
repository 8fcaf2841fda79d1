"""The Burley pass's entry point, settings, per-id parameters and the plan's per-step recipe
(:mod:`ssskit.backends.burley_plan`), checked against the independent implementations in
:mod:`ssskit.profiles.burley`, :mod:`ssskit.sampling.burley_radius` and :mod:`ssskit.sampling.hashes`."""

import math

import numpy as np
import pytest

from ssskit.backends.burley_plan import R2_A1, R2_A2, build_burley_plan
from ssskit.backends.numpy_backend import burley_counts, burley_keys, burley_radius, burley_uniforms, burley_weights
from ssskit.errors import PassError, SettingsError
from ssskit.profiles import burley_d_dmfp, burley_profile
from ssskit.profiles.burley import burley_inverse_cdf
from ssskit.sampling.burley_radius import xie_g
from ssskit.sampling.hashes import pixel_hashes
from ssskit.screenspace import BurleyParams, BurleySettings, Camera, GBuffer, burley_sss
from ssskit.screenspace.burley import burley_params_for_material


def _gb(h=20, w=24):
    pid = np.ones((h, w), np.uint32)
    return GBuffer(diffuse=np.random.default_rng(0).random((h, w, 3)).astype(np.float32),
                   albedo=np.ones((h, w, 3), np.float32), depth=np.full((h, w), 300.0, np.float32), profile_id=pid,
                   camera=Camera(w, h, 600.0, 600.0, w / 2, h / 2))


# ---- parameters ------------------------------------------------------------------------------------

def test_params_from_dmfp_are_eq5_configuration_3():
    p = BurleyParams.from_dmfp((0.9, 0.6, 0.33), (3.0, 2.0, 1.0))
    np.testing.assert_allclose(p.d_mm, burley_d_dmfp(np.array([0.9, 0.6, 0.33]), np.array([3.0, 2.0, 1.0])))
    assert p.d_mm[2] == pytest.approx(1.0 / 3.5)  # A = 0.33: d = dmfp / 3.5 (Xie 2020 Eq. 5, Theta_3)
    assert p.sampling_channel == 1  # the largest d (0.2134, 0.4961, 0.2857 mm), not the largest dmfp


def test_params_from_material_match_the_burley_profile():
    p = burley_params_for_material("skin1")
    prof = burley_profile(__import__("ssskit.materials", fromlist=["get_material"]).get_material("skin1"))
    assert p.d_mm == tuple(c.d for c in prof.channels)
    assert p.albedo == tuple(c.albedo for c in prof.channels)
    q = BurleyParams.from_profile(p.profile())
    assert q.d_mm == p.d_mm and q.albedo == p.albedo


@pytest.mark.parametrize("albedo,dmfp,match", [
    (-0.1, 1.0, "albedo must lie in"), (1.2, 1.0, "albedo must lie in"),
    (0.5, -1.0, r"mean free path must lie in \[1e-06, 1e\+06\] mm, got -1"),
    (0.5, 0.0, r"mean free path must lie in \[1e-06, 1e\+06\] mm, got 0"),
    (0.5, (1.0, 2.0), r"must be a number or three \[R, G, B\], got \(1, 2\)"),
    (float("nan"), 1.0, r"albedo must lie in \(0, 1\], got nan"),
])
def test_bad_params(albedo, dmfp, match):
    with pytest.raises(PassError, match=match):
        BurleyParams.from_dmfp(albedo, dmfp)


def test_params_take_what_eq5_gives_from_the_mean_free_paths_every_model_takes():
    """docs/models.md: A in (0, 1], dmfp in [1e-6, 1e6] mm, d in that range over Eq. 5's scalings,
    whose extremes over A in [0, 1] are computed here from the three configurations."""
    from ssskit.profiles import burley_d
    from ssskit.profiles.domain import BURLEY_D_RANGE_MM, BURLEY_EQ5_SCALING_RANGE, MFP_RANGE_MM

    a = np.linspace(0.0, 1.0, 100_001)
    s = np.concatenate([1.0 / burley_d(a, 1.0, c) for c in ("searchlight", "diffuse-transmission", "dmfp")])
    assert BURLEY_EQ5_SCALING_RANGE[0] == pytest.approx(s.min(), rel=1e-9)
    assert BURLEY_EQ5_SCALING_RANGE[1] == pytest.approx(s.max(), rel=1e-9)
    np.testing.assert_allclose(BURLEY_D_RANGE_MM, (MFP_RANGE_MM[0] / s.max(), MFP_RANGE_MM[1] / s.min()), rtol=1e-9)
    for albedo, dmfp in ((0.0, 1.0), (0.5, 1e12), (0.5, 1e-9), (0.5, (1.0, 1.0, 1.5e6))):
        with pytest.raises(PassError, match=r"albedo must lie in \(0, 1\]|in \[1e-06, 1e\+06\] mm"):
            BurleyParams.from_dmfp(albedo, dmfp)
    for d in (BURLEY_D_RANGE_MM[0] / 2, BURLEY_D_RANGE_MM[1] * 2):
        with pytest.raises(PassError, match=r"Burley length d must lie in \[4.2\d*e-08, 1.1\d*e\+06\] mm, got"):
            BurleyParams((0.5, 0.5, 0.5), (1.0, d, 1.0))
    BurleyParams.from_dmfp(1.0, MFP_RANGE_MM[0])
    BurleyParams.from_dmfp(1.0, MFP_RANGE_MM[1])
    BurleyParams((0.5, 0.5, 0.5), (BURLEY_D_RANGE_MM[0], 1.0, BURLEY_D_RANGE_MM[1]))


def test_profile_that_is_not_burley_is_refused():
    from ssskit.profiles import profile_for_material

    with pytest.raises(PassError, match="needs a Burley profile"):
        BurleyParams.from_profile(profile_for_material("skin1", "dipole"))


# ---- settings --------------------------------------------------------------------------------------

@pytest.mark.parametrize("field,value,match", [
    ("spp", 0, "spp must lie"), ("spp", -3, "spp must lie"), ("sampler", "halton", "sampler must be one of"),
    ("c", 2.0, "c must"), ("c", 3.0, "c must"), ("c", 1.5, "c must"), ("sequence", "sobol", "sequence"),
    ("bleed", 1.5, "bleed"), ("backend", "cuda", "backend"), ("stable", 1, "stable"), ("mips", "yes", "mips"),
    ("mip_scale", 0.0, "mip_scale"),
])
def test_bad_settings(field, value, match):
    with pytest.raises(SettingsError, match=match):
        BurleySettings(**{field: value})


def test_c_names_its_domain():
    """A non-finite c is refused naming c's own domain (2, 3), not [-inf, inf]."""
    for c in (float("nan"), float("inf")):
        with pytest.raises(SettingsError, match=r"c must lie in \(2, 3\), got "):
            BurleySettings(sampler="xie", c=c)
    with pytest.raises(SettingsError, match=r"c must be a number, got 'x'"):
        BurleySettings(sampler="xie", c="x")


def test_settings_round_trip(tmp_path):
    s = BurleySettings(sampler="xie", spp=8, c=2.6, stable=True, backend="numpy")
    s.save(tmp_path / "b.toml")
    assert BurleySettings.load(tmp_path / "b.toml") == s


def test_entry_point_checks():
    gb = _gb()
    p = BurleyParams.from_dmfp(0.5, 1.0)
    with pytest.raises(PassError, match="no Burley parameters given for profile id 1"):
        burley_sss(gb, {2: p})
    with pytest.raises(PassError, match="Burley parameters must be BurleyParams or Mapping, got list"):
        burley_sss(gb, [p])
    with pytest.raises(PassError, match=r"the sample counts must be an integer array of shape \(20, 24\), got shape \(24, 20\)"):
        burley_sss(gb, p, counts=np.ones((24, 20), np.int64))
    with pytest.raises(PassError, match="settings must be BurleySettings"):
        burley_sss(gb, p, settings={"spp": 4})
    with pytest.raises(PassError, match=r"c must lie in \(2, 3\), got 3.5 \(Eq. 21's damping"):
        build_burley_plan({1: p}, 600.0, 600.0, c=3.5)


# ---- the plan's recipe, step by step ----------------------------------------------------------------

def test_step1_keys_are_the_shared_pixel_hashes():
    plan = build_burley_plan({1: BurleyParams.from_dmfp(0.5, 1.0)}, 500.0, 500.0, frame=4, seed=9)
    ys, xs = np.mgrid[0:5, 0:7]
    h1, _ = burley_keys(plan, ys.ravel(), xs.ravel(), np.full(35, 100.0))
    np.testing.assert_array_equal(h1, pixel_hashes(5, 7, 4, 9).ravel())


def test_step3_r2_constants_and_unit_interval():
    g = 1.324717957244746  # the plastic number, x^3 = x + 1
    assert abs(g**3 - g - 1) < 1e-12
    assert R2_A1 == round(2**32 / g) and R2_A2 == round(2**32 / g**2)
    plan = build_burley_plan({1: BurleyParams.from_dmfp(0.5, 1.0)}, 500.0, 500.0)
    h = np.array([0, 0xFFFFFFFF], np.uint64)
    for j in (0, 1, 1000):
        u1, u2 = burley_uniforms(plan, h, h, j, np.array([4, 4]))
        assert np.all((u1 > 0) & (u1 < 1) & (u2 > 0) & (u2 < 1))
    # R2: sample j is the rotation of j * alpha mod 1
    u1, u2 = burley_uniforms(plan, np.array([0], np.uint64), np.array([0], np.uint64), 5, np.array([8]))
    assert u1[0] == pytest.approx(((5 * R2_A1) % 2**32 >> 8) / 2**24 + 2**-25)


def test_step4_radii_are_eq20_inverted_and_eq21():
    xi = np.array([1e-6, 0.01, 0.3, 0.7, 0.99, 1 - 2**-25])
    d = np.full(xi.size, 1.7)
    exact = build_burley_plan({1: BurleyParams.from_dmfp(0.5, 1.0)}, 500.0, 500.0)
    np.testing.assert_allclose(burley_radius(exact, xi, d), burley_inverse_cdf(xi, 1.7), rtol=1e-12)
    xie = build_burley_plan({1: BurleyParams.from_dmfp(0.5, 1.0)}, 500.0, 500.0, sampler="xie", c=2.6)
    np.testing.assert_allclose(burley_radius(xie, xi, d), xie_g(xi, 1.7, 2.6), rtol=1e-12)


def test_step7_weights_are_eq24_up_to_a_constant():
    """w_c = r' R_c(r') / pdf(r) / (A_c / (2 pi)); 1 for the sampling channel on a flat surface."""
    p = BurleyParams((0.8, 0.6, 0.4), (2.0, 1.0, 0.5))
    prof = p.profile()
    r = np.array([0.1, 1.0, 4.0])
    rp = np.sqrt(r**2 + 0.3**2)
    w = burley_weights(r, rp, np.full(3, 2.0), np.array(p.d_mm))
    pdf = prof.channels[0].radial_pdf(r)  # per unit radius
    want = rp[:, None] * prof.eval(rp) / pdf[:, None] * (2 * math.pi / np.array(p.albedo))
    np.testing.assert_allclose(w, want, rtol=1e-12)
    np.testing.assert_allclose(burley_weights(r, r, np.full(3, 2.0), np.array(p.d_mm))[:, 0], 1.0)


def test_step2_golubev_caps_the_count_by_the_footprint():
    p = BurleyParams.from_dmfp(0.5, 1.0)
    plan = build_burley_plan({1: p}, 500.0, 500.0, sampler="golubev")
    r = plan.r997_mm[1]
    assert float(p.profile().channels[0].energy_within(r) / p.albedo[0]) == pytest.approx(0.997)
    sx = np.array([0.5, 5.0, 50.0])
    n = burley_counts(plan, 64, np.zeros(3, int), np.zeros(3, int), sx, sx, np.ones(3, int))
    np.testing.assert_array_equal(n, [max(1, min(64, math.floor(math.pi * (r * s) ** 2 / 4))) for s in sx])
    assert n[0] >= 1 and n[-1] == 64


# ---- prefiltered irradiance (step 5b, Xie 2020 Eqs. 22-23) ---------------------------------------------

def test_mip_pyramid_is_the_masked_block_mean():
    from ssskit.backends.burley_plan import mip_pyramid

    rng = np.random.default_rng(2)
    e = rng.random((13, 10, 3))
    slots = (rng.random((13, 10)) < 0.6).astype(np.int32) + (rng.random((13, 10)) < 0.3)
    pyr = mip_pyramid(e, slots, 3)
    assert [lv.shape[1:3] for lv in pyr] == [(13, 10), (7, 5), (4, 3), (2, 2), (1, 1), (1, 1)]
    for s in (1, 2):
        m = slots == s
        block = pyr[2][s, 1, 1]  # texels y 4..7, x 4..7
        sub = m[4:8, 4:8]
        assert block[3] == pytest.approx(sub.mean())
        np.testing.assert_allclose(block[:3], (e[4:8, 4:8] * sub[..., None]).sum(axis=(0, 1)) / 16)
        assert pyr[5][s, 0, 0, 3] == pytest.approx(m.sum() / 1024)  # the 32 x 32 block: zeros off the image


def test_mip_level_is_eq22_in_xie_units():
    """m = 0.5 max(-log2(a n p(r) / (ell_max^2 t)), 0) with p(r) the radial pdf per mm (Eq. 20's
    derivative), ell_max the largest dmfp (mm) and t = (sx / W)(sy / H) (Eq. 23: UV^2 per mm^2), as in
    Unreal's pass; numbers worked by hand."""
    from ssskit.backends.numpy_backend import burley_mip_level

    # A = 0.33 in every channel: d = dmfp / 3.5, so dmfp (1, 2, 4) mm gives ell_max = 4 mm
    plan = build_burley_plan({1: BurleyParams.from_dmfp(0.33, (1.0, 2.0, 4.0))}, 800.0, 500.0, mips=True,
                             mip_scale=1 / 16)
    assert plan.dmfp_max_mm[1] == pytest.approx(4.0)
    # z = 400 mm: sx = 2, sy = 1.25 px/mm; W x H = 160 x 100: t = (2/160)(1.25/100) = 1.5625e-4
    r = np.array([0.0, 1.0, 40.0, 60.0, 400.0])
    d = np.full(5, 2.0)
    m = burley_mip_level(plan, r, d, np.full(5, 16), np.full(5, 400.0), np.ones(5, np.int64), (100, 160))
    # r = 60: p = (e^-30 + e^-10) / 8 = 5.6750e-6 per mm; a n p / (ell^2 t) = 5.6750e-6 / (16 x 1.5625e-4)
    #       = 2.2700e-3, m = 0.5 x 8.783 = 4.391
    assert m[3] == pytest.approx(0.5 * -np.log2(5.6750e-6 / (16 * 1.5625e-4)), rel=1e-4)
    assert m[3] == pytest.approx(4.391, abs=2e-3)
    # r = 40: p = 1.5908e-4, ratio 0.063632, m = 1.987; r <= 1: p >= 0.18, ratio > 1, level 0
    assert m[2] == pytest.approx(1.987, abs=2e-3)
    assert m[0] == 0.0 and m[1] == 0.0
    assert m[-1] == 5.0  # clamped


def test_mip_level_does_not_depend_on_the_resolution():
    """Eq. 23's t is in viewport UV per mm: the same view at twice the pixels (fx and W doubled) gives
    the same levels (and a = 1/16 means the paper's a at any resolution)."""
    from ssskit.backends.numpy_backend import burley_mip_level

    p = {1: BurleyParams.from_dmfp(0.6, (8.0, 4.0, 2.0))}
    r = np.linspace(0.1, 80.0, 50)
    one = np.ones(50, np.int64)
    lo = burley_mip_level(build_burley_plan(p, 300.0, 300.0, mips=True), r, np.full(50, 2.0), np.full(50, 8),
                          np.full(50, 500.0), one, (120, 160))
    hi = burley_mip_level(build_burley_plan(p, 600.0, 600.0, mips=True), r, np.full(50, 2.0), np.full(50, 8),
                          np.full(50, 500.0), one, (240, 320))
    np.testing.assert_allclose(lo, hi, rtol=1e-12)
    assert lo.max() > 0  # the tail reaches coarser levels


def test_dmfp_inverts_from_dmfp():
    p = BurleyParams.from_dmfp((0.9, 0.6, 0.2), (3.0, 2.0, 1.0))
    np.testing.assert_allclose(p.dmfp_mm, (3.0, 2.0, 1.0), rtol=1e-12)


def test_mips_blur_more_at_low_counts():
    """Fewer samples per pixel: coarser levels, a smoother result on a checkerboard (same seed)."""
    h, w = 32, 32
    yy, xx = np.mgrid[0:h, 0:w]
    e = np.repeat(((xx + yy) % 2)[..., None], 3, axis=2).astype(np.float32)
    gb = _gb(h, w).with_layers(diffuse=e)
    p = BurleyParams.from_dmfp(0.5, 20.0)
    a = burley_sss(gb, p, spp=4, mips=True, seed=1, backend="numpy")
    b = burley_sss(gb, p, spp=4, mips=False, seed=1, backend="numpy")
    assert a[8:24, 8:24].std() < 0.5 * b[8:24, 8:24].std()


def test_unknown_keyword_is_a_settings_error():
    """A misspelt override (spps for spp) is a SettingsError naming the known fields, not a TypeError."""
    with pytest.raises(SettingsError, match=r"BurleySettings: unknown setting\(s\) spps \(known: sampler, spp, "):
        burley_sss(_gb(), BurleyParams.from_dmfp(0.6, (8.0, 4.0, 2.0)), spps=4)
