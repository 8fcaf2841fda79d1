"""The back-lit built-in scenes (backlit.toml, leaf.toml) and their variants (scenes.backlit): the slab's light
layers give the pass its thickness, normal incidence and irradiance; the leaf is Apple, thinning to its rim."""

import math

import numpy as np
import pytest

from ssskit.errors import SceneError
from ssskit.scenes import SCENES, render_gbuffer
from ssskit.scenes.backlit import backlit_scene, backlit_slab
from ssskit.scenes.scenes import camera_pose


def _thickness(gb):
    from ssskit.backends.numpy_backend import shadow_depth

    uvz, shadow, ndl, light = gb.transmission_inputs()
    return uvz[..., 2] - shadow_depth(shadow, uvz[..., 0], uvz[..., 1]), ndl, light


@pytest.mark.parametrize("t", [0.5, 4.0])
def test_the_slab_is_lit_from_behind_through_its_thickness(t):
    """Every pixel sees the slab; the map's thickness is t (the G-buffer's depth is a mean over the pixel, a few
    hundredths of a mm off its centre at 45 degrees), the back faces the light squarely, and the irradiance is
    the sphere light's pi L (r / d)^2 at the slab's middle."""
    spec = backlit_slab(t)
    gb = render_gbuffer(spec, (0.5, 0.5, 0.5), width=32, height=24, spp=16, light_layers=True)
    thick, ndl, light = _thickness(gb)
    assert gb.mask.all()
    assert abs(float(np.median(thick)) - t) < 0.02
    np.testing.assert_allclose(ndl, -1.0, atol=1e-5)
    np.testing.assert_allclose(light, math.pi * 400.0 * (250.0 / (5000.0 - t / 2)) ** 2, rtol=1e-9)
    assert spec.name == f"backlit-{t:g}mm" and not np.any(gb.diffuse)  # the seen face is unlit


def test_the_view_moves_the_camera_about_the_slab():
    for deg in (0.0, 30.0):
        origin, target, _ = camera_pose(backlit_slab(2.0, deg))
        v = origin - target
        assert math.degrees(math.acos(v[2] / np.linalg.norm(v))) == pytest.approx(deg, abs=1e-9)
        assert np.linalg.norm(v) == pytest.approx(300.0)
    origin, target, _ = camera_pose(SCENES.get("backlit"))
    assert math.degrees(math.acos((origin - target)[2] / 300.0)) == pytest.approx(45.0)
    for bad in (0.0, -1.0, 41.0):
        with pytest.raises(SceneError, match="thickness"):
            backlit_slab(bad)
    with pytest.raises(SceneError, match="view angle"):
        backlit_slab(1.0, 85.0)
    with pytest.raises(SceneError, match="back-lit scene must be one of backlit, leaf"):
        backlit_scene("ear")


def test_the_leaf_is_apple_thinning_to_its_rim():
    spec = SCENES.get("leaf")
    assert spec.sss_materials == ("apple",)
    gb = render_gbuffer("leaf", (0.5, 0.5, 0.5), width=48, height=36, spp=4, light_layers=True)
    thick, ndl, _ = _thickness(gb)
    t_n = np.where(gb.mask, thick * np.clip(-ndl, 0, 1), np.nan)
    assert 0.2 < gb.mask.mean() < 0.7
    # 1.5 mm at the middle (the light's chord x cos 25 degrees), thin at the rim; through a map of 2 mm texels
    # (the frame's size) and depths averaged over 1.5 mm pixels seen at 45 degrees, a few tenths of a mm apart
    assert 1.1 < np.nanpercentile(t_n, 75) < 1.6 and np.nanpercentile(t_n, 5) < 0.4
    assert np.nanmedian(-ndl[gb.mask]) == pytest.approx(math.cos(math.radians(25.0)), abs=0.02)
