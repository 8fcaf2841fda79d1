"""The flat-medium prediction (:mod:`lab.oblique`): its averaging and boundary factor on
a synthetic G-buffer, and the index-matched flat medium at grazing incidence against MCML at eta = 1
(the cheap Mitsuba-vs-MCML check of the oblique-incidence transport)."""

import dataclasses

import numpy as np
import pytest

from ssskit.errors import SceneError, SettingsError
from ssskit.materials import get_material
from lab.oblique import (compare_flat_limit, flat_experiment, flat_prediction, interpolate_in_cos,
                                     pixel_angles, point_light, surface_reentry)
from lab.oblique_table import ObliqueTable, oblique_table
from ssskit.screenspace.camera import Camera
from ssskit.screenspace.gbuffer import GBuffer


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))


def _table() -> ObliqueTable:
    """A synthetic table: Rd = (0.4, 0.2, 0.1) x (1 - 0.5 (1 - cos theta_i)) at 0, 60, 80 degrees, radiance
    factor 1 + 0.1 k / 19 over the exit bins (k = 0 .. 19)."""
    ang = np.array([0.0, 60.0, 80.0])
    rd = np.array([0.4, 0.2, 0.1])[:, None] * (1 - 0.5 * (1 - np.cos(np.radians(ang))))[None]
    rad = np.broadcast_to(1 + 0.1 * np.arange(20) / 19, (3, 3, 20)).copy()
    return ObliqueTable(ang, rd, np.full_like(rd, 1e-4), rad, np.full_like(rad, 1e-3), 1.3, 1000)


def _gbuffer(e_left=1.0, e_right=3.0) -> GBuffer:
    """A flat 4 x 2 patch facing a camera 100 mm away along -z... the plane z = 0 seen from +z."""
    cam = Camera.from_fov(4, 2, 10.0, world_to_camera=np.diag([1.0, -1.0, -1.0, 1.0]) @ np.array(
        [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -100.0], [0, 0, 0, 1]]), world_units_per_mm=1.0)
    diffuse = np.zeros((2, 4, 3), np.float32)
    diffuse[:, :2] = e_left
    diffuse[:, 2:] = e_right
    normal = np.zeros((2, 4, 3), np.float32)
    normal[..., 2] = 1.0
    return GBuffer(diffuse=diffuse, albedo=np.ones((2, 4, 3), np.float32), depth=np.full((2, 4), 100.0, np.float32),
                   profile_id=np.ones((2, 4), np.uint32), camera=cam, normal=normal, materials=("m",))


def test_level_is_the_e_weighted_mean_of_the_pixels_radiance():
    tab = _table()
    gb = _gbuffer()
    light = np.array([1000.0, 0.0, 577.35])  # 60 degrees from the normal at the origin
    cos_i, cos_v = pixel_angles(gb, light)
    assert np.all(np.abs(np.degrees(np.arccos(cos_i)) - 60.0) < 0.2) and np.all(cos_v > 0.99)
    mask = np.ones((2, 4), bool)
    out = flat_prediction(gb, light, tab, {"all": mask})["all"]
    per_pixel = tab.exit_radiance(cos_i[mask], cos_v[mask])  # (3, P)
    e = gb.diffuse[mask][:, 0].astype(float)
    np.testing.assert_allclose(out["level"], per_pixel @ e / e.sum(), rtol=1e-12)
    split = np.array(out["rd0"]) * out["incidence"] * np.array(out["exit"])
    np.testing.assert_allclose(split, out["level"], rtol=1e-12)
    assert out["incidence_deg"] == pytest.approx(60.0, abs=0.2)
    # a boundary factor of 1.1 at every angle scales the level by 1.1; its error propagates as 1.1's
    withb = flat_prediction(gb, light, tab, {"all": mask},
                            boundary=([0.0, 90.0 - 1e-6], np.full((3, 2), 1.1), np.full((3, 2), 0.01)))["all"]
    np.testing.assert_allclose(withb["level"], 1.1 * np.asarray(out["level"]), rtol=1e-12)
    np.testing.assert_allclose(withb["boundary"], 1.1)
    assert all(0.007 < s <= 0.01 + 1e-12 for s in withb["boundary_se"])
    # the flat-limit comparison: exact level / predicted level, over the measured ratio
    cmp = compare_flat_limit(out, tab.rd[:, 0], [1.0, 1.0, 1.0], [0.01, 0.01, 0.01])
    np.testing.assert_allclose(cmp["predicted_exact_over_reference"], tab.rd[:, 0] / np.asarray(out["level"]))
    np.testing.assert_allclose(cmp["reference_over_flat"], cmp["predicted_exact_over_reference"])


def test_interpolation_in_cos():
    ang = [0.0, 60.0, 80.0]
    vals = np.array([[1.0, 2.0, 4.0]])
    np.testing.assert_allclose(interpolate_in_cos(ang, vals, np.cos(np.radians(ang))), vals)
    mid = 0.5 * (np.cos(np.radians(60.0)) + 1.0)
    np.testing.assert_allclose(interpolate_in_cos(ang, vals, mid), [1.5])
    np.testing.assert_allclose(interpolate_in_cos(ang, vals, 0.0), [4.0])


