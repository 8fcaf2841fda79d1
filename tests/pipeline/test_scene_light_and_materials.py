"""A new user's trial of the built-in scenes: a scene lit only from behind (backlit, leaf) runs the transmittance
pass under ``transmission = "auto"``, its black comparisons say "no light" instead of NaN or a perfect match, the
demo's reflectance tables leave it out; a scene that names its own material (leaf: Apple) is labelled with it and
refuses a ``--material`` that would apply to no object."""

import math
import warnings

import numpy as np
import pytest

from ssskit.errors import SettingsError
from ssskit.metrics import no_light, psnr_text, region_metrics
from ssskit.pipeline import RenderSettings, plan, render
from ssskit.pipeline.settings import BurleyPass
from ssskit.pipeline.frame import metric_lines
from ssskit.pipeline.regions import format_regions
from ssskit.scenes import SCENES, front_lit_scenes, resolve_scene
from ssskit.scenes.scenefile import BUILTIN_DIR

QUICK = dict(width=16, height=12, spp=1, backend="numpy", perceptual=False)


def _behind(name: str) -> bool:
    """Every light of the scene on the far side of its target from the camera (the geometry, not the flag)."""
    spec = SCENES.get(name)
    target = np.array(spec.target, float)
    view = np.array(spec.origin, float) - target
    centres = [light.get("position", light.get("center")) for light in spec.lights().values()]
    return all(float(np.dot(np.asarray(c, float) - target, view)) < 0 for c in centres)


def test_the_flag_says_which_scenes_are_lit_only_from_behind():
    """The scene files' ``lit_from_behind`` matches their lights' geometry, and the demo's reflectance tables
    take the others."""
    flagged = {n for n in SCENES.names() if SCENES.get(n).lit_from_behind}
    assert flagged == {n for n in SCENES.names() if _behind(n)} == {"backlit", "leaf"}
    assert front_lit_scenes() == [n for n in SCENES.names() if n not in flagged]


def test_auto_runs_the_transmittance_pass_on_a_scene_lit_from_behind():
    for scene, runs in (("backlit", True), ("leaf", True), ("slab", False), ("ear", False)):
        assert plan(scene, RenderSettings(**QUICK)).transmission is runs, scene
        assert plan(scene, RenderSettings(**QUICK, transmission="off")).transmission is False
    assert plan("backlit", RenderSettings(**QUICK, pass_=BurleyPass())).transmission is True


def test_a_black_reference_gives_no_relative_error_and_says_no_light():
    mask = np.zeros((6, 8), bool)
    mask[1:5, 2:6] = True
    black = np.zeros((6, 8, 3))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the relative RMSE divided 0 by 0 with a RuntimeWarning
        m = region_metrics(black, black, mask, perceptual=False)
    assert m["rmse"] == 0.0 and math.isnan(m["relative_rmse"]) and math.isnan(m["psnr"]) and no_light(m)
    assert psnr_text(m["psnr"]) == "no light"  # not "exact"
    lit = region_metrics(black + 1.0, black + 0.5, mask, perceptual=False)
    assert lit["relative_rmse"] == pytest.approx(0.5) and not no_light(lit)


def test_a_back_lit_scene_without_transmission_says_no_light():
    """The trial's ``--scene backlit`` with the pass off: a black frame against a black exact frame read
    "relative_rmse nan psnr inf" and an empty "# regions" heading."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        res = render("backlit", RenderSettings(**QUICK, transmission="off"))
    assert not res.transmission.ran and not np.any(res.image)
    lines = metric_lines(res.metrics)
    assert len(lines) == 1 and "no light" in lines[0] and "nan" not in lines[0] and "inf" not in lines[0], lines
    assert res.metrics["exact_2d"]["no_light"] is True
    assert format_regions(res.metrics["regions"]) == [
        "# regions: none (they are cut from the front light E/pi's lit level, its 98th percentile inside the SSS "
        "mask, which is 0: the frame is lit from behind)"]


def test_the_transmitted_light_alone_is_no_match_either():
    """With the pass on, the frame and its exact limit get the same transmitted light and no reflected light:
    equal, but measuring nothing, so no PSNR of infinity."""
    res = render("backlit", RenderSettings(**QUICK))
    assert res.transmission.ran and np.any(res.image)
    m = res.metrics["exact_2d"]
    assert no_light(m) and math.isnan(m["psnr"]) and "inf" not in metric_lines(res.metrics)[0]


def test_the_leaf_is_labelled_and_rendered_with_its_own_material():
    from ssskit.materials import get_material
    from ssskit.profiles import profile_for_material

    res = render("leaf", RenderSettings(**QUICK, exact=False, photons=1_000_000))
    assert res.material.name == "Apple" and res.to_dict()["material"] == "Apple"
    assert res.lines()[0].startswith("# leaf: Apple ")
    apple = profile_for_material(get_material("apple"), "montecarlo", photons=1_000_000)
    np.testing.assert_array_equal(res.profile.total_rd(), apple.total_rd())
    assert plan("leaf", RenderSettings(**QUICK, material="apple")).material.name == "Apple"  # the same: accepted


def test_a_material_the_leaf_would_ignore_is_refused():
    with pytest.raises(SettingsError, match=r"--material marble applies to no object of the scene 'leaf': each "
                                            r"names its own material \(leaf = Apple\)"):
        plan("leaf", RenderSettings(**QUICK, material="marble"))
    with pytest.raises(SettingsError, match="--material-map NAME=MATERIAL"):  # the scene's file: the same rule
        plan(resolve_scene(BUILTIN_DIR / "leaf.toml"), RenderSettings(**QUICK, material="marble"))


def test_the_material_map_reaches_a_primitive_or_generated_shape():
    """The leaf's file with ``--material-map leaf=marble`` (the refusal's advice) gives the plate Marble: a
    one-object shape's id was listed as an object but the map never reached it."""
    spec = resolve_scene(BUILTIN_DIR / "leaf.toml", material_map="leaf=marble").spec
    assert spec.sss_materials == ("marble",)
    slab = resolve_scene(BUILTIN_DIR / "backlit.toml", material_map="slab=marble").spec
    assert slab.sss_materials == ("marble",)


def test_the_demo_tables_take_the_front_lit_scenes(monkeypatch, tmp_path):
    """The screen-space and Burley tables of the demo run over :func:`front_lit_scenes` (their rows read
    "exact / 0.000" and "inf" on the back-lit scenes, black without the transmittance pass)."""
    import ssskit.figures.burley as burley
    import ssskit.figures.screenspace as screenspace
    import ssskit.pipeline
    import ssskit.scenes

    class Stop(Exception):
        pass

    seen: list = []

    def cached(name, key, make):
        seen.append(key["scenes"])
        raise Stop

    monkeypatch.setattr(screenspace, "_cached", cached)
    with pytest.raises(Stop):
        screenspace.screen_space_comparison(tmp_path)
    assert seen == [front_lit_scenes()]

    def record(scene, *args, **kwargs):
        seen.append(scene)
        raise Stop

    monkeypatch.setattr(ssskit.scenes, "front_lit_scenes", lambda: ["front-lit"])
    monkeypatch.setattr(ssskit.pipeline, "render", record)
    with pytest.raises(Stop):
        burley.burley_comparison(tmp_path)
    assert seen[-1] == "front-lit"
