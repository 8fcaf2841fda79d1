"""experiments/adaptive_gap.py: the jitter sequence and the jittered plane it renders."""

import numpy as np

import adaptive_gap as ag


def test_halton_is_the_radical_inverse():
    # Halton (1964): base 2 gives 1/2, 1/4, 3/4, 1/8; base 3 gives 1/3, 2/3, 1/9
    assert [ag.halton(i, 2) for i in range(1, 5)] == [0.5, 0.25, 0.75, 0.125]
    np.testing.assert_allclose([ag.halton(i, 3) for i in range(1, 4)], [1 / 3, 2 / 3, 1 / 9], rtol=1e-15)


def test_jitter_is_sub_pixel_centred_and_repeats_every_eight_frames():
    offs = np.array([ag.taa_jitter(f) for f in range(16)])
    assert np.all(offs >= -0.5) and np.all(offs < 0.5)
    np.testing.assert_array_equal(offs[:8], offs[8:])
    assert len({tuple(o) for o in offs[:8]}) == 8
    assert abs(offs[:8, 0].mean()) < 0.07 and abs(offs[:8, 1].mean()) < 0.07


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
