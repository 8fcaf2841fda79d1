"""The region-wise comparison of a rendered frame: on the slab, the exact 2D convolution's plateau
level is the profile's total Rd (a uniformly lit flat surface far from every edge), and the shadow-edge
shape separates the screen-space kernel's error from the model's."""

import numpy as np
import pytest

from ssskit.pipeline import RenderSettings, SeparablePass, render


@pytest.fixture(scope="module")
def slab():
    return render("slab", RenderSettings(width=128, height=96, spp=4, perceptual=False, backend="numpy",
                                         pass_=SeparablePass(jitter=0.0)))


def test_plateau_level_of_the_exact_convolution_is_the_total_rd(slab):
    regions = slab.metrics["regions"]
    plateau = regions["regions"]["plateau"]
    assert plateau["pixels"] > 1000
    np.testing.assert_allclose(plateau["exact_2d"]["level"], slab.profile.total_rd(), rtol=2e-3)
    # a pass that conserves energy keeps the level on the plateau too
    np.testing.assert_allclose(plateau["screen_space"]["level"], slab.profile.total_rd(), rtol=5e-3)
    assert regions["regions"]["silhouette"]["pixels"] == 0  # the slab fills the frame
    # the pixel size at 600 mm and the reach of Skin1's dipole (99% of the red energy, 13.7 mm)
    assert regions["pixel_mm"] == pytest.approx(2 * 600 * np.tan(np.radians(3.5)) / 128, rel=1e-3)
    assert regions["radius_px"] * regions["pixel_mm"] == pytest.approx(
        float(np.max(slab.profile.radius_at_fraction(0.99))), rel=1e-9)


def test_edge_shape_of_the_straight_shadow_edge(slab):
    """The shadow edge is the image's middle column: the normalised profile goes from 1 on the lit
    plateau to ~0 deep in the shadow and is 1/2 (for a symmetric profile) at the edge itself."""
    shape = slab.metrics["regions"]["edge_shape"]
    c0, c1 = shape["columns"]
    assert c0 < 64 < c1 and shape["rows"] == 96
    exact = np.asarray(shape["profiles"]["exact_2d"])
    assert exact[0].min() > 0.9 and exact[-1].max() < 0.05
    mid = 64 - c0
    np.testing.assert_allclose(exact[mid - 1: mid + 1].mean(axis=0), 0.5, atol=0.06)
    kernel_err = shape["rmse_screen_space_vs_exact_2d"]
    assert 0 < kernel_err["rmse"] < 0.05 and kernel_err["resolved"]
