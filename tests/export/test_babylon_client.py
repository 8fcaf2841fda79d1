"""The client: Babylon.js (@babylonjs/core, the pinned npm version, in headless Chromium) renders ssskit's
Babylon export on the shadow-edge slab of ssskit.view.babylon, read back as linear floats after its
subsurface pass. What is asserted: the plateau is the exported albedo; the export's default variant draws
the edge at the distances of ssskit's Burley prediction for the exported d (within the bumps of Babylon's
fixed 40-sample pattern); and the render settles how Babylon reads the profile colour: as the shape S = 1/d
per channel in r, g, b order (the other reading, the colour as d, predicts widths 3x off; the r, b, g order
predicts green 1.6x off). On the page's sphere, with the G-buffer Babylon's pass read read back: Babylon's
lit level equals ssskit's numpy Burley pass on that G-buffer, and past the terminator the narrow channels lose
the light that the export's doubled depth term removes. Skips with the reason without Chromium, Playwright or
@babylonjs/core."""

import numpy as np
import pytest

from ssskit.export import fit_burley
from ssskit.export.babylon import babylon_module, babylon_parameters
from ssskit.export.blender import compare_slab, edge_distances
from ssskit.materials import get_material
from ssskit.profiles import profile_for_material
from ssskit.view.babylon import babylon_available, crop_view

OK, WHY = babylon_available()
pytestmark = [pytest.mark.skipif(not OK, reason=f"no Babylon.js client: {WHY}"), pytest.mark.slow]

#: 8 rows; pixels a quarter of the narrowest d; the view wide enough that no sample leaves it
HEIGHT = 8


def _log_errors(cmp, d_pred, levels=(0, 1, 2)):
    """|log(measured / predicted)| per channel at the 25 / 10 / 3 % levels, against the widths ``d_pred``."""
    out = []
    for c, ch in enumerate(cmp["channels"]):
        pred = edge_distances(float(d_pred[c]), (0.25, 0.10, 0.03))
        got = [ch["distances"][j]["measured_mm"] for j in levels]
        assert all(g is not None for g in got), (c, got)
        out.append(float(np.mean(np.abs(np.log(np.array(got) / pred)))))
    return out


