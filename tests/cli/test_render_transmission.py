"""``ssskit render --transmission``: the transmittance pass in a rendered frame and in every frame of
``--pass burley-adaptive`` (docs/transmission.md), on the back-lit ear (its key light behind it), and the bad
inputs it refuses (one line, exit status 2, nothing written)."""

import json

import numpy as np
import pytest

from .test_bad_input import one_error_line

SIZE = "32x24"
QUICK = ("--backend", "numpy", "--no-exact", "--no-perceptual")


def _image(path):
    import OpenEXR

    with OpenEXR.File(str(path)) as f:
        ch = f.channels()
        return {name: np.asarray(c.pixels) for name, c in ch.items()}


@pytest.fixture(scope="module")
def ear(tmp_path_factory):
    """The ear rendered with --transmission on (separable pass, numpy backend): its JSON, image and G-buffer
    with the light layers."""
    from ssskit.cli import main

    folder = tmp_path_factory.mktemp("ear")
    out, gbf = folder / "on.exr", folder / "light.exr"
    code = main(["render", "--scene", "ear", "--size", SIZE, "--spp", "1", *QUICK, "--transmission", "on",
                 "--save-gbuffer", str(gbf), "--out", str(out)])
    assert code == 0 and out.is_file() and gbf.is_file()
    return folder, out, gbf


def _render(run, *args):
    code, out, err = run("render", *args, "--json")
    assert code == 0, err
    return json.loads(out)


def test_transmission_on_is_brighter_behind_and_off_is_the_reflectance_pass(run, ear):
    from ssskit.screenspace import load_gbuffer

    folder, on_exr, gbf = ear
    gb = load_gbuffer(gbf)
    assert gb.has_light
    on = _image(on_exr)
    # the same G-buffer, transmission off; and with its light layers stripped (what ssskit rendered before the
    # pass existed: the reflectance pass never reads the layers), under auto and off
    plain = folder / "plain.exr"
    gb.with_layers(light_depth=None, light=None).save(plain)
    outs = {}
    for name, scene, mode in (("off", gbf, "off"), ("plain_off", plain, "off"), ("plain_auto", plain, "auto"),
                              ("auto", gbf, "auto")):
        outs[name] = folder / f"{name}.exr"
        data = _render(run, "--scene", scene, *QUICK, "--transmission", mode, "--out", outs[name])
        assert data["transmission"]["ran"] is (name == "auto")
        assert data["settings"]["transmission"] == mode
    off, auto = _image(outs["off"]), _image(outs["auto"])
    np.testing.assert_array_equal(_image(outs["plain_off"])["RGB"], off["RGB"])
    np.testing.assert_array_equal(_image(outs["plain_auto"])["RGB"], off["RGB"])
    assert "transmission" not in off and "transmission" in on
    # auto on the G-buffer with the layers runs the pass: the frame rendered with on
    np.testing.assert_array_equal(auto["RGB"], on["RGB"])
    # brighter behind: the transmitted light is >= 0, lit where the back sees the key light, nothing outside the mask
    mask = gb.mask
    t = on["transmission"]
    assert np.all(t >= 0) and not np.any(t[~mask])
    lit = np.any(t > 0, axis=-1)
    assert lit.sum() > 0.5 * mask.sum()  # the key light is behind the ear: most of the seen side is lit through
    gain = on["RGB"] - off["RGB"]
    assert np.all(gain[~mask] == 0)
    # adding light >= 0 never darkens (float32 rounding is monotone); where it is lit it shows
    assert np.all(gain >= 0) and np.mean(np.any(gain[lit] > 0, axis=-1)) > 0.9
    # the composite holds the transmitted radiance on top of the reflectance (float32 rounding)
    np.testing.assert_allclose(gain, t, rtol=1e-5, atol=1e-7 * float(np.abs(on["RGB"]).max()))
    # red crosses the most tissue (MCML's skin T(t): R > G > B) and the back-lit ear gains severalfold
    mean_gain = gain[mask].mean(axis=0)
    assert mean_gain[0] > mean_gain[1] > mean_gain[2] > 0
    assert mean_gain[0] > off["RGB"][mask].mean(axis=0)[0]


