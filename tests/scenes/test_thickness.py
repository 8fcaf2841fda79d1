"""A scene's thickness (scenes.thickness): the chord under each pixel, exact on the thin slab and on the
ear the analytic ellipsoid's along the normal; the slab cut thin keeps its top face and its image."""

import numpy as np
import pytest

from ssskit.scenes import SceneError
from ssskit.scenes.scenes import camera_pose, get_scene, scene_camera
from ssskit.scenes import render_gbuffer
from ssskit.scenes.thickness import box_thickness_mm, chord_thickness, thin_scene


def test_chord_through_the_thin_slab_is_its_thickness():
    c = chord_thickness(thin_scene("slab", 3.0), 32, 24)
    assert np.isfinite(c).all()  # the 7 degree view sees only the slab's top face
    np.testing.assert_allclose(c, 3.0, rtol=1e-5)


def test_chord_through_the_ear_is_the_ellipsoids():
    """The ear is the ellipsoid (18, 2, 28) mm about (0, 0, 32): from a surface point p along the inward
    normal -n the chord is s = 2 |sum p_i n_i / r_i^2| / sum n_i^2 / r_i^2 (the quadratic's other root).
    The mesh (96 x 192) and its interpolated normals give it within 0.2% on the median pixel away from
    the rim (measured 0.03%), within 1% on 98% of them, within 5% on all (a few where the faceted mesh
    and the smooth ellipsoid differ most), and never more than the ellipsoid's 4 mm."""
    w, h = 80, 60
    c = chord_thickness("ear", w, h)
    ok = np.isfinite(c)
    assert ok.sum() > 1000 and np.nanmax(c) <= 4.0 + 1e-3
    # the analytic ellipsoid's chords at the pixel centres' hit points
    spec = get_scene("ear")
    cam = scene_camera(spec, w, h)
    eye = camera_pose(spec)[0]
    far = cam.unproject(np.ones((h, w)))
    r2 = np.array([18.0, 2.0, 28.0]) ** 2
    centre = np.array([0.0, 0.0, 32.0])
    ys, xs = np.nonzero(ok)
    rel = []
    for y, x in zip(ys[::7], xs[::7]):
        d = far[y, x] - eye
        d /= np.linalg.norm(d)
        # the ray's hit on the analytic ellipsoid: |(eye + s d - c) / r| = 1
        o = eye - centre
        a, b, cc = np.sum(d * d / r2), 2 * np.sum(o * d / r2), np.sum(o * o / r2) - 1
        s = (-b - np.sqrt(b * b - 4 * a * cc)) / (2 * a)
        p = o + s * d
        n = p / r2
        n /= np.linalg.norm(n)
        if abs(n @ d) < 0.3:  # the rim, where the mesh's facets and the pixel's footprint differ most
            continue
        chord = 2 * abs(np.sum(p * n / r2)) / np.sum(n * n / r2)
        rel.append(c[y, x] / chord - 1)
    rel = np.array(rel)
    assert rel.size > 100 and np.median(np.abs(rel)) < 0.002, rel
    assert np.mean(np.abs(rel) > 0.01) < 0.02 and np.max(np.abs(rel)) < 0.05, rel


def test_chord_rejects_a_wrong_mask():
    with pytest.raises(SceneError, match="mask"):
        chord_thickness("ear", 32, 24, mask=np.ones((10, 10), bool))


@pytest.mark.parametrize("size", [(-1, 5), (5, 0), (16, 2.5)])
def test_chord_and_incidence_refuse_an_image_size_before_any_array(size):
    """A width of -1 made chord_thickness's (H, W) array first: numpy's ValueError, not a SceneError."""
    from ssskit.scenes.thickness import incidence_angle

    for fn in (chord_thickness, incidence_angle):
        with pytest.raises(SceneError, match=r"image (width|height) must (lie in \[8, 8192\] px|be an integer)"):
            fn("slab", *size)


def test_incidence_angle_on_the_slab_is_the_point_lights():
    """The slab's top face (normal +z) under the point light at (400, 0, 1000): the angle at each seen point
    p is arccos((L - p)_z / |L - p|), 20-24 degrees over the view; a pixel outside the mask is NaN."""
    from ssskit.scenes.thickness import incidence_angle

    w, h = 32, 24
    mask = np.ones((h, w), bool)
    mask[0, 0] = False
    a = incidence_angle("slab", w, h, mask=mask)
    cam = scene_camera(get_scene("slab"), w, h)
    eye = camera_pose(get_scene("slab"))[0]
    far = cam.unproject(np.ones((h, w)))
    d = far - eye
    p = eye + d * (-eye[2] / d[..., 2:3])  # the pixel centre rays' hits on z = 0
    lp = np.array([400.0, 0.0, 1000.0]) - p
    ref = np.degrees(np.arccos(lp[..., 2] / np.linalg.norm(lp, axis=-1)))
    assert np.isnan(a[0, 0])
    np.testing.assert_allclose(a[mask], ref[mask], atol=1e-3)
    assert 20 < np.nanmin(a) and np.nanmax(a) < 24


def _gb(scene, w=64, h=48):
    return render_gbuffer(scene, (0.5, 0.5, 0.5), eta=1.3, width=w, height=h, spp=4)


def test_thin_scene_keeps_the_top_face_and_the_image():
    """The slab cut to 2 mm below its top face: its box is 2 mm thick, its top at z = 0 as before, and
    the G-buffer (mask, E / pi, depth) is the 20 mm slab's."""
    thin = thin_scene("slab", 2.0)
    box = thin.shapes()["slab"]
    assert thin.name == "slab-t2" and box_thickness_mm(box) == pytest.approx(2.0)
    m = np.array(box["to_world"].matrix)
    assert m[2, 3] + m[2, 2] == pytest.approx(0.0, abs=1e-6) and m[2, 3] - m[2, 2] == pytest.approx(-2.0)
    g0, g1 = _gb("slab"), _gb(thin)
    np.testing.assert_array_equal(g1.mask, g0.mask)
    np.testing.assert_allclose(g1.diffuse, g0.diffuse, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(g1.depth[g0.mask], g0.depth[g0.mask], rtol=1e-6)


@pytest.mark.parametrize("args", [("sphere", 2.0), ("slab", 20.0), ("slab", 0.0), ("slab", float("nan"))])
def test_thin_scene_rejects(args):
    with pytest.raises(SceneError):
        thin_scene(*args)
