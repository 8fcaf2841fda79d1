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
    with pytest.raises(GBufferError, match=r"layer 'light_depth' must be a float array of shape \(12, 16\), got shape \(11, 16\)"):
        base.with_layers(light_depth=ld[:-1], light=_light())
    with pytest.raises(GBufferError, match="size"):
        base.with_layers(light_depth=ld, light=_light(W + 1, H))
    with pytest.raises(GBufferError, match="irradiance"):
        base.with_layers(light_depth=ld, light={**_light(), "irradiance": [1.0, -1.0, 0.0]})
    assert not base.has_light and base.with_layers(light_depth=ld, light=_light()).has_light


def test_light_depth_takes_either_infinity_as_no_surface(base):
    """+-inf in the light map is a texel that meets no surface (the transmittance pass's SHADOW_MM takes both, as
    the G-buffer did before its layers became one table); NaN is refused, and the camera depth keeps refusing
    -inf (its range is (0, inf])."""
    ld = np.full((H, W), 100.0, np.float32)
    ld[0, 0], ld[0, 1] = np.inf, -np.inf
    gb = base.with_layers(light_depth=ld, light=_light())
    assert np.isposinf(gb.light_depth[0, 0]) and np.isneginf(gb.light_depth[0, 1])
    assert np.isneginf(gb.transmission_inputs()[1][0, 1])
    ld[0, 2] = np.nan
    with pytest.raises(GBufferError, match=r"layer 'light_depth' must be finite, got NaN or inf in 1 of 192 values"):
        base.with_layers(light_depth=ld, light=_light())
    depth = base.depth.copy()
    depth[0, 0] = -np.inf
    with pytest.raises(GBufferError, match=r"layer 'depth' must be finite, got NaN or inf in 1 of 192 pixels"):
        base.with_layers(depth=depth)


_SKEW = float(np.sqrt(0.5))


@pytest.mark.parametrize("change, fragment", [
    ({"direction": "down"}, "'direction' must be a real array of shape (3,), got shape () <U4"),
    ({"direction": ["d", 0, 1]}, "'direction' must be a real array of shape (3,), got shape (3,) <U"),
    ({"u": [1.0, 0.0]}, "'u' must be a real array of shape (3,), got shape (2,)"),
    ({"v": [0.0, float("inf"), 0.0]}, "'v' must be finite, got NaN or inf in 1 of 3 values"),
    ({"origin": [0.0, float("nan"), 0.0]}, "'origin' must be finite, got NaN or inf in 1 of 3 values"),
    ({"direction": [0.0, 0.0, 0.0]}, "'direction': its length must lie in [0.999, 1.001], got 0 (a unit vector"),
    ({"direction": [0.0, 0.0, -10.0]}, "'direction': its length must lie in [0.999, 1.001], got 10"),
    ({"u": [1.002, 0.0, 0.0]}, "'u': its length must lie in [0.999, 1.001], got 1.002"),
    ({"u": [_SKEW, _SKEW, 0.0]}, "'u' . 'v' must lie in [-0.001, 0.001], got 0.707107 (orthogonal axes"),
    ({"v": [0.0, 0.0, -1.0]}, "'direction' . 'v' must lie in [-0.001, 0.001], got 1 (orthogonal axes"),
    ({"size": [W + 0.5, H]}, "'size' must be an integer, got 16.5"),
    ({"size": [W, 0]}, "'size' must lie in [1, 2147483647] texels, got 0"),
    ({"size": [True, H]}, "'size' must be an integer, got True"),
    ({"texel_mm": float("nan")}, "'texel_mm' must lie in (0, inf) mm, got nan"),
    ({"irradiance": [1e39, 1.0, 1.0]}, "'irradiance' must lie in [0, 3.40282e+38], got 1e+39 in 1 of 3 values"),
    ({"irradiance": [1.0, float("inf"), 1.0]}, "'irradiance' must be finite, got NaN or inf in 1 of 3 values"),
    ({"irradiance": ["1", 1.0, 1.0]}, "'irradiance' must be a real array of shape (3,), got shape (3,) <U32"),
])
def test_a_meaningless_light_projection_is_refused_naming_the_field(base, change, fragment):
    """The projection's axes must be an orthonormal frame (what LightView.project assumes: u, v the map's axes in
    mm, direction the depth), the size whole texels, the irradiance a float32 the pass can hold (3.4e38)."""
    ld = np.full((H, W), 100.0, np.float32)
    with pytest.raises(GBufferError) as exc:
        base.with_layers(light_depth=ld, light={**_light(), **change})
    assert fragment in str(exc.value)


