"""The light's view of a scene (scenes.lightspace): the ray-cast chord along the light is the sphere's
analytic chord, and the thickness a translucency shadow map gives converges to it as the map gets finer."""

import numpy as np

from ssskit.scenes.lightspace import depth_map, scene_light_view, seen_truth
from ssskit.screenspace.transmission import thickness_from_map

CENTRE, RADIUS = np.array([0.0, 0.0, 30.0]), 30.0  # sphere.toml


def test_the_chord_along_the_light_is_the_spheres():
    """From a point p on the sphere, the ray towards the light (-d) crosses the sphere for 2 (p - c) . d
    when that is positive (p on the side away from the light), else p is lit directly (0)."""
    view = scene_light_view("sphere", 16)
    truth = seen_truth("sphere", view, 24, 24)
    d = np.asarray(view.direction)
    analytic = np.maximum(2.0 * (truth["points"] - CENTRE) @ d, 0.0)
    assert len(analytic) > 100 and np.count_nonzero(analytic > 1.0) > 10
    np.testing.assert_allclose(truth["chord"], analytic, atol=1e-3)
    np.testing.assert_allclose(truth["through"], truth["chord"], atol=1e-3)  # a convex object: no gaps


def test_the_maps_thickness_converges_to_the_chord():
    errs = []
    for res in (32, 128):
        view = scene_light_view("sphere", res)
        truth = seen_truth("sphere", view, 24, 24)
        th = thickness_from_map(view, depth_map("sphere", view), truth["points"])
        m = truth["chord"] > 0.05
        e = np.abs(th[m] - truth["chord"][m])
        assert not np.isnan(e).any()
        errs.append((float(np.median(e)), view.texel_mm))
    # the median error falls with the texel (bilinear depth on a smooth surface: faster than linearly)
    assert errs[1][0] < 0.5 * errs[0][0], errs
    assert errs[1][0] < errs[1][1], errs  # and is below one texel at 128 texels
