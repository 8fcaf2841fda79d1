"""What the live viewer's page shows, computed with the Python API: the scene (mesh, camera, lights, in mm)
and, per material, the separable pass's fragment shader (the text ``ssskit export --format glsl-shader
--out X.frag`` writes), its kernel's taps and the Burley pass's fragment shader; and the static folder
(``ssskit view --out DIR``) that holds the page, its script and these data as one ``data.js``.

The data travel as a script (``window.SSSKIT_DATA = {...}``), not as JSON fetched by the page: a page opened
from ``file://`` may not fetch files, but it may run scripts beside it.
"""

from __future__ import annotations

import base64
import json
import math
import os
import shutil
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import SsskitError

#: the files of the page (ssskit/view/static), copied into a static folder and the only files served
PAGE_FILES = ("index.html", "viewer.js", "viewer.css")
#: the material presets a static folder precomputes
PRESETS = ("skin1", "skin2", "marble", "ketchup", "apple")
#: the scenes ``--scene`` takes by name (generated meshes, mm); a mesh file (.obj, .ply, .glb, .gltf) too
SCENE_NAMES = ("head", "bust", "icosphere", "torus")
MESH_SUFFIXES = (".obj", ".ply", ".glb", ".gltf")
#: the separable pass's defaults (those of ``ssskit render``: RenderSettings), and the profile model the
#: viewer uses (the dipole: closed form, so a material change re-renders within a second)
DEFAULT_KERNEL = "preintegrated"
DEFAULT_TAPS = 7
DEFAULT_MODEL = "dipole"
DEFAULT_JITTER = 0.1
#: the tap counts and spp the page offers (the API refuses others: bounded work per request)
TAP_CHOICES = (5, 7, 9, 11, 13, 15, 17, 21, 25)
SPP_RANGE = (1, 256)


@dataclass(frozen=True)
class MaterialRequest:
    """A material for the page: a preset name or material file (``material``), or artists' terms
    (``albedo`` with ``mfp`` in mm, 3 values each), and the separable pass's options."""

    material: str | None = "skin1"
    albedo: tuple[float, float, float] | None = None
    mfp: tuple[float, float, float] | None = None
    kernel: str = DEFAULT_KERNEL
    taps: int = DEFAULT_TAPS
    jitter: float = DEFAULT_JITTER

    def check(self) -> None:
        """Every refusal before any work (a :class:`SsskitError` naming the input and its valid domain)."""
        from ..profiles.artist import check_artist

        artist = self.albedo is not None or self.mfp is not None
        if artist == (self.material is not None):
            raise SsskitError("give the material once: a preset name or file, or albedo with mfp")
        if artist:
            if self.albedo is None or self.mfp is None:
                raise SsskitError("artists' terms need albedo and mfp (3 values each)")
            check_artist(self.albedo, self.mfp, "mfp", 1.4, 0.0)
        if self.taps not in TAP_CHOICES:
            raise SsskitError(f"taps must be one of {', '.join(map(str, TAP_CHOICES))}, got {self.taps!r}")
        if not (isinstance(self.jitter, (int, float)) and math.isfinite(self.jitter) and 0.0 <= self.jitter <= 1.0):
            raise SsskitError(f"jitter is a fraction of the kernel size in [0, 1], got {self.jitter!r}")
        from ..kernels import parse_method_spec

        parse_method_spec(self.kernel)

    def resolve(self) -> Any:
        """The :class:`~ssskit.materials.Material`."""
        from ..materials import get_material
        from ..profiles.artist import ArtistMaterial, material_from_artist

        if self.material is not None:
            return get_material(self.material)
        assert self.albedo is not None and self.mfp is not None
        return material_from_artist(ArtistMaterial("artist", self.albedo, self.mfp, "mfp", 1.4, 0.0))


