"""The controlled scene variants change only what they are meant to: the scaled scene gives the same
image with k x the depth; the backed scene blocks the surface the camera does not see and nothing the
camera sees (mask, E / pi), and it does remove light from the reference."""

import dataclasses

import numpy as np
import pytest

from ssskit.materials import get_material
from ssskit.scenes import SCENES, SceneError, render_gbuffer
from ssskit.scenes.reference import ReferenceRenderer
from ssskit.scenes.scenes import camera_pose, get_scene
from lab.variants import backed_scene, backing_faces, scaled_scene, surface_mesh

SKIN = get_material("skin1")
W, H = 64, 48


def _gb(scene):
    return render_gbuffer(scene, (0.5, 0.5, 0.5), eta=1.3, width=W, height=H, spp=4)


@pytest.mark.parametrize("scene", ["sphere", "ear", "slab"])
def test_scaled_scene_is_the_same_image_at_k_times_the_depth(scene):
    """E / pi is scale-free (area lights: same radiance and solid angle; point lights: intensity x k^2
    at k x the distance); only depth (and so the mm per pixel) grows by k."""
    g1 = _gb(scene)
    for k in (2.0, 8.0):
        gk = _gb(scaled_scene(scene, k))
        m = g1.mask
        np.testing.assert_array_equal(gk.mask, m)
        assert m.sum() > 100
        np.testing.assert_allclose(gk.diffuse[m], g1.diffuse[m], rtol=1e-3, atol=1e-5 * g1.diffuse[m].max())
        np.testing.assert_allclose(gk.depth[m], k * g1.depth[m], rtol=1e-4)
        np.testing.assert_allclose(gk.normal[m], g1.normal[m], atol=1e-4)


def test_scaled_scene_keeps_light_orbits_and_names():
    s = scaled_scene("sphere", 4)
    assert s.name == "sphere-x4" and s.sss_shapes == ("sphere",)
    np.testing.assert_allclose(camera_pose(s, 3)[0], 4 * camera_pose(SCENES.get("sphere"), 3)[0])
    assert s.shapes()["sphere"]["radius"] == 120.0
    assert get_scene(s) is s


@pytest.mark.parametrize("k", [0, -1, float("nan"), True, "2"])
def test_scaled_scene_rejects_bad_factors(k):
    with pytest.raises(SceneError, match="scale factor"):
        scaled_scene("sphere", k)


def test_backing_covers_exactly_the_unseen_surface():
    """The shell's faces are the faces whose vertices all face away from the camera, and every shell
    point lies outside the sphere (beyond the mesh's sag): it never cuts into the medium."""
    spec = SCENES.get("sphere")
    shape = spec.shapes()["sphere"]
    v, f, n, sag = surface_mesh(shape)
    eye = camera_pose(spec)[0]
    keep = backing_faces(v, f, n, eye)
    assert 0.3 < keep.mean() < 0.7  # about half of a sphere seen from outside
    c = v[f[keep]].mean(axis=1)
    assert np.all(np.sum((eye - c) * (c - np.array(shape["center"])), axis=1) < 0)
    shell = v + (sag + 0.001) * n
    tri = shell[f[keep]]
    # the flat shell faces' centroids (the points closest to the sphere) stay outside it
    assert np.linalg.norm(tri.mean(axis=1) - np.array(shape["center"]), axis=1).min() > shape["radius"]


@pytest.mark.parametrize("scene", ["sphere", "ear"])
def test_backed_scene_changes_nothing_the_camera_sees(scene):
    """Same SSS mask; E / pi the same except on a few silhouette pixels lit at grazing angles over the
    0.01 mm offset (the attribution takes each setup's levels against its own E / pi)."""
    g0, gb = _gb(scene), _gb(backed_scene(scene))
    np.testing.assert_array_equal(gb.mask, g0.mask)
    m = g0.mask
    changed = np.abs(gb.diffuse - g0.diffuse).max(axis=-1) > 1e-6
    assert (changed & m).sum() <= 0.01 * m.sum()
    assert abs(gb.diffuse[m].mean() / g0.diffuse[m].mean() - 1) < 2e-3