def test_a_light_frame_within_the_tolerance_passes(base):
    """A frame rounded to 4 digits (|length - 1| and |dot| ~ 1e-4, under 1e-3) and a float32 max irradiance load;
    an integral float size reads as the integer."""
    light = {**LightView.looking_along(np.array([0.3, -0.2, -1.0]), np.zeros(3), 40.0, (W, H)).to_dict(),
             "irradiance": [1.0, 1.0, 1.0]}
    rounded = {k: [round(x, 4) for x in light[k]] for k in ("direction", "u", "v")}
    assert rounded["direction"] != light["direction"]  # the rounding moved the frame
    top = float(np.finfo(np.float32).max)
    gb = base.with_layers(light_depth=np.full((H, W), 100.0, np.float32),
                          light={**light, **rounded, "size": [float(W), float(H)], "irradiance": [top, 0.0, 1.0]})
    assert LightView.from_dict(gb.light).size == (W, H)
    # arrays (a light dict built in Python, not read from JSON) are the same numbers as lists
    arrays = {k: (np.asarray(v) if isinstance(v, list) else v) for k, v in light.items()}
    base.with_layers(light_depth=np.full((H, W), 100.0, np.float32),
                     light={**arrays, "irradiance": np.array([1.0, 0.5, 0.25], np.float32)})
    assert LightView.from_dict(arrays).size == (W, H)


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


def test_the_pass_inputs_are_the_light_views_projection_of_the_positions(base):
    """transmission_inputs' row and column terms equal the direct route: the pixels' world positions (mm)
    projected by the light view, N . L from the normal layer, within float64 rounding; in float32 the same
    numbers rounded once."""
    cam = base.camera
    turned = np.array([[0.0, -1.0, 0.0, 3.0], [1.0, 0.0, 0.0, -2.0], [0.0, 0.0, 1.0, 0.5], [0, 0, 0, 1.0]])
    from dataclasses import replace

    light = {**LightView.looking_along(np.array([0.3, -0.2, -1.0]), np.array([1.0, 2.0, 0.0]), 30.0, (W, H)).to_dict(),
             "irradiance": [1.0, 2.0, 3.0]}
    for scale in (1.0, 0.1):  # a scene in mm and one in cm (world units per mm 0.1)
        c = replace(cam, world_to_camera=turned @ cam.world_to_camera, world_units_per_mm=scale)
        gb = base.with_layers(light_depth=np.full((H, W), 7.0, np.float32), light=light)
        gb = type(gb)(**{**{f: getattr(gb, f) for f in ("diffuse", "albedo", "depth", "profile_id", "specular",
                                                            "normal", "materials", "meta", "light_depth", "light")},
                         "camera": c})
        uvz, shadow, ndl, rgb = gb.transmission_inputs()
        view = LightView.from_dict(light)
        direct = view.project(gb.positions() / scale)
        np.testing.assert_allclose(uvz, direct, rtol=0, atol=1e-9 * np.abs(direct).max())
        np.testing.assert_allclose(ndl, gb.normal.astype(np.float64) @ -np.asarray(view.direction), rtol=0, atol=1e-12)
        np.testing.assert_allclose(shadow, 7.0 / scale)
        np.testing.assert_array_equal(rgb, np.broadcast_to([1.0, 2.0, 3.0], (H, W, 3)))
        f32 = gb.transmission_inputs(np.float32)
        assert all(a.dtype == np.float32 for a in f32)
        np.testing.assert_array_equal(f32[0], uvz.astype(np.float32))
