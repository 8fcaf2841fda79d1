"""Meshes through the CLI: every bad mesh input is one line ``ssskit: error: ...`` and exit status 2 before
any work, from every command that takes a mesh scene."""

import numpy as np
import pytest

from ssskit.scenes.generated import icosphere
from ssskit.scenes.meshes import Mesh, write_mesh

#: the commands that take --scene with a mesh (their other arguments)
COMMANDS = [["render", "--size", "32x24"], ["figures", "xie-fig1", "--out", "figs"], ["demo", "--out", "demo"]]


@pytest.fixture
def meshes(tmp_path, monkeypatch):
    """A folder with good and bad meshes; the cache lies outside it (nothing may be written into it)."""
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    ball = icosphere(2, 30.0, name="ball")
    write_mesh(work / "ball.ply", ball)
    write_mesh(work / "two.glb", [Mesh("skinA", ball.vertices, ball.faces, ball.normals),
                                  Mesh("skinB", ball.vertices + np.float32([70, 0, 0]), ball.faces, ball.normals)])
    v = ball.vertices.copy()
    v[3, 0] = np.nan
    write_mesh(work / "nan.obj", Mesh("ball", v, ball.faces, ball.normals))
    write_mesh(work / "nan.glb", Mesh("ball", v, ball.faces, ball.normals))
    (work / "degen.obj").write_text("v 0 0 0\nv 10 0 0\nv 20 0 0\nf 1 2 3\n")  # one face of zero area
    (work / "empty.obj").write_bytes(b"")
    (work / "dust.obj").write_text("v 0 0 0\nv 2e-5 0 0\nv 0 1e-5 0\nf 1 2 3\n")  # 20 nm: lit too dark (0.41)
    (work / "huge.obj").write_text("v 0 0 0\nv 1e30 0 0\nv 0 1e30 0\nf 1 2 3\n")  # the trial's: Mitsuba's lights overflow
    (work / "model.stl").write_bytes(b"solid x\n")
    (work / "huge.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\n"
                                    b"property float x\nproperty float y\nproperty float z\nelement face 2000000000\n"
                                    b"property list uchar uint vertex_indices\nend_header\n")
    return work


BAD = [
    (["--scene", "nope.obj"], "mesh 'nope.obj' does not exist"),
    (["--scene", "empty.obj"], "mesh 'empty.obj' is empty (0 bytes)"),
    (["--scene", "dust.obj"], "dust.obj: the model's bounding-sphere diameter (units mm) must lie in [0.0002, 1e+09] mm"),
    (["--scene", "huge.obj"], "huge.obj: the model's bounding-sphere diameter (units mm) must lie in [0.0002, 1e+09] mm, "
                              "got 1.41421e+30"),
    (["--scene", "model.stl"], "its format must be one of .obj, .ply, .glb, .gltf, .toml, .exr, got '.stl'"),
    (["--scene", "nan.obj"], "vertex positions must be finite, got NaN or inf"),
    (["--scene", "nan.glb"], "vertex positions must be finite, got NaN or inf in 3 of 486 coordinates"),
    (["--scene", "degen.obj"], "mesh 'degen.obj' is degenerate: its 1 face has zero area"),
    (["--scene", "two.glb", "--material-map", "skinC=skin1"], "material map names 'skinC', which 'two.glb' does not "
                                                              "have (its objects: skinA, skinB)"),
    (["--scene", "two.glb", "--material-map", "skinA=unobtainium"], "unobtainium"),
    (["--scene", "two.glb", "--material-map", "skinA"], "material map entry 'skinA' is not NAME=MATERIAL"),
    (["--scene", "huge.ply"], "2,000,000,000 faces: rendering it at "),
    (["--scene", "ball.ply", "--units", "mm", "--units", "m"], "--units mm and --units m disagree; give the units once"),
    (["--scene", "ball.ply", "--units", "inch"], "'inch' is not one of 'mm', 'cm', 'm'"),
]