def test_backing_stops_the_light_of_a_back_light():
    """The ear lit by its key light alone (behind it: on the seen surface E / pi is ~0 but at the rim):
    the reference's front holds the light that came through the medium; with the backing almost
    none of it is left (< 0.5%, measured 0.02-0.2%: the key light's grazing entry on the seen rim;
    the shell lies beyond the few um by which Mitsuba spawns rays off the surface, at 0.002 mm 80%
    came through)."""
    mat = dataclasses.replace(SKIN, eta=1.0)  # index-matched: the low-noise boundary
    spec = SCENES.get("ear")
    m = _gb("ear").mask
    lit = dataclasses.replace(spec, name="ear-key", lights=lambda: {"key": spec.lights()["key"]})
    means = []
    for scene in (lit, backed_scene(lit)):
        r = ReferenceRenderer(scene, mat, W, H, max_depth=256, boundary="index-matched")
        means.append(np.array([r.chunk(i, 8)[m].mean(axis=0) for i in range(2)]).mean(axis=0))
    key, key_backed = means
    assert np.all(key > 1e-3)
    assert np.all(key_backed < 5e-3 * key)


def test_backing_needs_a_known_surface():
    with pytest.raises(SceneError, match="no backing"):
        backed_scene("slab").shapes()
    with pytest.raises(SceneError, match="offset"):
        backed_scene("ear", offset_mm=0)


# ---- thickness: the deepened ear (the thin slab: tests/scenes/test_thickness.py) ---------------------------------------------------------

def test_backing_shell_leaves_the_chords():
    """The backing shell is no SSS shape: the chord under every pixel is the plain ear's."""
    from ssskit.scenes.thickness import chord_thickness

    np.testing.assert_array_equal(chord_thickness(backed_scene("ear"), 80, 60), chord_thickness("ear", 80, 60))


def test_deepened_ear_keeps_the_seen_half_and_stretches_the_other():
    """The ear's half facing away from the camera is 10 x deeper along its short axis (y): the seen half's
    vertices and normals are written back unchanged, the back half reaches 10 x 2 mm; the G-buffer's mask,
    normals and depth are the same and E / pi too, but on a few rim pixels."""
    from lab.variants import _read_ply, deepened_scene

    deep = deepened_scene("ear", 10)
    v0, f0, n0 = _read_ply(get_scene("ear").shapes()["ear"]["filename"])
    v1, f1, n1 = _read_ply(deep.shapes()["ear"]["filename"])
    np.testing.assert_array_equal(f1, f0)
    front = v0[:, 1] <= 1e-9
    np.testing.assert_array_equal(v1[front], v0[front])
    np.testing.assert_array_equal(n1[front], n0[front])
    assert v0[:, 1].max() == pytest.approx(2.0, rel=1e-3) and v1[:, 1].max() == pytest.approx(20.0, rel=1e-3)
    # the stretched half's normals are the ellipsoid (18, 20, 28)'s: n ~ (x / 18^2, y / 20^2, (z - 32) / 28^2)
    back = v1[:, 1] > 0.5
    ref = (v1[back] - [0, 0, 32]) / np.array([18.0, 20.0, 28.0]) ** 2
    ref /= np.linalg.norm(ref, axis=1, keepdims=True)
    np.testing.assert_allclose(n1[back], ref, atol=2e-3)
    g0, g1 = _gb(backed_scene("ear")), _gb(backed_scene(deep))
    np.testing.assert_array_equal(g1.mask, g0.mask)
    m = g0.mask
    np.testing.assert_array_equal(g1.normal[m], g0.normal[m])
    np.testing.assert_array_equal(g1.depth[m], g0.depth[m])
    # E / pi: the same but on a few rim pixels whose samples partly see the floor, where the deeper ear's
    # shadow falls differently (the attribution takes each setup's levels against its own E / pi)
    changed = np.abs(g1.diffuse - g0.diffuse).max(axis=-1) > 1e-6
    assert (changed & m).sum() <= 0.01 * m.sum()
    assert abs(g1.diffuse[m].mean() / g0.diffuse[m].mean() - 1) < 2e-3


@pytest.mark.parametrize("args", [("slab", 2.0), ("ear", 0.5), ("ear", -2), ("ear", "3")])
def test_deepened_scene_rejects(args):
    from lab.variants import deepened_scene

    with pytest.raises(SceneError):
        deepened_scene(*args)
