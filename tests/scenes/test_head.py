"""The built-in head (ssskit.scenes.head, builtin/head.toml): the shipped scan is the PLY's arrays unchanged,
its scale puts the head's breadth and length among adult men's, its views and the credit its licence asks for."""

import json
import tomllib
from fnmatch import fnmatch
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from ssskit.errors import SceneError
from ssskit.scenes import SCENES, resolve_scene
from ssskit.scenes.head import (ATTRIBUTION, DATA_PATH, FACES, MM_PER_UNIT, VERTICES, head_arrays, head_measures,
                                head_mesh, write_head_data)
from ssskit.scenes.meshes import topology

ROOT = Path(__file__).resolve().parents[2]
#: the source scan: shared/ beside the checkout (as on the developers' machines and in CI)
PLY = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "head" / "head.ply"
needs_ply = pytest.mark.skipif(not PLY.is_file(), reason=f"the source PLY {PLY} is not on this machine")


@needs_ply
def test_shipped_arrays_equal_the_ply_read_by_trimesh():
    trimesh = pytest.importorskip("trimesh")
    raw = trimesh.load(str(PLY), process=False).metadata["_ply_raw"]
    v = raw["vertex"]["data"]
    f = raw["face"]["data"]["vertex_indices"]
    faces = np.stack([np.asarray(x, dtype=np.int64) for x in (f["f1"] if f.dtype.names else f)])
    a = head_arrays()
    np.testing.assert_array_equal(a["vertices"], np.stack([v["x"], v["y"], v["z"]], 1))
    np.testing.assert_array_equal(a["normals"], np.stack([v["nx"], v["ny"], v["nz"]], 1))
    np.testing.assert_array_equal(a["uvs"], np.stack([v["s"], v["t"]], 1))
    np.testing.assert_array_equal(a["faces"], faces)


@needs_ply
def test_regenerated_file_is_the_shipped_file(tmp_path):
    out = write_head_data(PLY, tmp_path / "head.npz")
    assert out.read_bytes() == DATA_PATH.read_bytes()


def test_shipped_scan_is_a_closed_manifold_with_unit_normals():
    a = head_arrays()
    assert a["vertices"].shape == (VERTICES, 3) and a["faces"].shape == (FACES, 3)
    assert a["vertices"].dtype == np.float32 and a["faces"].dtype == np.int32
    np.testing.assert_allclose(np.linalg.norm(a["normals"], axis=1), 1.0, atol=1e-3)
    t = topology(head_mesh())
    assert t.closed and t.misoriented_edges == 0 and t.volume > 0  # the reference can path-trace it
    assert t.reference_problem("head") is None


def test_scale_puts_breadth_and_length_within_one_sd_of_adult_male_means():
    """[PH06] (British men 19-65): head breadth 155 mm (SD 6), head length 195 mm (SD 8)."""
    mm = {k: v * MM_PER_UNIT for k, v in head_measures().items()}
    assert abs(mm["breadth"] - 155.0) <= 6.0
    assert abs(mm["length"] - 195.0) <= 8.0
    assert head_measures(head_mesh(MM_PER_UNIT))["breadth"] == pytest.approx(mm["breadth"], rel=1e-5)


def test_package_data_patterns_ship_the_scan_and_its_licence():
    patterns = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["ssskit"]
    for name in ("scenes/data/head.npz", "scenes/data/HEAD-LICENSE.md", "scenes/builtin/head.toml"):
        assert any(fnmatch(name, p) for p in patterns), name
    assert ATTRIBUTION in (DATA_PATH.parent / "HEAD-LICENSE.md").read_text()


def test_head_scene_views_and_about():
    spec = SCENES.get("head")
    about = dict(spec.about)
    assert about["attribution"] == ATTRIBUTION and about["mm_per_unit"] == MM_PER_UNIT
    views = dict(spec.views)
    assert set(views) == {"front", "ear", "close"}
    assert (spec.origin, spec.target) == views["front"][:2]
    ear = resolve_scene("head", view="ear").spec
    assert ear.origin == views["ear"][0] and dict(ear.about) == about
    assert resolve_scene("head", view="profile").spec.origin == ear.origin  # the alias of ear
    with pytest.raises(SceneError, match="--view of the built-in scene 'head' must be one of front, ear, close, got 'top'"):
        resolve_scene("head", view="top")
    with pytest.raises(SceneError, match="--units"):
        resolve_scene("head", units="m", view="ear")
    with pytest.raises(SceneError, match="fixed camera"):
        resolve_scene("sphere", view="ear")


def test_head_scale_out_of_its_domain_is_refused():
    from ssskit.scenes.scenefile import scene_from_document

    doc = {"shapes": {"h": {"type": "generated", "generator": "head", "params": {"mm_per_unit": 5.0}}},
           "camera": {"origin": [0, 0, -700], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 30},
           "lights": {"k": {"type": "point", "position": [0, 0, -700], "intensity": 1.0}}}
    with pytest.raises(SceneError, match=r"mm_per_unit must (lie in \[100, 1000\]|be a number), got"):
        scene_from_document(doc)


def test_render_json_reports_scale_and_attribution(tmp_path):
    from ssskit.cli import cli as main

    r = CliRunner().invoke(main, ["render", "--scene", "head", "--material", "skin1", "--size", "64x48", "--json",
                                  "--no-perceptual"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["scene"] == "head" and out["material"] == "Skin1"
    assert out["scene_about"]["mm_per_unit"] == MM_PER_UNIT
    assert out["scene_about"]["attribution"] == ATTRIBUTION
    helptext = CliRunner().invoke(main, ["render", "--help"]).output
    assert "Lee Perry-Smith, Infinite-Realities (CC BY 3.0)" in " ".join(helptext.split())