@pytest.fixture(scope="module")
def skin1():
    from ssskit.view.babylon import render_babylon

    a, d = fit_burley(profile_for_material(get_material("skin1"), "dipole"))
    params = babylon_parameters([("skin1", a, d)])
    w = params["variants"]["widest"]
    ext = 2.0 * w["filter_radius_mm"]["skin1"] + 1.6 * float(edge_distances(float(np.max(d)), (0.01,))[0])
    width = int(np.ceil(2 * ext / (float(np.min(d)) / 4)) // 8 * 8)
    job = {"width": width, "height": HEIGHT, "extent": ext, "intensity": 0.5, "shape": "slab", "material": "skin1",
           "variant": "widest"}
    k = w["metersPerUnit"] / params["unit_m"] / w["pixel_size_fix"]
    swapped = [1 / (k * d[0]), 1 / (k * d[2]), 1 / (k * d[1])]  # the widest colours with g and b exchanged
    res = render_babylon(babylon_module(params, "skin1"),
                         [dict(job, white=True), job, dict(job, override={"color": swapped})])
    reach = 1.05 * w["filter_radius_mm"]["skin1"]
    white, ext_c = crop_view(res[0]["image"], ext, reach)

    def compare(img, d_pred):
        img = crop_view(img, ext, reach)[0]
        return compare_slab({"images": [img] * 3, "white": [white] * 3, "extent_mm": [ext_c] * 3}, a,
                            np.asarray(d_pred))

    return a, d, k, compare, res


def test_plateau_is_the_exported_albedo(skin1):
    a, d, _, compare, res = skin1
    for ch in compare(res[1]["image"], d)["channels"]:
        assert abs(ch["plateau_ratio"] - 1.0) < 0.02, ch["plateau_ratio"]


def test_the_colour_is_the_shape_one_over_d(skin1):
    """The default export's render against the two readings of its colour 1/(k d): as Babylon's weights
    read it (S, widths d) it is within 16 % per level on average; as its sampling reads it (d = colour, widths
    d_min d_max / d in true mm) red and blue are off by more than 60 %: the readings differ by >= 20 %."""
    a, d, k, compare, res = skin1
    s_reading = _log_errors(compare(res[1]["image"], d), d)
    d_other = 1.0 / (k * k * d)  # the colour 1/(k d) read as a distance in the pass's mm (k true mm each)
    assert min(abs(np.log(d_other / d))[[0, 2]]) > np.log(1.2)  # the two readings predict >= 20 % apart
    d_reading = _log_errors(compare(res[1]["image"], d_other), d_other)
    assert max(s_reading) < 0.16, s_reading
    assert d_reading[0] > 0.5 and d_reading[2] > 0.5, d_reading


def test_the_colour_is_read_in_rgb_order(skin1):
    """The colour with g and b exchanged: Babylon's green channel follows the colour's g (Skin1's blue d),
    not its b: the r, b, g reading would predict green 1.6x wider."""
    a, d, _, compare, res = skin1
    rgb = _log_errors(compare(res[2]["image"], [d[0], d[2], d[1]]), [d[0], d[2], d[1]])
    rbg = _log_errors(compare(res[2]["image"], d), d)
    assert rgb[1] < 0.2 and rbg[1] > rgb[1] + 0.25, (rgb, rbg)


@pytest.fixture(scope="module")
def skin1_sphere():
    """Skin1 on the page's sphere (radius 8 d_max, 96^2 pixels, the 45-degree sun), the export's default
    variant, with what Babylon's subsurface pass read (pre-pass irradiance, profile index, view z) read back;
    and ssskit's numpy Burley pass (Golubev's sampler, as Babylon's) on that same G-buffer."""
    from ssskit.view.babylon import render_babylon, ssskit_pass, terminator_regions

    a, d = fit_burley(profile_for_material(get_material("skin1"), "dipole"))
    params = babylon_parameters([("skin1", a, d)])
    radius, size = 8.0 * float(np.max(d)), 96
    job = {"width": size, "height": size, "extent": 1.25 * radius, "intensity": 2.0, "shape": "sphere",
           "radius": radius, "material": "skin1", "variant": "widest", "gbuffer": True}
    res = render_babylon(babylon_module(params, "skin1"), [job])[0]
    g = res["gbuffer"]
    ours = ssskit_pass(g, a, d)
    babylon = res["image"] / np.sqrt(a)  # the pass's output: sqrt(albedo) x the blurred irradiance
    masks = terminator_regions(g, 2.5 * radius / size, float(np.max(d)))
    return a, d, res, g, babylon, ours, masks


def test_sphere_gbuffer_is_what_the_pass_read(skin1_sphere):
    """The read-back G-buffer is Babylon's: view z on the sphere is the camera's distance minus the height of a
    sphere of the rendered radius (to 1 % of the radius), the profile index is the export's one material (1),
    and the irradiance stays below the pre-pass's clamp at 1."""
    a, d, res, g, *_ = skin1_sphere
    on = g["sss"] & (g["profile"] > 0)
    assert set(np.unique(g["profile"][g["sss"]])) == {1}
    assert res["info"]["clipped"] == 0 and g["irradiance"].max() < 1.0
    radius = 8.0 * float(np.max(d))
    far = 50 * 1.25 * radius
    height = far - g["depth"][on]  # the surface's height above the sphere's centre plane
    assert height.max() == pytest.approx(radius, rel=0.01)
    assert height.min() > -0.01 * radius


def test_sphere_matches_ssskit_pass_on_the_same_gbuffer(skin1_sphere):
    """On the lit side, where the irradiance varies slowly, Babylon's blurred level equals ssskit's numpy pass on
    the same G-buffer to 2 % per channel; past the terminator (no direct light: the G-buffer's irradiance is 0)
    both carry the scattered light, red the most (Skin1's widest d), and Babylon's red is within 30 % of ssskit's."""
    a, d, res, g, babylon, ours, masks = skin1_sphere
    lit, dark = masks["lit (N.L >= 0.5)"], masks["dark, 0-1 d past"]
    assert lit.sum() > 200 and dark.sum() > 50
    for c in range(3):
        assert babylon[..., c][lit].mean() / ours[..., c][lit].mean() == pytest.approx(1.0, abs=0.02)
    assert np.all(g["irradiance"][dark] == 0)
    for img in (babylon, ours):
        level = [img[..., c][dark].mean() / img[..., c][lit].mean() for c in range(3)]
        assert level[0] > 0.05 and level[0] > level[1] > level[2], level
    ratio = babylon[..., 0][dark].mean() / ours[..., 0][dark].mean()
    assert 1 / 1.3 < ratio < 1.3, ratio


def test_sphere_narrow_channels_lose_light_to_the_doubled_depth_term(skin1_sphere):
    """The export's metersPerUnit x 2 (the pixel-size fix, docs/engines/babylon-sss-pixel-size.md) also doubles
    the depth step of Babylon's bilateral weight: past the terminator Skin1's green and blue carry at most 80 % of
    what ssskit's pass gives on the same G-buffer, and ssskit's pass with every depth step doubled comes within
    25 % of Babylon there (closer than the undoubled pass)."""
    from ssskit.view.babylon import ssskit_pass

    a, d, res, g, babylon, ours, masks = skin1_sphere
    ours2 = ssskit_pass(g, a, d, depth_scale=2.0)
    dark = masks["dark, 0-1 d past"]
    for c in (1, 2):
        b, o1, o2 = (img[..., c][dark].mean() for img in (babylon, ours, ours2))
        assert b / o1 < 0.8, (c, b, o1)
        assert abs(np.log(b / o2)) < np.log(1.25) and abs(np.log(b / o2)) < abs(np.log(b / o1)), (c, b, o1, o2)
