"""Meshes as scenes: every format reads back the mesh written, renders the same G-buffer, units scale,
two glTF materials are two profile ids, topology checks, and each bad input is refused before any
render (small meshes, tiny images)."""

from __future__ import annotations

import os
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from ssskit.errors import SceneError
from ssskit.scenes import SCENES, render_gbuffer, render_reference, resolve_scene
from ssskit.scenes.generated import bust, bust_path, bust_sdf, icosphere, torus
from ssskit.scenes.meshes import (BYTES_PER_FACE, FORMATS, Mesh, MeshCounts, check_render_memory, mesh_counts, read_mesh,
                                  topology, write_mesh)
from ssskit.scenes.scenefile import builtin_scene_files, load_scene_file, parse_view, scene_from_document

W, H = 40, 30
ALBEDO = (0.7, 0.5, 0.4)
SUFFIXES = sorted(FORMATS)  # .glb .gltf .obj .ply


def _sphere(radius: float = 30.0) -> Mesh:
    return icosphere(3, radius, name="ball")


def _rows(a: np.ndarray) -> np.ndarray:
    return a[np.lexsort(a.T[::-1])]


@pytest.mark.parametrize("suffix", SUFFIXES)
@pytest.mark.parametrize("make", [_sphere, lambda: torus(30.0, 9.0, 32, 16)], ids=["icosphere", "torus"])
def test_each_format_reads_back_the_mesh_written(tmp_path, suffix, make):
    mesh = make()
    path = write_mesh(tmp_path / f"m{suffix}", mesh)
    (back,) = read_mesh(path)
    assert len(back.faces) == len(mesh.faces)
    # readers may split or reorder vertices: compare the sets of (position, normal) rows; positions exact
    # in float32, normals within 2 float32 ulps of 1 (the glTF reader renormalises them)
    want = _rows(np.unique(np.concatenate([mesh.vertices, mesh.normals], 1), axis=0))
    got = _rows(np.unique(np.concatenate([back.vertices, back.normals], 1), axis=0))
    assert got.shape == want.shape
    np.testing.assert_array_equal(got[:, :3], want[:, :3])
    np.testing.assert_allclose(got[:, 3:], want[:, 3:], rtol=0, atol=2 * np.finfo(np.float32).eps)
    t = topology(back)
    assert t.closed and t.misoriented_edges == 0 and t.volume > 0


def test_generated_meshes_are_closed_with_the_analytic_volume():
    """Icosphere -> 4/3 pi r^3 and torus -> 2 pi^2 R r^2 as the tessellation refines (inscribed polyhedra:
    slightly smaller)."""
    s = topology(icosphere(5, 1.0))
    assert s.closed and s.misoriented_edges == 0
    assert s.volume == pytest.approx(4 / 3 * math.pi, rel=2e-3) and s.volume < 4 / 3 * math.pi
    t = topology(torus(1.0, 0.3, 192, 96))
    assert t.closed and t.misoriented_edges == 0
    assert t.volume == pytest.approx(2 * math.pi**2 * 0.09, rel=2e-3)


def test_every_format_renders_the_same_gbuffer(tmp_path):
    mesh = _sphere()
    gbs = {}
    for suffix in SUFFIXES:
        scene = resolve_scene(str(write_mesh(tmp_path / f"ball{suffix}", mesh)), units="mm", width=W, height=H)
        gbs[suffix] = render_gbuffer(scene.spec, ALBEDO, width=W, height=H, spp=2, seed=3)
    ref = gbs[".ply"]
    assert ref.mask.mean() > 0.2
    for suffix, gb in gbs.items():
        np.testing.assert_array_equal(gb.profile_id, ref.profile_id, err_msg=suffix)
        m = ref.mask
        np.testing.assert_allclose(gb.depth[m], ref.depth[m], rtol=4 * np.finfo(np.float32).eps, err_msg=suffix)
        for layer in ("normal", "diffuse", "specular", "albedo"):
            np.testing.assert_allclose(getattr(gb, layer), getattr(ref, layer), rtol=1e-5, atol=1e-6,
                                       err_msg=f"{suffix} {layer}")


