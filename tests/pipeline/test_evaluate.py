"""Signals, metrics, evaluation of methods against the exact 2D convolution (the CLI's tests:
tests/cli/)."""

import numpy as np
import pytest

from ssskit.errors import SignalError
from ssskit.pipeline import evaluate
from ssskit.metrics import flip, psnr, relative_rmse, rmse, ssim
from ssskit.profiles import profile_for_material
from ssskit.scenes import make_signal


@pytest.fixture(scope="module")
def skin():
    return profile_for_material("skin1", "dipole")


# ---- signals ------------------------------------------------------------------------------------

def test_signals_shapes_and_coverage():
    for name in ("edge", "edge-rotated", "disk", "line", "texture"):
        img = make_signal(name, 64)
        assert img.shape == (64, 64, 3) and img.min() >= 0 and img.max() <= 1
    # a straight edge through the centre lights half the image; a disk of radius r covers pi r^2 pixels
    assert make_signal("edge-rotated", 64).mean() == pytest.approx(0.5, abs=1e-3)
    assert make_signal("disk", 128, radius_px=10).sum() / 3 == pytest.approx(np.pi * 100, rel=2e-3)
    np.testing.assert_array_equal(make_signal("texture", 32), make_signal("texture", 32))
    with pytest.raises(SignalError, match="size"):
        make_signal("edge", 3)
    with pytest.raises(SignalError, match="signal"):
        make_signal("checkerboard", 32)


# ---- metrics ------------------------------------------------------------------------------------

def test_metrics_against_definitions():
    a = np.random.default_rng(1).random((32, 32, 3))
    b = a + 0.01
    assert rmse(a, b) == pytest.approx(0.01)
    assert psnr(a, b, peak=1.0) == pytest.approx(40.0, abs=1e-9)
    assert relative_rmse(a, b) == pytest.approx(0.01 / np.sqrt(np.mean(a**2)))
    assert ssim(a, a) == pytest.approx(1.0) and ssim(a, b) < 1.0
    assert flip(a, a) == 0.0 and flip(a, np.zeros_like(a)) > 0.1
    with pytest.raises(SignalError, match="shape"):
        rmse(a, a[:10])


# ---- the paper's qualitative claims, checked on skin ----------------------------------------------

def test_paper_claims_on_skin(skin):
    methods = ["svd:1", "svd:2", "svd:3", "svd:6", "gaussians:1", "preintegrated", "jimenez2012"]
    edge = evaluate(skin, "edge", methods, size=128, perceptual=False).results
    disk = evaluate(skin, "disk", methods, size=128, perceptual=False).results
    # pre-integrated is exact on the axis-aligned edge (paper Sec. 4)
    assert edge["preintegrated"]["relative_rmse"] < 1e-6
    for res in (edge, disk):
        # rank-1 SVD is worse than pre-integrated at the same cost (paper Sec. 3)
        assert res["svd:1"]["relative_rmse"] > res["preintegrated"]["relative_rmse"]
        # pre-integrated beats one Gaussian at the same number of convolutions (Fig. S.4)
        assert res["gaussians:1"]["relative_rmse"] > res["preintegrated"]["relative_rmse"]
        assert res["preintegrated"]["convolutions_1d"] == res["gaussians:1"]["convolutions_1d"] == 2
        # SVD converges quickly with rank (Fig. 4)
        errs = [res[f"svd:{r}"]["relative_rmse"] for r in (1, 2, 3, 6)]
        assert all(a > 3 * b for a, b in zip(errs, errs[1:]))
    assert edge["jimenez2012"]["energy_matched"] is True


def test_repeated_evaluations_reuse_kernels_and_results(skin):
    """Kernels and metrics are memoised per profile object: a second evaluation gives the same numbers
    (as independent dicts), and keep_images still returns the images."""
    from ssskit.pipeline.evaluate import _RESULTS

    first = evaluate(skin, "disk", ["svd:2", "jimenez2012"], size=64, perceptual=False)
    assert any(k[1] == "disk" and k[3] == "svd:2" for k in _RESULTS)
    first.results["svd:2"]["rmse"] = -1.0  # callers may edit their copy
    again = evaluate(skin, "disk", ["svd:2", "jimenez2012"], size=64, perceptual=False, keep_images=True)
    assert again.results["svd:2"]["rmse"] > 0 and set(again.images) == {"svd:2", "jimenez2012"}
    third = evaluate(skin, "disk", ["svd:2"], size=64, perceptual=False)
    assert third.results["svd:2"] == again.results["svd:2"]


def test_one_spec_string_and_a_wrong_profile(skin):
    """A single spec given as a string is that one method (not its characters); a material or a name where the
    profile is expected is a ProfileError naming what is expected."""
    from ssskit.errors import ProfileError
    from ssskit.materials import get_material

    one = evaluate(skin, "disk", "svd:1", size=32, perceptual=False)
    assert list(one.results) == ["svd:1"]
    assert one.results == evaluate(skin, "disk", ["svd:1"], size=32, perceptual=False).results
    from ssskit.errors import SignalError

    with pytest.raises(SignalError, match="not bytes"):  # was "unknown kernel method '115'"
        evaluate(skin, "disk", b"svd:1", size=32, perceptual=False)
    for wrong in (get_material("skin1"), "skin1"):
        with pytest.raises(ProfileError, match=r"evaluate's profile \(profile_for_material\(material, model\)\) "
                                               "must be RGBProfile, got (Material|str)"):
            evaluate(wrong, "disk", ["svd:1"], size=32)