def test_point_light_only():
    assert point_light("bumpy") == pytest.approx([80.0, 20.0, 25.0])
    with pytest.raises(SceneError, match="one point light"):
        point_light("sphere")


def test_index_matched_flat_medium_at_grazing_incidence_matches_mcml():
    """Skin1 at eta = 1, light at 70 degrees, camera at 44 degrees (the bumpy tile's mean angles):
    Mitsuba's reference (index-matched boundary) over MCML's Rd(theta_i) x radiance factor at every
    pixel's angles. Measured with 4e5 photons and 256 spp at 32 x 24: ratios within 1% with a combined
    standard error of ~1% (MCML's exit bins, bounded conservatively, dominate); the bound is 3 standard
    errors and 3%, which a lost Fresnel factor at 70 degrees (12%) or the normal-incidence Rd (20-45% low
    here) fails by far."""
    mat = dataclasses.replace(get_material("skin1"), eta=1.0)
    # the pixels' incidence angles lie within 0.3 degrees of 70: held at 70 beyond it, interpolated towards 0
    # below it (< 0.1% from the node's value there)
    tab = oblique_table(mat, (0.0, 70.0), photons=400_000, seed=3)
    res = flat_experiment("skin1", 70.0, 44.0, -110.0, "index-matched", width=32, height=24, spp=256, table=tab)
    ratio, se = np.array(res["reference_over_prediction"]), np.array(res["reference_over_prediction_se"])
    assert np.all(se < 0.015), se
    assert np.all(np.abs(ratio - 1.0) <= np.minimum(3 * se, 0.03)), (ratio, se)
    # what the model of the pipeline would have said: Rd(0) E / pi, far off
    assert np.all(np.array(res["prediction"]["incidence"]) > 1.15)
    with pytest.raises(SettingsError, match="eta"):
        flat_experiment("skin1", 70.0, 44.0, -110.0, "rough-dielectric", spp=16, table=tab)


def test_fine_gbuffer_sums_over_the_sub_pixels():
    """With a fine G-buffer of the same view at 2 x 2 sub-pixels per pixel, a region's level is the E / pi
    weighted mean over its pixels' sub-pixels; a uniform flat patch gives the same level either way."""
    tab = _table()
    light = np.array([1000.0, 0.0, 577.35])
    coarse = _gbuffer(1.0, 1.0)
    cam = coarse.camera

    def flat(h, w):
        return GBuffer(diffuse=np.ones((h, w, 3), np.float32), albedo=np.ones((h, w, 3), np.float32),
                       depth=np.full((h, w), 100.0, np.float32), profile_id=np.ones((h, w), np.uint32),
                       camera=Camera.from_fov(w, h, 10.0, world_to_camera=cam.world_to_camera, world_units_per_mm=1.0),
                       normal=np.broadcast_to(np.float32([0, 0, 1]), (h, w, 3)).copy(), materials=("m",))

    fine = flat(4, 8)
    mask = np.zeros((2, 4), bool)
    mask[:, 1:3] = True
    a = flat_prediction(coarse, light, tab, {"r": mask})["r"]
    b = flat_prediction(coarse, light, tab, {"r": mask}, fine=fine)["r"]
    assert b["pixels"] == 4 and b["samples"] == 16
    np.testing.assert_allclose(b["level"], a["level"], rtol=2e-3)
    with pytest.raises(SettingsError, match="integer multiple"):
        flat_prediction(coarse, light, tab, {"r": mask}, fine=flat(4, 6))


def test_surface_reentry_is_zero_on_a_flat_surface_and_positive_on_the_relief():
    """Light leaving a flat surface never meets it again; on the bumpy tile (a swell and pits lit at
    ~70 degrees) some of the boundary's reflection and of the diffuse light re-enters. The reflected
    share on the flat slab is the rough dielectric's reflectance at 70 degrees (1 - its transmittance,
    sampled separately)."""
    from lab.flat import flat_scene, rough_dielectric_transmittance

    tab = _table()
    flat = surface_reentry(flat_scene(70.0, 44.0, -110.0), tab, samples=600, seed=1, batches=6)
    assert flat["specular_reentry"] == [0.0, 0.0, 0.0] and flat["diffuse_reentry"] == [0.0, 0.0, 0.0]
    t, t_se = rough_dielectric_transmittance(np.cos(np.radians([70.0])), 1.3, samples=4000, seed=3)
    assert abs(flat["reflected"] - (1 - t[0])) < 3 * np.hypot(flat["reflected_se"], t_se[0]) + 0.005
    bumpy = surface_reentry("bumpy", tab, samples=1200, seed=1, batches=6)
    assert all(0 < v < bumpy["reflected"] for v in bumpy["specular_reentry"])
    assert all(v > 0 for v in bumpy["diffuse_reentry"])