def test_units_scale_the_mesh_to_the_same_image(tmp_path):
    mesh = _sphere(30.0)
    in_m = Mesh("ball", mesh.vertices / np.float32(1000), mesh.faces, mesh.normals)
    a = resolve_scene(str(write_mesh(tmp_path / "mm.ply", mesh)), units="mm", width=W, height=H)
    b = resolve_scene(str(write_mesh(tmp_path / "m.ply", in_m)), units="m", width=W, height=H)
    ga = render_gbuffer(a.spec, ALBEDO, width=W, height=H, spp=2)
    gb = render_gbuffer(b.spec, ALBEDO, width=W, height=H, spp=2)
    np.testing.assert_array_equal(ga.profile_id, gb.profile_id)
    m = ga.mask
    np.testing.assert_allclose(gb.depth[m], ga.depth[m], rtol=1e-5)
    np.testing.assert_allclose(gb.diffuse, ga.diffuse, rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(ga.camera.fx, gb.camera.fx)


def test_no_units_says_what_it_assumed_and_the_size(tmp_path):
    tiny = Mesh("ball", _sphere(0.03).vertices, _sphere().faces, _sphere().normals)  # 60 mm in metres
    scene = resolve_scene(str(write_mesh(tmp_path / "ball.obj", tiny)), width=W, height=H)
    (note,) = scene.notes
    assert "assumed units mm" in note and "0.06 mm across" in note and "--units m (60 mm)" in note
    glb = resolve_scene(str(write_mesh(tmp_path / "ball.glb", tiny)), width=W, height=H)
    assert "assumed units m" in glb.notes[0] and "60 mm across" in glb.notes[0]


def _two_material_gltf(tmp_path: Path, suffix: str = ".glb") -> Path:
    a = icosphere(2, 20.0, name="skinA")
    b = Mesh("skinB", icosphere(2, 20.0).vertices + np.float32([45.0, 0, 0]), a.faces, a.normals)
    return write_mesh(tmp_path / f"two{suffix}", [a, b])


def test_two_glTF_materials_are_two_profile_ids_and_nothing_bleeds(tmp_path):
    from ssskit.kernels import build_kernel, default_grid
    from ssskit.profiles import profile_for_material
    from ssskit.sampling.taps import make_taps
    from ssskit.screenspace import separable_sss

    scene = resolve_scene(str(_two_material_gltf(tmp_path)), units="mm", material_map="skinA=skin1,skinB=marble",
                          width=64, height=32)
    assert scene.spec.sss_materials == ("skin1", "marble")
    gb = render_gbuffer(scene.spec, [(0.8, 0.5, 0.4), (0.9, 0.9, 0.85)], width=64, height=32, spp=1,
                        material=scene.spec.sss_materials)
    assert gb.materials == ("skin1", "marble")
    assert set(np.unique(gb.profile_id)) == {0, 1, 2}
    one, two = gb.profile_id == 1, gb.profile_id == 2
    assert one.sum() > 50 and two.sum() > 50
    np.testing.assert_allclose(gb.albedo[two], np.broadcast_to((0.9, 0.9, 0.85), (int(two.sum()), 3)), rtol=1e-6)
    taps = {}
    for pid, mat in ((1, "skin1"), (2, "marble")):
        prof = profile_for_material(mat, "dipole")
        cell, n = default_grid(prof)
        taps[pid] = make_taps(build_kernel("preintegrated", prof, cell, n), 7)
    # change the light on id 2 only: the blurred id-1 pixels stay bit-identical (no bleed between ids)
    base = np.repeat(np.where(gb.mask, 1.0, 0.0)[..., None], 3, axis=2).astype(np.float32)
    other = base.copy()
    other[two] = 7.0
    out_a = separable_sss(gb.with_layers(diffuse=base), taps, backend="numpy")
    out_b = separable_sss(gb.with_layers(diffuse=other), taps, backend="numpy")
    np.testing.assert_array_equal(out_a[one], out_b[one])
    np.testing.assert_allclose(out_a[one], 1.0, rtol=1e-12)  # a constant signal passes unchanged


def test_bust_is_a_closed_head_with_thin_ears_and_a_nose():
    path = bust_path()
    assert path.is_file() and path.suffix == ".ply"
    (m,) = read_mesh(path)
    t = topology(m)
    assert t.closed and t.misoriented_edges == 0 and t.volume > 0
    lo, hi = m.vertices.min(axis=0), m.vertices.max(axis=0)
    assert 250 < hi[0] - lo[0] < 350 and 250 < hi[1] - lo[1] < 350  # mm: a life-size bust
    # the ear is a thin plate off the head: a ray along -x through its free back part crosses 2-5 mm of it,
    # then more than 5 mm of air before the head
    from ssskit.scenes.scenes import mitsuba

    mi = mitsuba()
    scene = mi.load_dict({"type": "scene", "bust": {"type": "ply", "filename": str(path)}})
    hits, o = [], np.array([200.0, 165.0, -20.0])
    for _ in range(3):
        si = scene.ray_intersect(mi.Ray3f(mi.ScalarPoint3f(*o), mi.ScalarVector3f(-1.0, 0.0, 0.0)))
        assert si.is_valid()
        hits.append(float(si.p[0]))
        o = np.array([hits[-1] - 1e-3, 165.0, -20.0])
    assert 2.0 < hits[0] - hits[1] < 5.0 and hits[1] - hits[2] > 5.0
    # the nose stands out of the face: its tip is inside, 26 mm below it the face is more than 20 mm behind
    assert bust_sdf(np.array([[0.0, 146.0, 105.0]]))[0] < 0 < bust_sdf(np.array([[0.0, 120.0, 105.0]]))[0]


@pytest.mark.slow
def test_bust_regenerates_to_the_cached_file():
    (cached,) = read_mesh(bust_path())
    fresh = bust()
    np.testing.assert_array_equal(cached.vertices, fresh.vertices)
    np.testing.assert_array_equal(cached.faces, fresh.faces)


# ---- scene files, views and lights ---------------------------------------------------------------------

def test_builtin_scene_files_load_to_the_builtin_scenes():
    """The four built-in scenes' TOML files give the Mitsuba dicts, camera and paths the Python definitions
    had (tests/scenes/data/builtin_scenes.json: dumped from them at commit 242b729, before the scenes became
    files; the dump's JSON is also the reference cache key's geometry, so cached references stay valid)."""
    snap = json.loads((Path(__file__).parent / "data" / "builtin_scenes.json").read_text())

    def key(spec):
        text = json.dumps([spec.shapes(), spec.lights(), spec.origin, spec.fov_x_deg], default=str)
        return json.loads(text)

    def basenames(obj):
        if isinstance(obj, dict):
            return {k: Path(v).name if k == "filename" else basenames(v) for k, v in obj.items()}
        return [basenames(v) for v in obj] if isinstance(obj, list) else obj

    assert [p.stem for p in builtin_scene_files()] == SCENES.names()
    assert set(snap) <= set(SCENES.names())  # the scenes added since (backlit, leaf) have their own tests
    for path in builtin_scene_files():
        if path.stem not in snap:
            continue
        spec = load_scene_file(path).spec
        want = snap[path.stem]
        assert basenames(key(spec)) == basenames(json.loads(want["key"]))
        assert basenames(key(SCENES.get(path.stem))) == basenames(json.loads(want["key"]))
        assert spec.description == want["description"] and spec.sss_shapes == tuple(want["sss_shapes"])
        assert (spec.origin, spec.target, spec.up) == tuple(tuple(want[k]) for k in ("origin", "target", "up"))
        assert spec.orbit_deg_per_frame == want["orbit_deg_per_frame"]
        assert spec.light_orbit_deg_per_frame == want["light_orbit_deg_per_frame"]


def test_views_frame_the_bounding_sphere(tmp_path):
    path = str(write_mesh(tmp_path / "ball.ply", _sphere(30.0)))
    for view, axis in (("front", 2), ("profile", 0)):
        spec = resolve_scene(path, units="mm", view=view, width=W, height=H).spec
        offset = np.array(spec.origin) - np.array(spec.target)
        assert abs(offset[axis]) == pytest.approx(np.linalg.norm(offset))
    front = np.linalg.norm(np.subtract(resolve_scene(path, units="mm", width=W, height=H).spec.origin, 0))
    close = np.linalg.norm(np.subtract(resolve_scene(path, units="mm", view="close", width=W, height=H).spec.origin, 0))
    assert close == pytest.approx(0.45 * front, rel=1e-6)
    assert parse_view("30,10,2") == (30.0, 10.0, 2.0) and parse_view("ear") == parse_view("profile")
    # fitted with a 10% margin: the sphere's image is 1/1.1 of the frame's height
    gb = render_gbuffer(resolve_scene(path, units="mm", width=80, height=60).spec, ALBEDO, width=80, height=60, spp=1)
    rows = np.flatnonzero(gb.mask.any(axis=1))
    assert (rows[-1] - rows[0] + 1) / 60 == pytest.approx(1 / 1.1, abs=2.5 / 60)


@pytest.mark.parametrize("size", [0.0, 0.5])
def test_light_intensity_is_the_diffuse_radiance_at_the_centre(tmp_path, size):
    """A light at 3 bounding radii, 30 degrees off the view axis, intensity 1 (E = pi at the centre): the
    sphere's point facing it, 2 radii from it, receives E = pi (3/2)^2 from a point light (inverse square),
    and the same from a sphere light of radius a = 0.5 R: pi L (a/2R)^2 with L = (3R/a)^2 (a uniformly
    bright sphere: E = pi L sin^2 alpha, [PJH23] ch. 4)."""
    from ssskit.scenes import scene_camera

    doc = {"shapes": {"ball": {"type": "mesh", "file": str(write_mesh(tmp_path / "ball.ply", _sphere(30.0)))}},
           "lights": {"key": {"azimuth": 30.0, "elevation": 0.0, "distance": 3.0, "size": size, "intensity": 1.0}}}
    spec = scene_from_document(doc, units="mm", width=61, height=45).spec
    gb = render_gbuffer(spec, ALBEDO, width=61, height=45, spp=64)
    facing = np.array([30.0 * math.sin(math.radians(30)), 0.0, 30.0 * math.cos(math.radians(30))])
    (u, v), _ = scene_camera(spec, 61, 45).project(facing)
    x, y = int(u), int(v)
    assert gb.mask[y, x]
    np.testing.assert_allclose(gb.diffuse[y - 1:y + 2, x - 1:x + 2].mean(axis=(0, 1)), 1.5**2, rtol=0.03)


BAD_LIGHTS = [
    ({"type": "point", "position": [0, 400, -600], "intensity": -2.0e5}, r"intensity must lie in \[0, 1e\+30\]"),
    ({"type": "point", "position": [0, 400, -600], "intensity": [1.0, float("nan"), 1.0]}, "intensity must lie in"),
    ({"type": "point", "position": [0, float("inf"), -600], "intensity": 1.0}, "position must be finite"),
    ({"type": "sphere", "center": [0, 0, 100], "radius": 5, "radiance": float("inf")}, "radiance must lie in"),
    ({"type": "sphere", "center": [0, 0, 100], "radius": 5, "radiance": [1.0, -1.0, 1.0]}, "radiance must lie in"),
    ({"type": "sphere", "center": [0, 0, 100], "radius": -5, "radiance": 1.0},
     r"radius must lie in \(0, inf\), got -5"),
    ({"intensity": float("inf")}, r"intensity must lie in \[0, inf\), got inf"),
    ({"azimuth": float("nan")}, r"azimuth must lie in \(-inf, inf\) degrees, got nan"),
    ({"size": "big"}, "size must be a number, got 'big'"),
    # finite but beyond the renderer's float32 (the verifier's 1e36 key light: 64,000 warnings, then a NaN layer);
    # OTHER_LIGHT: distance 4, size 0.15, so radiance = 1e36 (4 / 0.15)^2 = 7.11e38
    ({"intensity": 1e36}, r"its radiance \(intensity x \(distance / size\)\^2\) must lie in \[0, 1e\+30\], got 7.11\d*e\+38"),
    ({"size": 1e-20, "intensity": 1.0}, "its radiance"),
    ({"size": 0.0, "distance": 1e30}, "its intensity"),
    ({"type": "point", "position": [0, 400, -600], "intensity": [1.0, 1e39, 1.0]}, r"intensity must lie in \[0, 1e\+30\], got \(1, 1e\+39, 1\)"),
]


@pytest.mark.parametrize("light, fragment", BAD_LIGHTS, ids=[f"{i}" for i in range(len(BAD_LIGHTS))])
def test_a_negative_or_non_finite_light_is_refused_before_any_work(tmp_path, light, fragment):
    """Every light's intensity, radiance, position and size are checked when the scene is read: a negative
    explicit intensity was accepted (a black image), as a relative light's was refused."""
    doc = {"shapes": {"ball": {"type": "mesh", "file": str(write_mesh(tmp_path / "ball.ply", _sphere(30.0)))}},
           "lights": {"rim": light}}
    with pytest.raises(SceneError, match=f"light 'rim': {fragment}"):
        scene_from_document(doc, units="mm", width=W, height=H)


def test_a_partly_given_default_light_takes_that_lights_defaults(tmp_path):
    """[lights.key] with only size and intensity sits where the default key light does (azimuth 50, elevation
    40, 6 R: docs/meshes.md), not at azimuth 0, elevation 0, 4 R (in front of the model, before the camera);
    a light with another name takes OTHER_LIGHT's fields."""
    from ssskit.scenes.scenefile import DEFAULT_LIGHTS, OTHER_LIGHT

    ball = {"ball": {"type": "mesh", "file": str(write_mesh(tmp_path / "ball.ply", _sphere(30.0)))}}
    full = scene_from_document({"shapes": ball, "lights": {"key": DEFAULT_LIGHTS["key"]}}, units="mm",
                               width=W, height=H).spec.lights()["key"]
    part = scene_from_document({"shapes": ball, "lights": {"key": {"size": 0.2, "intensity": 1.0}}}, units="mm",
                               width=W, height=H).spec.lights()["key"]
    assert part == full
    np.testing.assert_allclose(np.linalg.norm(part["center"]), 6.0 * 30.0, rtol=1e-6)  # 6 R from the centre
    other = scene_from_document({"shapes": ball, "lights": {"rim": {"intensity": 1.0}}}, units="mm",
                                width=W, height=H).spec.lights()["rim"]
    np.testing.assert_allclose(np.linalg.norm(other["center"]), OTHER_LIGHT["distance"] * 30.0, rtol=1e-6)


def test_scene_file_with_meshes_materials_and_units(tmp_path):
    _two_material_gltf(tmp_path, ".gltf")
    (tmp_path / "scene.toml").write_text('units = "mm"\n[camera]\nview = "front"\n'
                                         '[shapes.pair]\ntype = "mesh"\nfile = "two.gltf"\n'
                                         'materials = { skinA = "skin1", skinB = "ketchup" }\n')
    scene = resolve_scene(str(tmp_path / "scene.toml"), width=W, height=H)
    assert scene.kind == "file" and scene.spec.sss_materials == ("skin1", "ketchup")
    assert len(scene.spec.sss_shapes) == 2 and scene.spec.reference_problem is None
    over = resolve_scene(str(tmp_path / "scene.toml"), material_map="skinB=marble", width=W, height=H)
    assert over.spec.sss_materials == ("skin1", "marble")


# ---- topology and the reference --------------------------------------------------------------------------

def test_open_and_non_manifold_meshes_are_refused_by_the_reference_with_the_reason(tmp_path, monkeypatch):
    s = _sphere()
    open_mesh = Mesh("cup", s.vertices, s.faces[10:], s.normals)
    extra = np.concatenate([s.faces, s.faces[:1, ::-1], s.faces[:1]])  # one edge with four faces
    fin = Mesh("fin", s.vertices, extra, s.normals)
    assert topology(open_mesh).boundary_edges == 3 * 10 - 6 or topology(open_mesh).boundary_edges > 0
    import ssskit.scenes.reference as reference

    def boom(*a, **k):  # no render may start
        raise AssertionError("rendering started")

    monkeypatch.setattr(reference, "ReferenceRenderer", boom)
    monkeypatch.setattr(reference, "sss_region", boom)
    for mesh, word in ((open_mesh, "open"), (fin, "non-manifold")):
        scene = resolve_scene(str(write_mesh(tmp_path / f"{mesh.name}.ply", mesh)), units="mm", width=W, height=H)
        assert word in scene.spec.reference_problem
        render_gbuffer(scene.spec, ALBEDO, width=16, height=12, spp=1)  # the screen-space side takes it
        from ssskit.materials import get_material

        with pytest.raises(SceneError, match=f"is {word}.*path-traced reference needs"):
            render_reference(scene.spec, get_material("skin1"), width=16, height=12)


def test_inside_out_mesh_is_turned_for_the_medium(tmp_path):
    inv = _sphere().flipped()
    assert topology(inv).volume < 0
    scene = resolve_scene(str(write_mesh(tmp_path / "inv.ply", inv)), units="mm", width=W, height=H)
    (obj,) = scene.objects
    assert scene.spec.reference_problem is None
    (written,) = read_mesh(obj.shape["filename"])
    assert topology(written).volume > 0


@pytest.mark.slow
def test_reference_on_a_mesh_converges_with_two_materials(tmp_path):
    from ssskit.materials import get_material

    scene = resolve_scene(str(_two_material_gltf(tmp_path)), units="mm", material_map="skinA=skin1,skinB=marble",
                          width=32, height=16)
    mats = [get_material(m) for m in scene.spec.sss_materials]
    # small sphere lights seen through a rough dielectric are found by BSDF sampling alone: slow to converge
    ref = render_reference(scene.spec, mats, width=32, height=16, spp=16, max_spp=512, target_rel_se=0.2,
                           chunk_spp=8, use_cache=False, progress=False)
    assert ref.converged and np.all(ref.rel_se <= 0.2)
    assert np.all(np.isfinite(ref.image)) and ref.image[ref.region].mean() > 0


# ---- bad inputs (before any render) ----------------------------------------------------------------------

def _nan_mesh() -> Mesh:
    s = _sphere()
    v = s.vertices.copy()
    v[5, 1] = np.nan
    return Mesh("ball", v, s.faces, s.normals)


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_nan_vertices_are_refused(tmp_path, suffix):
    path = write_mesh(tmp_path / f"nan{suffix}", _nan_mesh())
    with pytest.raises(SceneError, match=r"vertex positions must be finite, got NaN or inf"):
        resolve_scene(str(path), units="mm")


def test_missing_empty_and_unknown_meshes_are_refused(tmp_path):
    with pytest.raises(SceneError, match="does not exist"):
        resolve_scene(str(tmp_path / "nope.obj"))
    (tmp_path / "empty.ply").write_bytes(b"")
    with pytest.raises(SceneError, match=r"is empty \(0 bytes\)"):
        resolve_scene(str(tmp_path / "empty.ply"))
    (tmp_path / "model.stl").write_bytes(b"solid x\n")
    with pytest.raises(SceneError, match="its format must be one of .obj, .ply, .glb, .gltf, .toml, .exr, got '.stl'"):
        resolve_scene(str(tmp_path / "model.stl"))
    with pytest.raises(SceneError, match=r"its format must be one of .*, got '\(no suffix\)'"):
        resolve_scene(str(tmp_path / "noext"))  # (a path: a file, not a scene's name)
    (tmp_path / "faceless.ply").write_bytes(b"ply\nformat ascii 1.0\nelement vertex 0\nelement face 0\n"
                                            b"property list uchar int vertex_indices\nend_header\n")
    with pytest.raises(SceneError, match="has no faces"):
        resolve_scene(str(tmp_path / "faceless.ply"))
    (tmp_path / "junk.glb").write_bytes(b"not a gltf at all")
    with pytest.raises(SceneError, match="not a binary glTF"):
        resolve_scene(str(tmp_path / "junk.glb"))


def test_material_map_naming_an_unknown_object_or_material(tmp_path):
    path = str(_two_material_gltf(tmp_path))
    with pytest.raises(SceneError, match=r"material map names 'skinC'.*its objects: skinA, skinB"):
        resolve_scene(path, units="mm", material_map="skinC=skin1")
    from ssskit.errors import MaterialError

    with pytest.raises(MaterialError):
        resolve_scene(path, units="mm", material_map="skinA=unobtainium")
    with pytest.raises(SceneError, match="not NAME=MATERIAL"):
        resolve_scene(path, units="mm", material_map="skinA")


def test_a_mesh_too_large_for_memory_is_refused_with_the_estimate(tmp_path):
    """A PLY header announcing 2 billion faces is refused from the header alone (nothing is loaded)."""
    p = tmp_path / "huge.ply"
    p.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\n"
                  b"property float y\nproperty float z\nelement face 2000000000\n"
                  b"property list uchar uint vertex_indices\nend_header\n")
    assert mesh_counts(p) == MeshCounts(1_000_000_000, 2_000_000_000)
    with pytest.raises(SceneError, match=r"2,000,000,000 faces: rendering it at 256x192 needs about 745\.[0-9] GiB"):
        resolve_scene(str(p), units="mm")
    need = check_render_memory(f"mesh {str(p)!r}", MeshCounts(10, 20), 256, 192, available=1 << 40)
    assert need == 20 * BYTES_PER_FACE + 256 * 192 * 512