@pytest.mark.parametrize("command", COMMANDS, ids=[c[0] for c in COMMANDS])
@pytest.mark.parametrize("args, fragment", BAD, ids=[f"{a[1]}{' ' + a[3] if len(a) > 3 else ''}" for a, _ in BAD])
def test_bad_mesh_input(run, meshes, command, args, fragment):
    before = sorted(p.name for p in meshes.rglob("*"))
    code, out, err = run(*command, *args)
    assert code == 2, err
    assert out == ""
    assert err.count("\n") == 1 and err.startswith("ssskit: error: "), err
    assert fragment in err, err
    assert sorted(p.name for p in meshes.rglob("*")) == before  # nothing written


def test_figures_scene_options_need_a_figure_that_renders_a_scene(run, meshes):
    code, _, err = run("figures", "fig7", "--scene", "ball.ply", "--out", "figs")
    assert code == 2 and "applies to figure xie-fig1, not figure fig7" in err


def test_demo_needs_scene_for_units(run, meshes):
    code, _, err = run("demo", "--units", "mm", "--out", "demo")
    assert code == 2 and "--units applies to a demo with --scene, not a demo without one" in err


def test_demo_section_of_your_model(tmp_path, monkeypatch):
    """build_report(scene=...) appends the "Your model" section (the other sections left out here)."""
    import ssskit.figures.views as views
    import ssskit.report as report

    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(report, "SECTIONS", [])
    monkeypatch.setattr(views, "DEMO_SIZE", (32, 24))
    monkeypatch.setattr(views, "DEMO_FRAMES", 2)
    monkeypatch.setattr(views, "DEMO_REFERENCE_SPP", 16)
    index = report.build_report(tmp_path / "demo", scene={"scene": "icosphere"})
    text = index.read_text()
    assert "<h2" in text and "Your model: icosphere" in text and "golubev-64" in text
    assert (tmp_path / "demo" / "figures" / "your_model.png").is_file()


RENDER = ["render", "--size", "40x30", "--spp", "2", "--no-exact", "--no-perceptual", "--backend", "numpy"]


def _saved(run, *args):
    from ssskit.screenspace import load_gbuffer

    code, out, err = run(*RENDER, *args)
    assert code == 0, err
    return load_gbuffer(args[args.index("--save-gbuffer") + 1]), err


def test_render_formats_and_units_give_the_same_gbuffer(run, meshes):
    """ssskit render --save-gbuffer: the mesh as OBJ (mm), glTF text (mm) and PLY in metres with --units m
    give the same G-buffer within float32; without --units the command says what it assumed."""
    ball = icosphere(2, 30.0, name="ball")
    write_mesh(meshes / "ball.obj", ball)
    write_mesh(meshes / "ball.gltf", ball)
    write_mesh(meshes / "ball_m.ply", Mesh("ball", ball.vertices / np.float32(1000), ball.faces, ball.normals))
    ref, err = _saved(run, "--scene", "ball.ply", "--save-gbuffer", "ply.exr")
    assert "ssskit: ball.ply: assumed units mm (no --units given); the model is 60 mm across" in err
    for args in (["--scene", "ball.obj", "--units", "mm"], ["--scene", "ball.gltf", "--units", "mm"],
                 ["--scene", "ball_m.ply", "--units", "m"]):
        gb, err = _saved(run, *args, "--save-gbuffer", f"{args[1]}.exr")
        assert "assumed" not in err
        np.testing.assert_array_equal(gb.profile_id, ref.profile_id)
        m = ref.mask
        np.testing.assert_allclose(gb.depth[m], ref.depth[m], rtol=1e-5)
        np.testing.assert_allclose(gb.diffuse, ref.diffuse, rtol=1e-4, atol=1e-5)