def kernel_taps(req: MaterialRequest) -> tuple[Any, Any, Any]:
    """(material, kernel, taps) as ``ssskit render`` builds them (:func:`ssskit.pipeline.render`'s
    ``taps_of``): the material's profile (:data:`DEFAULT_MODEL`), the kernel on its default grid, the taps."""
    from ..kernels import TapKernel, build_kernel, default_grid, parse_method_spec
    from ..profiles import profile_for_material
    from ..sampling.taps import make_taps

    req.check()
    mat = req.resolve()
    prof = profile_for_material(mat, DEFAULT_MODEL)
    method, params, _ = parse_method_spec(req.kernel)
    cell, n = default_grid(prof)
    kernel = build_kernel(method.name, prof, cell, n, **params)
    taps = make_taps(kernel, None if isinstance(kernel, TapKernel) else req.taps, "importance")
    return (mat, prof), kernel, taps


def material_payload(req: MaterialRequest) -> dict[str, Any]:
    """The page's data for one material: its name, the composite's albedo (the profile's total diffuse
    reflectance), the separable pass (the exported fragment shader, its term count, the taps), the
    Burley pass (its fragment shader; Burley parameters from the material, Xie 2020 Eq. 5 searchlight), the
    adaptive guide (Xie 2020 Sec. 4.1) and the transmittance pass (the material's MCML slab table)."""
    from ..backends.burley_plan import build_burley_plan
    from ..backends.gl.burley import burley_fragment_source
    from ..export.shaders import separable_shader
    from ..screenspace.burley import burley_params_for_material
    from ..screenspace.separable import default_depth_mode

    from ..backends.adaptive_plan import as_plan
    from ..backends.gl.adaptive import adaptive_fragment_source
    from ..backends.gl.transmission import transmission_fragment_source
    from ..backends.transmission_plan import build_transmission_plan
    from ..screenspace.adaptive import AdaptiveSettings
    from ..screenspace.transmission import mcml_model

    (mat, prof), kernel, taps = kernel_taps(req)
    shader = separable_shader(taps, "glsl", jitter=req.jitter, depth_mode=default_depth_mode(taps), stage="fragment")
    params = burley_params_for_material(mat)
    plan = build_burley_plan({1: params}, 1.0, 1.0)
    guide = as_plan(AdaptiveSettings())
    return {
        "name": getattr(mat, "name", "material"),
        "albedo": [float(v) for v in prof.total_rd()],
        "separable": {"shader": shader, "terms": int(taps.rank), "kernel": req.kernel, "taps": int(taps.taps),
                      "jitter": float(req.jitter), "offsets_mm": np.asarray(taps.offsets_mm).tolist(),
                      "weights": np.asarray(taps.weights).tolist()},
        "burley": {"shader": burley_fragment_source(plan), "dmfp_mm": [float(v) for v in params.dmfp_mm],
                   "albedo": [float(v) for v in params.albedo]},
        # Xie 2020 Sec. 4.1 with ssskit's AdaptiveSettings defaults: the estimate, the update (each also reading
        # the history through motion vectors), the Burley pass reading the count image
        "adaptive": {"estimate": adaptive_fragment_source(guide, False), "update": adaptive_fragment_source(guide, True),
                     # after an orbit step: the history fetched through motion vectors, a validity image
                     "estimate_moved": adaptive_fragment_source(guide, False, motion=True, valid=True),
                     "update_moved": adaptive_fragment_source(guide, True, motion=True, valid=True),
                     "burley": burley_fragment_source(plan, count_image=True), "b_min": guide.b_min,
                     "b_max": guide.b_max},
        # the transmittance pass with the material's MCML slab table (ssskit.screenspace.transmission.mcml_model)
        "transmission": {"shader": transmission_fragment_source(build_transmission_plan({1: mcml_model(mat)})),
                         "model": "mcml"},
    }


def _b64(a: np.ndarray, dtype: Any) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype=dtype).tobytes()).decode("ascii")