def test_conflicting_units_are_refused(tmp_path):
    path = str(write_mesh(tmp_path / "ball.ply", _sphere()))
    with pytest.raises(SceneError, match="--units mm and --units m disagree; give the units once"):
        resolve_scene(path, units=["mm", "m"])
    (tmp_path / "s.toml").write_text('units = "cm"\n[shapes.ball]\ntype = "mesh"\nfile = "ball.ply"\n')
    with pytest.raises(SceneError, match="--units m and .*s.toml: units cm disagree; give the units once"):
        resolve_scene(str(tmp_path / "s.toml"), units="m")
    with pytest.raises(SceneError, match="units must be one of mm, cm, m, got 'inch'"):
        resolve_scene(path, units="inch")
    with pytest.raises(SceneError, match="--units applies to --scene a mesh file or a scene .toml, not --scene 'slab' \\(a built-in scene"):
        resolve_scene("slab", units="mm")


def test_reference_is_cached_per_mesh_digest(tmp_path, monkeypatch):
    """The reference's cache key holds the mesh's digest (in the cached PLY's name): the same mesh read again
    reuses the render; the file rewritten with one vertex moved is rendered anew."""
    from ssskit.materials import get_material
    from ssskit.scenes.reference import reference_cache_dir

    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    s = _sphere()
    mat = get_material("skin1")
    kw = dict(width=16, height=12, spp=8, chunk_spp=8, progress=False)

    def files():
        return sorted(p.name for p in reference_cache_dir().glob("*.npz"))

    path = str(write_mesh(tmp_path / "ball.ply", s))
    a = resolve_scene(path, units="mm", width=16, height=12)
    ra = render_reference(a.spec, mat, **kw)
    first = files()
    assert len(first) == 1
    again = resolve_scene(path, units="mm", width=16, height=12)
    assert again.objects[0].digest == a.objects[0].digest
    rb = render_reference(again.spec, mat, **kw)
    assert files() == first
    np.testing.assert_array_equal(rb.image, ra.image)
    moved = s.vertices.copy()
    moved[0] *= np.float32(1.01)
    write_mesh(tmp_path / "ball.ply", Mesh("ball", moved, s.faces, s.normals))
    c = resolve_scene(path, units="mm", width=16, height=12)
    assert c.objects[0].digest != a.objects[0].digest
    render_reference(c.spec, mat, **kw)
    assert len(files()) == 2