def test_render_two_materials_and_reference_checks(run, meshes):
    gb, _ = _saved(run, "--scene", "two.glb", "--units", "mm", "--material-map", "skinA=skin1,skinB=marble",
                   "--save-gbuffer", "two.exr")
    assert gb.materials == ("Skin1", "Marble") and set(np.unique(gb.profile_id)) == {0, 1, 2}
    code, out, err = run(*RENDER, "--scene", "two.glb", "--units", "mm", "--material-map", "skinB=marble",
                         "--pass", "burley", "--json")
    assert code == 0, err
    import json

    data = json.loads(out)
    assert set(data["burley_params"]) == {"1", "2"}
    # skinA takes the default material: the summary names each id's material, not the settings' alone
    assert data["material"] == "Skin1 (id 1), Marble (id 2)" and data["materials"] == {"1": "Skin1", "2": "Marble"}
    code, out, err = run(*RENDER, "--scene", "two.glb", "--units", "mm", "--material-map", "skinB=marble")
    assert code == 0, err
    assert "# two: Skin1 (id 1), Marble (id 2); montecarlo profiles, preintegrated" in out
    assert "profile: montecarlo of Skin1 (id 1), Marble (id 2) (" in err
    code, out, err = run(*RENDER, "--scene", "two.glb", "--units", "mm", "--material-map", "skinA=marble,skinB=marble")
    assert code == 0, err
    assert "# two: Marble (montecarlo), preintegrated" in out and "profile: montecarlo of Marble (" in err
    s = icosphere(2, 30.0, name="cup")
    write_mesh(meshes / "cup.ply", Mesh("cup", s.vertices, s.faces[8:], s.normals))
    code, out, err = run(*RENDER, "--scene", "cup.ply", "--reference")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "mesh 'cup.ply' is open" in err and "path-traced reference needs a closed surface" in err
    code, _, err = run(*RENDER, "--scene", "slab", "--view", "front")
    assert code == 2 and "--view applies to --scene a generated mesh or " in err and "not --scene 'slab' (a built-in scene" in err


def test_mitsuba_log_goes_to_stderr_and_json_stays_parseable(meshes, capfd, monkeypatch):
    """Mitsuba's log (its default appender writes C++'s stdout: a trial's --json began with "WARN [Mesh] ...
    invalid vertices") goes to stderr, from any thread: a mesh with an extra zero-area face (whose read warned)
    renders with a warning logged from another thread during each of Mitsuba's renders; stdout is one JSON
    object, the warnings are on stderr (file descriptor level)."""
    import json
    import threading

    import ssskit.scenes.scenes as scenes_module
    from ssskit.cli import main
    from ssskit.scenes.mitsuba_variant import mitsuba

    ball = icosphere(2, 30.0, name="ball")
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in ball.vertices]
    lines += ["v 100 0 0", "v 110 0 0", "v 120 0 0"]  # three collinear vertices: a face of zero area
    n = len(ball.vertices)
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in ball.faces] + [f"f {n + 1} {n + 2} {n + 3}"]
    (meshes / "ball_degen.obj").write_text("\n".join(lines) + "\n")
    render = scenes_module.interruptible_render

    def warn_meanwhile(scene, **kwargs):
        mi = mitsuba()
        t = threading.Thread(target=mi.Log, args=(mi.LogLevel.Warn, "a warning from another thread"))
        t.start()
        t.join()
        return render(scene, **kwargs)

    monkeypatch.setattr(scenes_module, "interruptible_render", warn_meanwhile)
    capfd.readouterr()
    code = main([*RENDER, "--scene", "ball_degen.obj", "--units", "mm", "--json"])
    out, err = capfd.readouterr()
    assert code == 0, err
    assert "a warning from another thread" in err  # the warning reached the user, on stderr
    assert json.loads(out)["scene"] == "ball_degen"


def test_model_size_does_not_change_the_framing(run, meshes):
    """The camera frames any model the same way (docs/meshes.md "Camera and lights"): a sphere of radius 20 m
    (seen from 112 m, beyond Mitsuba's default far clip plane of 10 m: it rendered black) and one of radius
    0.2 micrometres (seen from 1.1 micrometres, all of it nearer than the default near plane of 10
    micrometres) give the same SSS pixel mask as the sphere of radius 20 mm."""
    ball = icosphere(2, 20.0, name="ball")
    write_mesh(meshes / "ball20.obj", ball)
    write_mesh(meshes / "speck.obj", Mesh("ball", ball.vertices * np.float32(1e-5), ball.faces, ball.normals))
    ref, _ = _saved(run, "--scene", "ball20.obj", "--units", "mm", "--save-gbuffer", "mm.exr")
    assert ref.mask.sum() > 0.3 * ref.mask.size
    for args in (["--scene", "ball20.obj", "--units", "m"], ["--scene", "speck.obj", "--units", "mm"]):
        gb, _ = _saved(run, *args, "--save-gbuffer", "big.exr")
        np.testing.assert_array_equal(gb.mask, ref.mask)


