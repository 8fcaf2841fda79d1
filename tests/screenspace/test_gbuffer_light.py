"""The G-buffer's optional light layers (screenspace.gbuffer): both or neither, the map the projection's
size, saved and loaded through the EXR, and the pass's inputs from them on a ray-cast sphere."""

import numpy as np
import pytest

from ssskit.errors import GBufferError
from ssskit.screenspace import load_gbuffer
from ssskit.screenspace.transmission import LightView

H, W = 12, 16




def _light(w=W, h=H):
    v = LightView.looking_along(np.array([0.0, 0.0, -1.0]), np.zeros(3), 40.0, (w, h))
    return {**v.to_dict(), "irradiance": [2.0, 2.0, 2.0]}


@pytest.fixture
def base():
    from ssskit.scenes import render_gbuffer

    return render_gbuffer("sphere", (0.5, 0.5, 0.5), width=W, height=H, spp=1)


def test_both_or_neither_and_the_right_shape(base):
    ld = np.full((H, W), 100.0, np.float32)
    with pytest.raises(GBufferError, match="light projection.*missing"):
        base.with_layers(light_depth=ld)
    with pytest.raises(GBufferError, match="without a 'light_depth'"):
        base.with_layers(light=_light())
    with pytest.raises(GBufferError, match="light_depth' has shape"):
        base.with_layers(light_depth=ld[:-1], light=_light())
    with pytest.raises(GBufferError, match="size"):
        base.with_layers(light_depth=ld, light=_light(W + 1, H))
    with pytest.raises(GBufferError, match="irradiance"):
        base.with_layers(light_depth=ld, light={**_light(), "irradiance": [1.0, -1.0, 0.0]})
    assert not base.has_light and base.with_layers(light_depth=ld, light=_light()).has_light


def test_light_layers_round_trip_through_the_exr(base, tmp_path):
    from ssskit.scenes.lightspace import light_layers

    ld, light = light_layers("sphere", W, H)
    assert np.isfinite(ld).any() and np.isinf(ld).any()  # the sphere, and texels beside it that meet no SSS surface
    gb = base.with_layers(light_depth=ld, light=light)
    gb.save(tmp_path / "g.exr")
    back = load_gbuffer(tmp_path / "g.exr")
    np.testing.assert_array_equal(back.light_depth, gb.light_depth)
    assert back.light == gb.light
    uvz, shadow, ndl, rgb = back.transmission_inputs()
    assert uvz.shape == (H, W, 3) and shadow.shape == (H, W) and ndl.shape == (H, W) and rgb.shape == (H, W, 3)
    # a sphere pixel's depth along the light lies at or behind the map's first surface (up to a texel's slope)
    from ssskit.backends.numpy_backend import shadow_depth

    d = shadow_depth(shadow, uvz[..., 0], uvz[..., 1])
    m = back.mask & np.isfinite(d)
    assert m.sum() > 10
    assert np.all(uvz[..., 2][m] - d[m] > -3 * LightView.from_dict(light).texel_mm)


def test_render_gbuffer_writes_the_light_layers():
    from ssskit.scenes import render_gbuffer

    gb = render_gbuffer("sphere", (0.5, 0.5, 0.5), width=W, height=H, spp=1, light_layers=True)
    assert gb.has_light and gb.light_depth.shape == (H, W) and gb.light["size"] == [W, H]
    assert not render_gbuffer("sphere", (0.5, 0.5, 0.5), width=W, height=H, spp=1).has_light