_OOB_HEADER = ("ply\nformat {fmt} 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
               "element face 1\nproperty list uchar int vertex_indices\nend_header\n")


@pytest.mark.parametrize("index", [3, 2_000_000_000, -5])
@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian"])
def test_a_ply_face_index_out_of_range_is_one_error_line_not_a_crash(tmp_path, fmt, index):
    """Mitsuba's PLY loader takes an index beyond the vertices as it is and crashed the process (exit 139, no
    message) for large ones; the file's indices are checked before any renderer sees them (a subprocess, so the
    old crash fails the test instead of the suite)."""
    import subprocess
    import sys

    head = _OOB_HEADER.format(fmt=fmt).encode()
    if fmt == "ascii":
        body = f"0 0 0\n1 0 0\n0 1 0\n3 0 1 {index}\n".encode()
    else:
        body = (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "<f4").tobytes() + b"\x03"
                + np.array([0, 1, index], "<i4").tobytes())
    path = tmp_path / "oob.ply"
    path.write_bytes(head + body)
    proc = subprocess.run([sys.executable, "-m", "ssskit.cli", "render", "--scene", str(path), "--out",
                           str(tmp_path / "o.png")], capture_output=True, text=True, timeout=120,
                          env={**os.environ, "SSSKIT_CACHE_DIR": str(tmp_path / "cache")})
    assert proc.returncode == 2, proc.stderr
    # (a heartbeat line, "  ... still working", comes only from a machine loaded enough to make this take 8 s)
    lines = [line for line in proc.stderr.splitlines() if not line.startswith("  ... still working")]
    assert len(lines) == 1 and "face indices must lie in [0, 2]" in lines[0], proc.stderr
    assert not (tmp_path / "o.png").exists()
    with pytest.raises(SceneError, match=re.escape(f"face indices must lie in [0, 2], got {float(index):g} in 1 of 3 indices")):
        read_mesh(path)


