"""experiments/adaptive_gap.py: the jittered plane it renders (the jitter sequence is the product's:
tests/screenspace/test_taa.py)."""

import numpy as np

import adaptive_gap as ag


def test_unjittered_plane_is_the_figures_plane():
    from ssskit.figures.adaptive import shadow_plane

    for distance in ("regular", "close"):
        np.testing.assert_array_equal(ag.jittered_plane(40, 24, distance, 0.0, 0.0).diffuse,
                                      shadow_plane(40, 24, distance).diffuse)


def test_anti_aliased_plane_is_the_lit_fraction_of_each_pixel():
    gb = ag.jittered_plane(40, 24, "regular", 0.25, 0.0, area=4)
    d = gb.diffuse[..., 0]
    # the edge is at x = 20 (the plane samples pixel i at x = i): pixel 20's samples at x = 20.25 + (-3/8, -1/8,
    # 1/8, 3/8): 3 of its 4 columns lit; pixel 19's none
    np.testing.assert_allclose(d[0, 20], 0.05 + (0.8 - 0.05) * 0.75, rtol=1e-6)
    np.testing.assert_allclose(d[0, 19], 0.05, rtol=1e-6)
    np.testing.assert_allclose(d[0, 30], 0.8, rtol=1e-6)
    np.testing.assert_allclose(d[0, 0], 0.05, rtol=1e-6)
    assert np.all((d >= 0.05 - 1e-6) & (d <= 0.8 + 1e-6))
