"""Region metrics and the display encoding shared with image files."""

import numpy as np
import pytest

from ssskit import io, metrics
from ssskit.errors import SignalError
from ssskit.metrics import psnr, region_metrics, rmse


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