@pytest.mark.parametrize("value", ["5", "true", "{ a = 1 }", "[5]"])
def test_units_of_a_wrong_type_in_a_scene_file_are_refused(tmp_path, value):
    """``units = 5`` in a scene file raised a TypeError (a traceback from the CLI); a scene error now."""
    write_mesh(tmp_path / "ball.ply", _sphere())
    for doc in (f'units = {value}\n[shapes.ball]\ntype = "mesh"\nfile = "ball.ply"\n',
                f'[shapes.ball]\ntype = "mesh"\nunits = {value}\nfile = "ball.ply"\n'):
        (tmp_path / "s.toml").write_text(doc)
        with pytest.raises(SceneError, match=r"units must be one of mm, cm, m, got "):
            resolve_scene(str(tmp_path / "s.toml"))


def test_a_mesh_with_a_240_character_name_is_rendered(tmp_path, monkeypatch):
    """The cache's file names held the mesh's whole name: a 240-character one passed the file system's 255 bytes
    and the mesh could not be rendered. Names are bounded (readable beginning + hash of the whole name)."""
    from ssskit.cache import NAME_BYTES, cache_file

    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    stem = "b" * 240
    path = write_mesh(tmp_path / f"{stem}.ply", _sphere())
    scene = resolve_scene(str(path), units="mm", width=16, height=12)
    (cached,) = (tmp_path / "cache" / "meshes").iterdir()
    assert len(cached.name.encode()) < 128 and cached.name.startswith("mesh-bbbb")
    gb = render_gbuffer(scene.spec, ALBEDO, width=16, height=12, spp=1)
    assert np.isfinite(gb.diffuse).all()
    # bounded in bytes for any name, readable, and apart for names sharing their beginning
    for name in ("é" * 300, "x" * 300, "x" * 299 + "y", "a/b\x00c"):
        p = cache_file("reference", name, "0123456789abcdef", ".npz")
        assert p.parent == tmp_path / "cache" / "reference"
        assert len(p.name.encode()) <= NAME_BYTES + 30 and "/" not in p.name and "\x00" not in p.name
    assert cache_file("meshes", "x" * 300, "k", ".ply") != cache_file("meshes", "x" * 299 + "y", "k", ".ply")
    assert cache_file("meshes", "head", "k", ".ply").name == "head-k.ply"