def _light_list(spec: Any) -> list[dict[str, Any]]:
    """The scene's lights as directions and the diffuse intensity each gives a white surface facing it:
    a sphere light of radius a and radiance L at distance d gives E = pi L (a / d)^2 ([PJH23] ch. 4, as
    :mod:`ssskit.scenes.scenefile` states), intensity E / pi; a point light of intensity I: E = I / d^2."""
    target = np.asarray(spec.target, float)
    out = []
    for name, light in spec.lights().items():
        pos = light.get("center", light.get("position"))
        if pos is None:
            continue
        v = np.asarray(pos, float) - target
        d = float(np.linalg.norm(v))
        if light.get("type") == "sphere":
            rad = np.broadcast_to(np.asarray(light["emitter"]["radiance"]["value"], float), 3)
            intensity = rad * (float(light["radius"]) / d) ** 2      # E / pi = L (a / d)^2
        else:
            val = light.get("intensity", {}).get("value", 0.0)
            intensity = np.broadcast_to(np.asarray(val, float), 3) / d**2 / math.pi
        out.append({"name": name, "direction": (v / d).tolist(), "intensity": [float(x) for x in intensity]})
    return out


def check_scene(scene: str | os.PathLike[str]) -> str:
    """The viewer's ``--scene``, checked before any work: a name of :data:`SCENE_NAMES` or an existing mesh file
    (.obj, .ply, .glb, .gltf); returns it as text."""
    text = os.fspath(scene)
    if text.lower() not in SCENE_NAMES and Path(text).suffix.lower() not in MESH_SUFFIXES:
        raise SsskitError(f"scene {text!r}: the viewer shows a generated mesh ({', '.join(SCENE_NAMES)}) or a mesh "
                          f"file ({', '.join(MESH_SUFFIXES)})")
    if text.lower() not in SCENE_NAMES and not Path(text).is_file():
        raise SsskitError(f"scene {text!r}: no such mesh file")
    return text


def check_out(out: str | os.PathLike[str]) -> Path:
    """The static folder's ``--out``, checked before any work: a new folder, an empty one or an earlier viewer
    folder (which :func:`write_site` replaces), never a file or a folder holding other files."""
    dest = Path(out)
    if dest.exists() and not dest.is_dir():
        raise SsskitError(f"--out {dest} exists and is not a folder")
    if dest.is_dir() and any(dest.iterdir()) and not (dest / "data.js").is_file():
        raise SsskitError(f"--out {dest} is a folder holding other files; give an empty or new folder")
    return dest


def scene_payload(scene: str) -> dict[str, Any]:
    """The page's scene: a generated mesh (:data:`SCENE_NAMES`) or a mesh file, read and framed as
    ``ssskit render --scene`` does (:func:`ssskit.scenes.scenefile.resolve_scene`), in mm: merged vertex
    positions and normals, faces, the camera (origin, target, up, horizontal fov) and the lights."""
    from ..scenes.meshes import Mesh, read_mesh, topology
    from ..scenes.scenefile import resolve_scene

    text = check_scene(scene)
    resolved = resolve_scene(text)
    spec = resolved.spec
    assert spec is not None
    verts, norms, faces = [], [], []
    base = 0
    for shape in spec.shapes().values():
        if shape.get("type") not in ("ply", "obj"):
            continue
        for mesh in read_mesh(shape["filename"]):
            v = np.asarray(mesh.vertices, np.float64)
            if "to_world" in shape:
                raise SsskitError("the viewer takes meshes without a transform")
            f = np.asarray(mesh.faces, np.int64)
            nrm = mesh.normals if mesh.normals is not None else _vertex_normals(v, f)
            verts.append(v)
            norms.append(nrm)
            faces.append(f + base)
            base += len(v)
    if not verts:
        raise SsskitError(f"scene {text!r} holds no mesh")
    v = np.concatenate(verts)
    f = np.concatenate(faces)
    # a closed, consistently wound mesh hides its back faces: the page culls them (half the triangles to raster)
    topo = topology(Mesh("scene", v.astype(np.float32), f.astype(np.uint32)))
    closed = topo.boundary_edges == 0 and topo.nonmanifold_edges == 0 and topo.misoriented_edges == 0
    if base >= 2**32:
        raise SsskitError("the mesh has more vertices than 32-bit indices hold")
    lo, hi = v.min(axis=0), v.max(axis=0)
    centre = (lo + hi) / 2
    radius = float(np.linalg.norm(v - centre, axis=1).max())
    return {"name": spec.name, "positions": _b64(v, np.float32), "bounds": {"centre": centre.tolist(), "radius": radius}, "normals": _b64(np.concatenate(norms), np.float32),
            "indices": _b64(f, np.uint32), "vertices": int(len(v)), "triangles": int(len(f)),
            "cull": ("back" if topo.volume > 0 else "front") if closed else "none",
            "camera": {"origin": list(map(float, spec.origin)), "target": list(map(float, spec.target)),
                       "up": list(map(float, spec.up)), "fov_x_deg": float(spec.fov_x_deg)},
            "lights": _light_list(spec), "about": dict(getattr(spec, "about", ()) or ())}


