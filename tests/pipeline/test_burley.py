"""One frame of the Burley pass through the pipeline (:mod:`ssskit.pipeline.burley_frame`) and its exact ground
truth, checked against the independent construction of tests/screenspace/test_burley_consistency.py."""

import numpy as np
import pytest

from ssskit.errors import SettingsError
from ssskit.pipeline import BurleyPass, RenderSettings
from ssskit.pipeline.burley_frame import burley_exact, render_burley
from ssskit.screenspace import BurleySettings, Camera, GBuffer
from ssskit.screenspace.burley import burley_params_for_material
from tests.screenspace.test_burley_consistency import PARAMS, _disk_gbuffer, normalised_truth


def test_burley_exact_is_the_normalised_convolution():
    gb = _disk_gbuffer()
    truth, _ = normalised_truth(gb, PARAMS)
    np.testing.assert_allclose(burley_exact(gb, PARAMS), truth, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(burley_exact(gb, {1: PARAMS}), truth, rtol=1e-5, atol=1e-6)
    tall = gb.with_layers(camera=Camera(64, 48, 1200.0, 1000.0, 32, 24))
    assert burley_exact(tall, PARAMS) is None  # non-square pixels: no single cell grid


def test_render_burley_in_memory():
    gb = _disk_gbuffer()
    res = render_burley(gb, RenderSettings(perceptual=False, backend="numba", pass_=BurleyPass(spp=256, mips=False)),
                        params=PARAMS)
    assert res.metrics["exact_2d"]["psnr"] > 35
    assert res.to_dict()["burley"]["spp"] == 256
    np.testing.assert_array_equal(res.image, gb.composite(res.sss))
    with pytest.raises(SettingsError, match="not a Burley one"):
        render_burley(gb, RenderSettings())  # settings of the separable pass


def test_material_gives_the_burley_profile():
    from ssskit.materials import get_material
    from ssskit.profiles import burley_profile

    h, w = 8, 8
    gb = GBuffer(diffuse=np.ones((h, w, 3), np.float32), albedo=np.ones((h, w, 3), np.float32),
                 depth=np.full((h, w), 100.0, np.float32), profile_id=np.ones((h, w), np.uint32),
                 camera=Camera(w, h, 100.0, 100.0, 4, 4))
    res = render_burley(gb, RenderSettings(material="marble", perceptual=False, pass_=BurleyPass(spp=2)))
    assert res.params.d_mm == tuple(c.d for c in burley_profile(get_material("marble")).channels)
    np.testing.assert_allclose(res.sss, 1.0, rtol=1e-6)
    assert burley_params_for_material("marble").d_mm == res.params.d_mm


def test_converged_reference_is_cached(tmp_path, monkeypatch):
    from ssskit.pipeline.burley_frame import burley_reference
    from ssskit.screenspace import burley_sss

    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path))
    gb = _disk_gbuffer()
    a = burley_reference(gb, PARAMS, spp=64)
    files = list((tmp_path / "reference").glob("burley-*.npy"))
    assert len(files) == 1
    np.testing.assert_array_equal(a, burley_sss(gb, PARAMS, spp=64, sampler="exact", mips=False, seed=0))
    np.testing.assert_array_equal(burley_reference(gb, PARAMS, spp=64), a)  # from the cache
    b = burley_reference(gb, PARAMS, spp=32)  # another key
    assert len(list((tmp_path / "reference").glob("burley-*.npy"))) == 2 and not np.array_equal(a, b)
    # converged: closer to the exact limit than a 64-spp frame
    truth, _ = normalised_truth(gb, PARAMS)
    ref = burley_reference(gb, PARAMS, spp=4096)
    assert np.sqrt(np.mean((ref - truth)[gb.mask] ** 2)) < 0.25 * np.sqrt(np.mean((a - truth)[gb.mask] ** 2))