@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_a_one_material_gltf_object_is_named_by_its_material(tmp_path, suffix):
    """docs/meshes.md: glTF objects are named by their material, so ``--material-map skin=skin1`` names the one
    object of a one-material head.glb (it was named after the file, 'head', and the documented map failed)."""
    path = str(write_mesh(tmp_path / f"head{suffix}", Mesh("skin", _sphere(0.03).vertices, _sphere(0.03).faces)))
    scene = resolve_scene(path, units="m", material_map="skin=skin1", width=W, height=H)
    assert [o.name for o in scene.objects] == ["skin"] and scene.objects[0].material == "skin1"
    with pytest.raises(SceneError, match=r"material map names 'head'.*its objects: skin"):
        resolve_scene(path, units="m", material_map="head=skin1", width=W, height=H)
    # a scene file's shape table: the same names (materials = { skin = ... })
    (tmp_path / "s.toml").write_text(f'units = "m"\n[shapes.head]\ntype = "mesh"\nfile = "head{suffix}"\n'
                                     'materials = { skin = "skin2" }\n')
    scene = resolve_scene(str(tmp_path / "s.toml"), width=W, height=H)
    assert [(o.name, o.material) for o in scene.objects] == [("skin", "skin2")]
    # OBJ and PLY: one object named by the file's stem
    ply = str(write_mesh(tmp_path / "ball.ply", _sphere()))
    assert [o.name for o in resolve_scene(ply, units="mm", material_map="ball=skin1", width=W, height=H).objects] == ["ball"]


