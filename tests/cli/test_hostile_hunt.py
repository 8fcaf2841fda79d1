"""Issue 34's hunt (benchmarks/hostile_inputs.py, its last section): inputs that ended in a traceback, a
recursion, a render started or a mesh cached before the refusal. Each, run in-process in a folder holding the
catalogue's files, is one line ``ssskit: error: ...`` naming its rule, exit status 2, nothing written (the mesh
cache included)."""

import importlib.util
from pathlib import Path

import pytest

_PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "hostile_inputs.py"
_spec = importlib.util.spec_from_file_location("hostile_inputs", _PATH)
hostile = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(hostile)

#: each case of the hunt (its catalogue name) and a fragment of the one line it must give
HUNT = {
    # the engine name checked once, case-insensitively (a RecursionError of ~3,000 lines)
    "export --material e_Unreal.json": "lacks the unreal parameters",
    "profile --material e_UNITY.json": "lacks the unity parameters",
    "export --material e_materialx.json": "the engine of an export must be one of unreal, unity, blender, got 'materialx'",
    "kernel --material e_materialx.json": "must be one of unreal, unity, blender, got 'materialx'",
    "render --material e_materialx.json": "must be one of unreal, unity, blender, got 'materialx'",
    # one (A, d) per channel (an IndexError)
    "export --material e_sd_empty.json": "Burley's d must be a real array of shape (3,), got shape (0,)",
    "profile --material e_sd_empty.json": "Burley's d must be a real array of shape (3,), got shape (0,)",
    # a scene's mesh file and primitives, each field by its quantity (TypeErrors, Mitsuba's tracebacks, renders)
    "render --scene file5.toml": "shape 'ball': file must be str, got int",
    "render --scene filelist.toml": "shape 'ball': file must be str, got list",
    "render --scene center5.toml": "shape 's': center must be a real array of shape (3,), got shape ()",
    "render --scene center2.toml": "shape 's': center must be a real array of shape (3,), got shape (2,)",
    "render --scene radiusstr.toml": "shape 's': radius must be a number, got 'big'",
    "render --scene radiusnan.toml": "shape 's': radius must lie in (0, inf) mm, got nan",
    "render --scene radiusneg.toml": "shape 's': radius must lie in (0, inf) mm, got -10",
    "render --scene scalestr.toml": "shape 'c': scale must be a real array of shape (3,)",
    "render --scene scalezero.toml": "shape 'c': scale must lie in (0, inf) mm, got 0 in 3 of 3 values",
    # the camera's rule for an explicit camera, before the mesh is cached
    "render --scene camsame.toml": "[camera]: up (0.0, 1.0, 0.0) and view direction (target - origin) (0.0, 0.0, "
                                   "0.0) must be non-zero and not parallel",
    "render --scene camupview.toml": "[camera]: up (0.0, 0.0, 1.0) and view direction (target - origin) (0.0, 0.0, "
                                     "-100.0) must be non-zero and not parallel",
    # the materials, before the mesh is cached
    "render --scene matunknown.toml": "unknown material 'unobtainium'",
    "render --scene matnum.toml": "shape 'ball': material must be str, got int",
    # glTF's arrays of objects (an AttributeError)
    "render --scene meshesdict.gltf": "meshes must be list, got dict",
    # a G-buffer's JSON header attributes (TypeErrors from json.loads)
    "render --scene cam_int.exr": "header 'ssskit_camera' must be str or bytes, got int",
    "render --scene mats_float.exr": "header 'ssskit_materials' must be str or bytes, got float",
    "render --scene meta_v3f.exr": "header 'ssskit_meta' must be str or bytes, got ndarray",
    "render --scene light_int.exr": "header 'ssskit_light' must be str or bytes, got int",
}
ARGS = dict(hostile.CASES)


def test_every_case_of_the_hunt_is_in_the_catalogue():
    assert set(HUNT) <= set(ARGS)


@pytest.mark.parametrize("name", HUNT)
def test_a_hunted_input_is_one_line_before_any_work(run, tmp_path, monkeypatch, name):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    hostile.setup(tmp_path)
    before = sorted(tmp_path.rglob("*"))
    code, out, err = run(*ARGS[name])
    assert code == 2 and out == "", err
    assert err.count("\n") == 1 and err.startswith("ssskit: error: ") and HUNT[name] in err, err
    assert sorted(tmp_path.rglob("*")) == before  # nothing written: no output, no mesh cache