@pytest.mark.parametrize("scene, what", [("slab", "built-in scene 'slab'"), ("bust", "generated scene 'bust'"),
                                         ("ball.ply", "mesh 'ball.ply' has 320 faces")])
def test_every_scene_kind_is_refused_when_its_render_needs_more_memory_than_available(run, meshes, monkeypatch,
                                                                                       scene, what):
    """The memory estimate (512 B per pixel + 400 B per face) is checked for built-in and generated scenes as for a
    mesh file, before any work: 2048x2048 needs 2.0 GiB for its pixels (the bust's faces add 0.1), more than 1 GiB
    made the available memory here."""
    import ssskit.scenes.meshes as meshes_module

    monkeypatch.setattr(meshes_module, "available_memory", lambda: 1 << 30)
    before = sorted(p.name for p in meshes.rglob("*"))
    code, out, err = run("render", "--scene", scene, "--size", "2048x2048", "--out", "x.png", "--save-gbuffer", "g.exr")
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith(f"ssskit: error: {what}: rendering it at 2048x2048 needs about "
                                                   "2."), err
    assert "more than the 1.0 GiB of memory available" in err
    assert sorted(p.name for p in meshes.rglob("*")) == before


def test_a_render_whose_gbuffer_has_no_sss_pixel_is_refused(run, meshes):
    """A plane seen edge-on (the default front view looks along it) has no SSS pixel: one line naming why, exit 2,
    nothing written (it rendered with exit 0, no metrics and no message), as for a G-buffer file without one."""
    (meshes / "flat.obj").write_text("v -10 0 -10\nv 10 0 -10\nv 10 0 10\nv -10 0 10\nf 1 2 3\nf 1 3 4\n")
    before = sorted(p.name for p in meshes.rglob("*"))
    code, out, err = run(*RENDER, "--scene", "flat.obj", "--units", "mm", "--out", "flat.png", "--json")
    assert code == 2 and out == ""
    assert err.count("ssskit: error: ") == 1 and err.rstrip().split("\n")[-1].startswith(
        "ssskit: error: the flat G-buffer (40x30) has no SSS pixel: the camera sees no surface of an SSS object "
        "(a flat model seen edge-on, or one outside the frame)"), err
    assert sorted(p.name for p in meshes.rglob("*")) == before


def test_an_unknown_scene_lists_every_scene_name_and_the_files_taken(run, meshes):
    """--scene nosuch listed only the built-in scene files' names; now every name (the generated meshes too) and
    every kind of file --scene takes, from the CLI and from the library (resolve_scene)."""
    from ssskit.errors import SceneError
    from ssskit.scenes import GENERATED_SCENES, SCENES, resolve_scene

    code, out, err = run("render", "--scene", "nosuch")
    assert code == 2 and out == "" and err.count("\n") == 1
    with pytest.raises(SceneError) as raised:
        resolve_scene("nosuch")
    for text in (err, str(raised.value)):
        assert "unknown scene 'nosuch'" in text
        for name in [*SCENES.names(), *GENERATED_SCENES]:
            assert name in text, text
        for kind in (".obj", ".ply", ".glb", ".gltf", "scene .toml", "G-buffer .exr"):
            assert kind in text, text


@pytest.mark.parametrize("option", [["--limit-spp", "64"], ["--disocclusion-spp", "8"]])
def test_adaptive_options_of_a_moving_camera_say_a_mesh_scene_is_static(run, meshes, option):
    """A mesh scene is always static under --pass burley-adaptive: the refusal of a moving camera's option says
    so (the user never passed --static)."""
    code, out, err = run("render", "--scene", "ball.ply", "--pass", "burley-adaptive", *option)
    assert code == 2 and out == "" and err.count("\n") == 1
    assert f"{option[0]} applies to a moving camera; this run is static (a mesh, scene file or generated mesh is " \
           "always static under --pass burley-adaptive" in err, err
