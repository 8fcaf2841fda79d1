"""The flat medium lit and seen at chosen angles (:mod:`lab.flat`): its G-buffer has the
incidence and view angles asked for at every pixel, E / pi = 1 at the centre, and only the slab's
lit top face in view."""

import math

import numpy as np
import pytest

from ssskit.errors import SceneError
from lab.oblique_table import incidence_cosines
from ssskit.scenes import render_gbuffer
from lab.oblique_table import fresnel_transmittance
from lab.flat import SLAB_HALF_MM, camera_position, flat_scene, light_position, rough_dielectric_transmittance


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))


@pytest.mark.parametrize("incidence, view, azimuth", [(70.0, 44.0, -110.0), (23.0, 0.0, 0.0)])
def test_angles_on_every_pixel(incidence, view, azimuth):
    spec = flat_scene(incidence, view, azimuth)
    gb = render_gbuffer(spec, (1.0, 1.0, 1.0), eta=1.3, width=32, height=24, spp=4)
    assert gb.mask.all()
    pos = gb.positions()
    # the image lies on the top face, far inside the slab's edges
    assert np.abs(pos[..., 2]).max() < 0.5 and np.abs(pos[..., :2]).max() < SLAB_HALF_MM - 60.0
    inc = np.degrees(np.arccos(incidence_cosines(pos, gb.normal, light_position(incidence))))
    view_deg = np.degrees(np.arccos(gb.view_cosine()))
    # the light 1500 mm and the camera 600 mm away: the angles vary by < 1 and < 2.5 degrees across the image
    assert np.abs(inc - incidence).max() < 1.0
    assert np.abs(view_deg - view).max() < 2.5
    # E / pi = I cos / d^2 / pi = 1 at the origin: the centre pixels within the light's falloff across them
    c = gb.diffuse[10:14, 14:18, 0]
    assert c.mean() == pytest.approx(1.0, abs=0.02)
    # white light: E / pi the same in every channel; no highlight reaches the camera off-specular
    np.testing.assert_allclose(gb.diffuse[..., 0], gb.diffuse[..., 2], rtol=1e-5)
    if azimuth != 0.0:
        assert gb.specular.max() < 1e-6


def test_positions_and_names():
    eye = camera_position(44.0, -110.0)
    assert np.linalg.norm(eye) == pytest.approx(600.0)
    assert math.degrees(math.acos(eye[2] / 600.0)) == pytest.approx(44.0)
    assert math.degrees(math.atan2(eye[1], eye[0])) == pytest.approx(-110.0)
    assert flat_scene(70, 44, -110).name == "flat-i70-v44-a-110"
    for bad in (90.0, -1.0, float("nan"), True, "70"):
        with pytest.raises(SceneError, match="incidence angle"):
            flat_scene(bad)
    with pytest.raises(SceneError, match="view angle"):
        flat_scene(30.0, 95.0)


def test_rough_dielectric_transmittance():
    """The reference's boundary (Beckmann alpha = 0.15, eta 1.3) transmits what a smooth one does (1 - R,
    Born & Wolf 1.5.21/22) within 0.5% up to 70 degrees' incidence; at grazing incidence more (its
    microfacets face the light: 9% at 80 degrees, 45% at 85 measured with 5e4 samples)."""
    c = np.cos(np.radians([0.0, 60.0, 85.0]))
    t, se = rough_dielectric_transmittance(c, 1.3, samples=20_000, seed=2)
    smooth = fresnel_transmittance(c, 1.3)
    assert np.all(se / t < 0.01)
    assert abs(t[0] / smooth[0] - 1) < 3 * se[0] / t[0] + 1e-3
    assert abs(t[1] / smooth[1] - 1) < 0.01
    assert t[2] / smooth[2] > 1.3
    with pytest.raises(SceneError, match=r"eta must lie in \(1, inf\)"):
        rough_dielectric_transmittance(c, 1.0)