def test_json_reports_the_pass_and_its_model(run, ear):
    _, _, gbf = ear
    for model in ("mcml", "jimenez2010"):
        data = _render(run, "--scene", gbf, *QUICK, "--transmission-model", model)
        assert data["transmission"]["ran"] and data["transmission"]["model"] == model
        assert data["transmission"]["lit_pixels"] > 0
    data = _render(run, "--scene", gbf, *QUICK, "--pass", "burley", "--spp", "4", "--transmission", "on")
    assert data["pass"] == "burley" and data["transmission"]["ran"] and data["transmission"]["model"] == "mcml"
    code, out, err = run("render", "--scene", gbf, *QUICK)
    assert code == 0 and "# transmission: mcml model" in out, err
    # the spread and the setting apart: "lateral spread off (setting on)" read as a contradiction
    line = next(x for x in out.splitlines() if x.startswith("# transmission:"))
    assert line.endswith(", lateral spread off; transmission setting auto"), line


def test_burley_with_transmission_is_brighter_behind(run, ear):
    folder, _, gbf = ear
    outs = {}
    for mode in ("off", "on"):
        outs[mode] = folder / f"burley_{mode}.exr"
        _render(run, "--scene", gbf, *QUICK, "--pass", "burley", "--spp", "4", "--transmission", mode,
                "--out", outs[mode])
    on, off = _image(outs["on"]), _image(outs["off"])
    np.testing.assert_allclose(on["RGB"] - off["RGB"], on["transmission"], rtol=1e-5,
                               atol=1e-7 * float(np.abs(on["RGB"]).max()))
    assert np.any(on["transmission"] > 0)


def test_adaptive_run_adds_the_light_to_every_frame(run, ear):
    """--pass burley-adaptive --transmission on along the ear's camera and light paths (moving, its G-buffers
    rendered with the light layers of each frame's light): the same sample counts as with it off (the guiding
    phase sees the reflectance pass), the JSON and the summary name the pass, the EXR holds the last frame's
    transmitted light; on the G-buffer file (static), the same light as the one-frame Burley pass."""
    folder, _, gbf = ear
    moving = ("--scene", "ear", "--pass", "burley-adaptive", "--size", "24x16", "--limit-spp", "64", "--frames", "2",
              "--budget", "2:8", "--backend", "numpy", "--no-perceptual")
    out = folder / "adaptive_on.exr"
    on = _render(run, *moving, "--transmission", "on", "--out", out)
    off = _render(run, *moving, "--transmission", "off")
    assert on["transmission"]["ran"] and on["transmission"]["model"] == "mcml" and not off["transmission"]["ran"]
    assert on["transmission"]["lit_pixels"] > 0
    assert [r["mean_spp"] for r in on["frames"]] == [r["mean_spp"] for r in off["frames"]]
    layers = _image(out)
    assert "transmission" in layers and np.any(layers["transmission"] > 0)
    code, text, err = run("render", *moving, "--transmission", "on")
    assert code == 0 and "# transmission: mcml model" in text, err
    static = folder / "adaptive_static.exr"
    one = folder / "burley_one.exr"
    data = _render(run, "--scene", gbf, *QUICK, "--pass", "burley-adaptive", "--frames", "2", "--budget", "2:4",
                   "--out", static)
    assert data["static"] and data["transmission"]["ran"]
    _render(run, "--scene", gbf, *QUICK, "--pass", "burley", "--spp", "4", "--out", one)
    np.testing.assert_array_equal(_image(static)["transmission"], _image(one)["transmission"])


@pytest.fixture
def workdir(tmp_path, monkeypatch, ear, gbuffer_file):
    """An empty folder holding the G-buffers of the bad inputs: without layers, the layers' variants."""
    from ssskit.io import read_exr, write_exr

    monkeypatch.chdir(tmp_path)
    (tmp_path / "plain.exr").write_bytes(gbuffer_file.read_bytes())
    header, channels = read_exr(ear[2], required=("diffuse",))
    attrs = {k: v for k, v in header.items() if k.startswith("ssskit_")}
    light = json.loads(attrs["ssskit_light"])
    ld = channels["light_depth"]
    variants = {
        "rgb_depth.exr": ({**channels, "light_depth": np.repeat(ld[..., None], 3, axis=-1)}, attrs),
        "map_size.exr": (channels, {**attrs, "ssskit_light": json.dumps({**light, "size": [64, 64]})}),
        "no_projection.exr": (channels, {k: v for k, v in attrs.items() if k != "ssskit_light"}),
        "dir_word.exr": (channels, {**attrs, "ssskit_light": json.dumps({**light, "direction": "down"})}),
        "dir_long.exr": (channels, {**attrs, "ssskit_light": json.dumps({**light, "direction": [
            10 * x for x in light["direction"]]})}),
        "u_is_v.exr": (channels, {**attrs, "ssskit_light": json.dumps({**light, "u": light["v"]})}),
        "size_half.exr": (channels, {**attrs, "ssskit_light": json.dumps({**light, "size": [
            light["size"][0] + 0.5, light["size"][1]]})}),
        "irr_huge.exr": (channels, {**attrs, "ssskit_light": json.dumps({**light, "irradiance": [1e39, 1, 1]})}),
    }
    for name, (ch, at) in variants.items():
        write_exr(tmp_path / name, ch, at)
    return tmp_path