def _vertex_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Area-weighted smooth vertex normals."""
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    out = np.zeros_like(v)
    for k in range(3):
        np.add.at(out, f[:, k], n)
    length = np.linalg.norm(out, axis=1, keepdims=True)
    return out / np.where(length > 0, length, 1.0)


def page_data(scene: str, materials: dict[str, MaterialRequest], default: str, served: bool) -> dict[str, Any]:
    """Everything ``data.js`` holds."""
    return {"version": 1, "served": bool(served), "scene": scene_payload(scene), "default_material": default,
            "materials": {name: material_payload(req) for name, req in materials.items()},
            "tap_choices": list(TAP_CHOICES), "spp_range": list(SPP_RANGE)}


def data_script(data: dict[str, Any]) -> str:
    """``data.js``: the data as a script (module docstring); ``</`` escaped so no text closes a tag."""
    return "window.SSSKIT_DATA = " + json.dumps(data, separators=(",", ":")).replace("</", "<\\/") + ";\n"


def page_file(name: str) -> bytes:
    """One of :data:`PAGE_FILES`."""
    if name not in PAGE_FILES:
        raise SsskitError(f"{name!r} is not a file of the page")
    return resources.files(__package__).joinpath("static", name).read_bytes()


def write_static(out: str | os.PathLike[str], scene: str, materials: dict[str, MaterialRequest], default: str) -> Path:
    """``ssskit view --out DIR``: the static folder of ``scene`` with ``materials`` (name -> request; ``default``
    shown first) precomputed (:func:`page_data`, :func:`write_site`); the demo report embeds one. Returns DIR."""
    check_scene(scene)
    check_out(out)
    return write_site(out, page_data(scene, materials, default, served=False))


def write_site(out: str | os.PathLike[str], data: dict[str, Any]) -> Path:
    """The static folder: :data:`PAGE_FILES` and ``data.js``, written to a staging folder and moved into place
    (nothing partial is left where a run is interrupted). An existing non-empty folder that is not an earlier
    viewer folder is refused."""
    dest = check_out(out)
    dest.parent.mkdir(parents=True, exist_ok=True)
    staging = dest.parent / f".{dest.name}.staging-{os.getpid()}"
    if staging.exists():
        shutil.rmtree(staging)
    staging.mkdir()
    try:
        for name in PAGE_FILES:
            (staging / name).write_bytes(page_file(name))
        (staging / "data.js").write_text(data_script(data), encoding="utf-8")
        if dest.exists():
            shutil.rmtree(dest)
        staging.rename(dest)
    finally:
        if staging.exists():
            shutil.rmtree(staging)
    return dest


__all__ = ["DEFAULT_KERNEL", "DEFAULT_MODEL", "DEFAULT_TAPS", "MESH_SUFFIXES", "MaterialRequest", "PAGE_FILES",
           "PRESETS", "SCENE_NAMES", "check_out", "check_scene", "data_script", "kernel_taps", "material_payload",
           "page_data", "page_file", "scene_payload", "write_site", "write_static"]
