"""Region metrics and the display encoding shared with image files."""

import numpy as np
import pytest

from ssskit import io, metrics
from ssskit.errors import SignalError
from ssskit.metrics import REGIONS, edge_profile, profile_rmse, psnr, region_level, region_masks, region_metrics, rmse


def test_region_metrics_use_only_the_masked_pixels():
    rng = np.random.default_rng(2)
    ref = rng.random((20, 30, 3))
    test = ref.copy()
    mask = np.zeros((20, 30), bool)
    mask[5:15, 10:20] = True
    test[mask] += 0.01
    test[~mask] += 5.0  # errors outside the mask do not count
    m = region_metrics(ref, test, mask, perceptual=False)
    assert set(m) == {"rmse", "relative_rmse", "psnr"}
    assert m["rmse"] == pytest.approx(0.01)
    assert m["psnr"] == pytest.approx(psnr(ref[mask][None], test[mask][None]))
    assert m["relative_rmse"] == pytest.approx(0.01 / np.sqrt(np.mean(ref[mask] ** 2)))
    assert "flip" in region_metrics(ref, ref, mask) and region_metrics(ref, ref, mask)["flip"] == 0.0


def test_region_metrics_empty_mask_and_bad_shapes():
    a = np.ones((4, 4, 3))
    m = region_metrics(a, a, np.zeros((4, 4), bool), perceptual=False)
    assert all(np.isnan(v) for v in m.values())
    with pytest.raises(SignalError, match="mask"):
        region_metrics(a, a, np.ones((3, 3), bool))
    with pytest.raises(SignalError, match="shape"):
        rmse(a, a[:2])


def test_tonemap_is_the_file_encoding():
    assert metrics.tonemap is io.tonemap
    x = np.array([0.0, 0.0031308, 0.5, 1.0, 2.0])
    np.testing.assert_allclose(io.tonemap(x, 1.0), [0.0, 0.04044994, 0.7353570, 1.0, 1.0], atol=1e-6)


def test_all_metrics_perceptual_names():
    from ssskit.metrics import all_metrics

    a = np.random.default_rng(4).random((16, 16, 3))
    assert set(all_metrics(a, a * 0.9, perceptual=("flip",))) == {"rmse", "relative_rmse", "psnr", "flip"}
    assert set(all_metrics(a, a * 0.9, perceptual=True)) == {"rmse", "relative_rmse", "psnr", "ssim", "flip"}
    assert set(all_metrics(a, a * 0.9, perceptual=False)) == {"rmse", "relative_rmse", "psnr"}
    with pytest.raises(SignalError, match="'lpips'"):
        all_metrics(a, a, perceptual=("lpips",))


# ---- region-wise comparison ---------------------------------------------------------------------------



def _half_lit(h=40, w=64, edge=32):
    e = np.zeros((h, w, 3))
    e[:, :edge] = 0.7
    return e


def test_region_masks_of_a_straight_shadow_edge():
    """A fully covered frame lit on its left half: no silhouette, no terminator, the shadow-edge band
    is the columns within the radius of the step, the plateau the lit columns beyond it."""
    e = _half_lit()
    m = region_masks(e, np.ones((40, 64), bool), radius_px=6.0)
    assert set(m) == set(REGIONS)
    assert not m["silhouette"].any() and not m["terminator"].any()
    band_cols = np.flatnonzero(m["shadow_edge"].any(axis=0))
    assert band_cols[0] == 31 - 6 and band_cols[-1] == 32 + 6 and m["shadow_edge"][:, band_cols].all()
    plateau_cols = np.flatnonzero(m["plateau"].any(axis=0))
    assert plateau_cols[0] == 0 and plateau_cols[-1] == 31 - 7
    # every region is inside the mask and they do not overlap
    total = sum(v.astype(int) for v in m.values())
    assert total.max() == 1


def test_region_masks_of_a_lit_disk():
    """A disk lit by cos(theta) from the left: a silhouette ring, a terminator where the light fades
    out smoothly, a plateau in the lit interior and no cast-shadow edge."""
    h = w = 96
    yy, xx = np.mgrid[:h, :w] + 0.5
    r = np.hypot(xx - 48, yy - 48)
    mask = r < 40
    nx = np.clip((48 - xx) / 40, -1, 1)  # normal's component towards a light at the far left
    e = np.where(mask, np.clip(nx, 0, None) * 0.8, 0.0)
    m = region_masks(e, mask, radius_px=4.0)
    assert m["silhouette"].any() and np.all(r[m["silhouette"]] >= 40 - 4 - 1)
    assert not m["shadow_edge"].any()
    assert m["terminator"].any() and np.all(np.abs(xx[m["terminator"]] - 48) < 0.26 * 40)
    assert m["plateau"].any() and np.all(e[m["plateau"]] > 0.5 * 0.8 * 0.9)


def test_region_level_is_the_albedo_of_a_lambertian_surface():
    """A surface of albedo A under any light has diffuse part A E / pi: its level is A in every
    region, whatever the light; pixel errors add in quadrature."""
    rng = np.random.default_rng(1)
    e = rng.uniform(0.1, 2.0, size=(30, 40, 3))
    a = np.array([0.6, 0.35, 0.2])
    region = rng.random((30, 40)) < 0.3
    out = region_level(a * e, e, region, pixel_se=np.full(e.shape, 0.01))
    np.testing.assert_allclose(out["level"], a, rtol=1e-12)
    n = region.sum()
    np.testing.assert_allclose(out["se"], 0.01 * np.sqrt(n) / n / e[region].mean(axis=0), rtol=1e-12)
    assert out["pixels"] == n


def test_edge_profile_is_independent_of_the_albedo():
    e = _half_lit()
    blur = np.cumsum(e[:, ::-1], axis=1)[:, ::-1] / 64  # any smooth profile across the edge
    region = np.ones((40, 64), bool)
    p1, _ = edge_profile(0.5 * blur, region, 0.5 * blur[0, 0])
    p2, _ = edge_profile(0.2 * blur, region, 0.2 * blur[0, 0])
    np.testing.assert_allclose(p1, p2, rtol=1e-12)
    assert p1[0, 0] == pytest.approx(1.0)


def test_profile_rmse_separates_a_difference_from_the_reference_noise():
    rng = np.random.default_rng(2)
    truth = np.linspace(1, 0, 200)
    s = np.full(200, 0.02)
    noisy = truth + rng.normal(0, 0.02, 200)
    same = profile_rmse(truth, noisy, s)
    assert same["rmse"] == pytest.approx(0.02, rel=0.2) and same["noise"] == pytest.approx(0.02)
    assert not same["resolved"]
    off = profile_rmse(truth + 0.1, noisy, s)
    assert off["resolved"] and off["rmse"] == pytest.approx(0.1, rel=0.1)
    assert off["rmse_se"] == pytest.approx(0.02 / np.sqrt(200), rel=0.3)


def test_ssim_refuses_images_smaller_than_its_window():
    """Wang et al.'s 11 x 11 Gaussian window (sigma 1.5): a smaller image is a SignalError saying so, not
    scikit-image's ValueError; an 11 x 11 image has an SSIM, 1 against itself."""
    a = np.random.default_rng(0).random((12, 12, 3))
    for h, w in ((3, 3), (10, 12), (12, 7)):
        with pytest.raises(SignalError, match="SSIM needs images of at least 11 x 11 pixels"):
            metrics.ssim(a[:h, :w], a[:h, :w])
    assert metrics.SSIM_MIN_SIDE == 11
    assert metrics.ssim(a[:11, :11], a[:11, :11]) == pytest.approx(1.0)