@pytest.mark.parametrize("args, fragment", [
    (["--scene", "plain.exr", "--transmission", "on"], "transmission on (--transmission on) needs the G-buffer's light "
                                                        "layers"),
    (["--scene", "plain.exr", "--pass", "burley", "--transmission", "on"], "needs the G-buffer's light layers"),
    (["--scene", "rgb_depth.exr"], "layer 'light_depth' must be a float array of shape ("),
    (["--scene", "map_size.exr", "--transmission", "off"], "the light projection's size [64, 64] is not the "
                                                           "'light_depth' layer's"),
    (["--scene", "no_projection.exr"], "the light projection (header 'ssskit_light'), which is missing"),
    (["--scene", "dir_word.exr"], "'direction' must be a real array of shape (3,), got shape () <U4"),
    (["--scene", "dir_long.exr", "--transmission", "off"], "'direction': its length must lie in [0.999, 1.001], got"),
    (["--scene", "u_is_v.exr"], "'u' . 'v' must lie in [-0.001, 0.001], got 1 (orthogonal axes"),
    (["--scene", "size_half.exr"], "the light projection's 'size' must be an integer, got "),
    (["--scene", "irr_huge.exr"], "'irradiance' must lie in [0, 3.40282e+38], got 1e+39"),
    (["--scene", "plain.exr", "--transmission-model", "foo"], "Invalid value for '--transmission-model': 'foo'"),
    (["--scene", "plain.exr", "--transmission", "maybe"], "Invalid value for '--transmission'"),
    (["--scene", "plain.exr", "--transmission", "off", "--transmission-model", "jimenez2010"],
     "transmission_model applies to transmission auto or on, not transmission off"),
    (["--scene", "plain.exr", "--pass", "burley-adaptive", "--transmission", "on"], "needs the G-buffer's light layers"),
    (["--scene", "rgb_depth.exr", "--pass", "burley-adaptive"], "layer 'light_depth' must be a float array of shape ("),
    (["--scene", "plain.exr", "--pass", "burley-adaptive", "--transmission-model", "unreal2"],
     "Invalid value for '--transmission-model': 'unreal2'"),
    (["--scene", "plain.exr", "--pass", "burley-adaptive", "--transmission", "off", "--transmission-model",
      "jimenez2010"], "transmission_model applies to transmission auto or on, not transmission off"),
    (["--scene", "plain.exr", "--transmission-spread", "wide"], "Invalid value for '--transmission-spread': 'wide'"),
    # auto with no light layers: the pass does not run, so a model or spread asked for would be dropped silently
    (["--scene", "plain.exr", "--transmission-model", "jimenez2010"], "transmission_model applies to transmission on, "
                                                                      "not transmission auto (the G-buffer "),
    (["--scene", "plain.exr", "--transmission-spread", "mcml"], "transmission_spread applies to transmission on, not"),
    (["--scene", "slab", "--transmission-model", "unreal"], "the scene slab is not lit from behind alone"),
    (["--scene", "plain.exr", "--transmission", "off", "--transmission-spread", "mcml"],
     "transmission_spread applies to transmission auto or on, not transmission off"),
])
def test_bad_transmission_input(run, workdir, args, fragment):
    one_error_line(run, workdir, ["render", *args, "--backend", "numpy", "--out", "o.exr", "--save-gbuffer", "g2.exr"],
                   fragment)


