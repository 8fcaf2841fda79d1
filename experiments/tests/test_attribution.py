"""The attribution experiments' machinery: paired standard errors that match the spread of repeats,
setups that differ in one thing only, and a physical property of each control (small sizes, the
dipole profile, the index-matched boundary where the noise allows)."""

import dataclasses

import numpy as np
import pytest

from ssskit.errors import SettingsError
from ssskit.materials import get_material
from lab.attribution import (
    ATTRIBUTION_REGIONS,
    Setup,
    curvature_setups,
    experiment_setups,
    fresnel_setups,
    prepare,
    ratio_se,
    run_experiment,
    transmission_setups,
)
from ssskit.scenes.scenes import SceneSpec, get_scene
from lab.variants import scaled_scene

SKIN = get_material("skin1")


def test_ratio_se_matches_the_spread_of_repeated_experiments(rng):
    """The delta-method batch SE of mean(a)/mean(b) from correlated per-chunk pairs equals the standard
    deviation of the ratio over 3000 repeated experiments within 8% (its own scatter is ~1/sqrt(2K))."""
    k, reps = 64, 3000
    common = rng.normal(size=(reps, k))
    a = 2.0 + 0.3 * common + 0.2 * rng.normal(size=(reps, k))
    b = 1.0 + 0.1 * common + 0.1 * rng.normal(size=(reps, k))
    r = a.mean(axis=1) / b.mean(axis=1)
    se = np.array([ratio_se(a[i], b[i])[1] for i in range(reps)])
    assert abs(np.mean(se) / np.std(r) - 1) < 0.08
    # a constant numerator: the relative SE of the denominator's mean
    rc, sec = ratio_se(np.full(k, 3.0), b[0])
    assert rc == pytest.approx(3.0 / b[0].mean())
    assert sec == pytest.approx(rc * b[0].std(ddof=1) / np.sqrt(k) / b[0].mean())
    with pytest.raises(SettingsError, match="two chunks"):
        ratio_se(a[0, :1], b[0, :1])


def test_setups_differ_in_one_thing():
    base, backed = transmission_setups("ear", "skin1")
    assert base.material == backed.material and base.boundary == backed.boundary == "rough-dielectric"
    assert "ear-backing" in backed.scene.shapes() and set(base_shapes := get_scene("ear").shapes()) < set(
        backed.scene.shapes())
    assert backed.scene.lights() == get_scene("ear").lights() and backed.scene.origin == get_scene("ear").origin
    assert len(base_shapes) == 2
    rough, matched = fresnel_setups("sphere", "skin1")
    assert rough.scene == matched.scene == "sphere"
    assert matched.boundary == "index-matched" and matched.material.eta == 1.0 and rough.material.eta == SKIN.eta
    assert dataclasses.replace(matched.material, eta=SKIN.eta) == SKIN
    c = curvature_setups("sphere", "skin1", (1, 3))
    assert c[0].scene is get_scene("sphere") and isinstance(c[1].scene, SceneSpec)
    assert c[1].scene.name == "sphere-x3" and c[1].material == SKIN
    with pytest.raises(SettingsError, match="scale factor"):
        curvature_setups("sphere", "skin1", ())


def test_view_cosine_and_surface_convolution_on_the_flat_slab():
    """The slab is seen head-on: cos ~ 1 everywhere; there the convolution over the seen surface equals
    the exact 2D convolution on the lit plateau (the same Eq. 1 on a fronto-parallel plane), and both
    are the albedo Rd far from the shadow edge."""
    p = prepare(Setup("slab", "slab", SKIN), 32, 24, 0, gbuffer_spp=4, model="dipole")
    gb = p.gbuffer
    cos = gb.view_cosine()
    assert cos[gb.mask].min() > 0.99
    plateau = np.zeros(gb.shape, bool)
    plateau[4:20, 1:7] = True  # lit, > 20 mm (2.3 mm pixels) from the shadow edge at the centre column
    e = gb.diffuse[plateau].astype(float)
    exact = (gb.albedo * p.exact)[plateau] / e
    surface = p.surface[plateau] / e
    np.testing.assert_allclose(surface.mean(axis=0), exact.mean(axis=0), rtol=5e-3)
    np.testing.assert_allclose(surface.mean(axis=0), p.profile.total_rd(), rtol=1e-2)


def test_view_cosine_falls_to_zero_at_the_sphere_silhouette():
    p = prepare(Setup("sphere", "sphere", SKIN), 64, 48, 0, gbuffer_spp=4, surface=False, model="dipole")
    cos = p.gbuffer.view_cosine()[p.gbuffer.mask]
    assert cos.max() > 0.99 and cos.min() < 0.2


def test_scaled_flat_slab_keeps_its_plateau_level():
    """A flat slab has no curvature to lose: scaled by 2 (the same image, twice the mm per pixel) its
    plateau level is the same within the paired standard error (index-matched boundary, the fast one);
    the experiment measures every setup on the same pixels with the same chunk seeds."""
    mat = dataclasses.replace(SKIN, eta=1.0)
    setups = [Setup("x1", "slab", mat, "index-matched"), Setup("x2", scaled_scene("slab", 2), mat, "index-matched")]
    res = run_experiment(setups, width=48, height=36, spp=96, chunk_spp=8, photons=0, gbuffer_spp=4,
                         surface=False, model="dipole")
    assert set(res["regions"]) == set(ATTRIBUTION_REGIONS)
    assert res["regions"]["plateau"] > 50
    vs = res["setups"][1]["vs_first"]["plateau"]["reference_ratio"]
    ratio, se = np.array(vs["value"]), np.array(vs["se"])
    assert np.all(se > 0) and np.all(se < 0.02)
    assert np.all(np.abs(ratio - 1) < 3.5 * se + 2e-3)
    first = res["setups"][0]["regions"]["plateau"]
    assert "exact_over_reference" in first and "vs_first" not in res["setups"][0]


def test_run_experiment_checks_its_budget():
    with pytest.raises(SettingsError, match="two chunks"):
        run_experiment([Setup("x", "slab", SKIN)], spp=8, chunk_spp=8)
    with pytest.raises(SettingsError, match="at least one setup"):
        run_experiment([])


def test_experiment_setups_dispatches_by_name():
    """Each experiment's own setups; only curvature takes the scale factors; an unknown name is refused."""
    c = experiment_setups("curvature", "sphere", "skin1", (1.0, 8.0))
    assert [s.label for s in c] == ["x1", "x8"] and c[1].scene.name == "sphere-x8"
    f = experiment_setups("fresnel", "sphere", "skin1", (1.0, 8.0))
    assert [s.boundary for s in f] == ["rough-dielectric", "index-matched"]
    assert experiment_setups("transmission", "ear", "skin1")[1].scene.name == "ear-backed"
    with pytest.raises(SettingsError, match="experiment must be one of transmission, fresnel, curvature"):
        experiment_setups("gravity", "sphere", "skin1")