_SPHERE = {"type": "sphere", "center": [0, 0, 0], "radius": 10, "sss": True}
_CAMERA = {"origin": [0, 0, 100], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 30}
_LIGHT = {"k": {"type": "point", "position": [0, 0, 50], "intensity": 1.0}}


@pytest.mark.parametrize("doc, fragment", [
    # each raised a TypeError or ValueError (a traceback) or went unchecked before
    ({"shapes": {"s": _SPHERE}, "camera": 5}, r"scene: \[camera\] must be a table, got 5"),
    ({"shapes": {"s": _SPHERE}, "lights": 5}, r"scene: \[lights\] must be a table, got 5"),
    ({"shapes": {"s": _SPHERE}, "camera": _CAMERA, "lights": _LIGHT, "orbit_deg_per_frame": "x"},
     "orbit_deg_per_frame must be a number, got 'x'"),
    ({"shapes": {"s": _SPHERE}, "camera": {**_CAMERA, "origin": "x"}, "lights": _LIGHT},
     r"\[camera\]: origin must be a real array of shape \(3,\)"),
    ({"shapes": {"g": {"type": "generated", "generator": "icosphere"}}, "camera": {"up": ["a", 1, 0]}},
     r"camera up must be a real array of shape \(3,\)"),
    ({"shapes": {"g": {"type": "generated", "generator": "icosphere"}}, "camera": {"front": [0, 2, 0]}},
     r"camera up \(0.0, 1.0, 0.0\) and front \[0, 2, 0\] must be non-zero and not parallel"),
    ({"shapes": {"g": {"type": "generated", "generator": "bust", "params": 5}}}, "params must be a table, got 5"),
    ({"shapes": {"g": {"type": "generated", "generator": "bust", "params": {"voxel_mm": "x"}}}},
     "bust voxel size must be a number, got 'x'"),
    ({"shapes": {"g": {"type": "generated", "generator": "bust", "params": {"voxels": 2}}}},  # (was ignored)
     "generator 'bust': got an unexpected keyword argument 'voxels'"),
    ({"shapes": {"g": {"type": "generated", "generator": "teapot"}}},
     "generator must be one of bust, icosphere, torus, ellipsoid, heightfield, head, got 'teapot'"),
    ({"shapes": {"s": _SPHERE}, "camera": _CAMERA},  # the default lights are placed relative to the framing
     r"a scene with an explicit camera needs explicit \[lights\]"),
    ({"shapes": {"s": _SPHERE}, "camera": _CAMERA, "lights": {**_LIGHT, "rim": {"azimuth": 180.0}}},
     "light 'rim' is placed relative to the automatic framing, but the camera is explicit"),
])
def test_scene_file_values_of_the_wrong_kind_are_refused(doc, fragment):
    with pytest.raises(SceneError, match=fragment):
        scene_from_document(doc)


def test_a_relative_mesh_name_is_read_from_the_current_folder(tmp_path, monkeypatch):
    """Mitsuba resolves a relative file name against its file resolver, which holds the folder it was first
    imported in: in one process, after a chdir, ``read_mesh("m.obj")`` read that folder's m.obj, not the current
    one's (found by the in-process tests of issue 34's hunt, whose folders hold a 4-face ball.obj). (An OBJ: Mitsuba
    reads it; a PLY is read by trimesh.)"""
    from ssskit.scenes.mitsuba_variant import mitsuba

    first, here = tmp_path / "first", tmp_path / "here"
    first.mkdir(), here.mkdir()
    write_mesh(first / "m.obj", icosphere(1, 1.0))
    write_mesh(here / "m.obj", torus(30.0, 9.0, 32, 16))
    resolver = mitsuba().file_resolver()
    resolver.prepend(str(first))  # as if Mitsuba had been imported in `first`
    try:
        monkeypatch.chdir(here)
        (mesh,) = read_mesh("m.obj")
    finally:
        del resolver[0]
    assert len(mesh.faces) == len(torus(30.0, 9.0, 32, 16).faces) != len(icosphere(1, 1.0).faces)