@pytest.mark.parametrize("content, fragment", [
    ("transmission_model = 'foo'\n", "transmission_model must be one of mcml, jimenez2010, unreal, got 'foo'"),
    ("transmission = 'yes'\n", "transmission must be one of auto, on, off, got 'yes'"),
    ("transmission_spread = 'wide'\n", "transmission_spread must be one of mcml, off, got 'wide'"),
    ("transmission = 'off'\ntransmission_spread = 'mcml'\n", "transmission_spread applies to transmission auto or on, not transmission off"),
])
def test_bad_transmission_settings_file(run, workdir, content, fragment):
    (workdir / "s.toml").write_text(content)
    one_error_line(run, workdir, ["render", "--scene", "plain.exr", "--settings", "s.toml", "--out", "o.exr"], fragment)


def test_a_material_outside_the_transmission_domain_fails_before_the_frame(run, tmp_path, tmp_path_factory,
                                                                            monkeypatch):
    """A material so clear that the light crossing 200 mm unscattered is above the table's floor
    (0.945 exp(-0.02 * 200) = 1.7e-2 > 1e-4, the exact bound of absorber_transmittance) cannot get an MCML
    transmission table: refused in one line before the G-buffer renders and before MCML runs (it used to run
    every grid thickness, then fail after the frame's G-buffer and its pass)."""
    import ssskit.pipeline.frame as frame
    import ssskit.profiles.montecarlo.transmission as tr

    def must_not_run(*args, **kwargs):
        raise AssertionError("work ran before the material's domain was checked")

    monkeypatch.setattr(tr, "simulate", must_not_run)
    monkeypatch.setattr(frame, "render_gbuffer", must_not_run)
    # an empty cache: no reflectance profile of clear either (its 10^7-photon MCML is work too)
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
    monkeypatch.chdir(tmp_path)
    (tmp_path / "clear.json").write_text('{"sigma_a": 0.01, "sigma_s": 0.01, "eta": 1.4, "name": "clear"}')
    # unreal's T(t) needs no MCML table; its lateral spread's widths do
    for extra in ([], ["--pass", "burley"], ["--transmission-model", "unreal", "--transmission-spread", "mcml"]):
        err = one_error_line(run, tmp_path, ["render", "--scene", "backlit", "--material", "clear.json",
                                             "--transmission", "on", "--size", SIZE, "--backend", "numpy",
                                             "--out", "o.exr", *extra],
                             "clear's transmission table cannot reach its floor 0.0001")
        assert "sigma_t above about 0.0461 /mm in every channel" in err  # ln(1e4) / 200 mm
    # the engines' transmission fields need the table: refused before the reflectance profile's MCML (its
    # progress lines on an empty cache would break the one line)
    for fmt, out in (("unreal", "u.json"), ("unity", "u.asset")):
        one_error_line(run, tmp_path, ["export", "--material", "clear.json", "--format", fmt, "--out", out],
                       "clear's transmission table cannot reach its floor 0.0001")


@pytest.mark.parametrize("model", ["mcml", "unreal"])
def test_burley_parameters_without_a_material_have_no_transmission_table(run, tmp_path, monkeypatch, model):
    """--albedo/--dmfp give the Burley pass its parameters and no material: the mcml (and unreal) transmission
    took the default material's table (Skin1's) without a word; now one line before any work, naming the ways
    out. jimenez2010 (no material) still runs."""
    monkeypatch.chdir(tmp_path)
    one_error_line(run, tmp_path, ["render", "--scene", "ear", "--pass", "burley", "--albedo", "0.8,0.5,0.3", "--dmfp",
                                   "8,4,2", "--transmission", "on", "--transmission-model", model, "--size", SIZE,
                                   "--backend", "numpy", "--out", "o.exr"],
                   f"the {model} transmission model reads a material's MCML slab table")


def test_the_docs_table_lists_every_transmission_model():
    """docs/transmission.md's "What is built" row of the render options names every --transmission-model choice
    (it listed mcml|jimenez2010 without unreal)."""
    from pathlib import Path

    from ssskit.cli import cli

    choices = next(p.type.choices for p in cli.commands["render"].params if p.name == "transmission_model")
    doc = (Path(__file__).resolve().parents[2] / "docs" / "transmission.md").read_text()
    row = next(line for line in doc.splitlines() if line.startswith("| `ssskit render --transmission auto"))
    listed = "\\|".join(choices)  # a table cell escapes its pipes
    assert f"--transmission-model {listed}`" in row, row
