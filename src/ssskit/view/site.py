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
import numbers
import os
import shutil
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import SsskitError
from ..quantities import BURLEY_ALBEDO, CHOICE, FRACTION, MFP_MM, Choice, ErrorClass, Rule, check_instance, fail
from ..settings import Settings, setting

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
#: the separable pass's jitter radius, as ``ssskit render`` takes it (PassSettings' FRACTION, default 0.1)
JITTER = FRACTION.within(reason="a fraction of the kernel size")
#: the tap counts and spp the page offers (the API refuses others: bounded work per request)
TAP_CHOICES = (5, 7, 9, 11, 13, 15, 17, 21, 25)
SPP_RANGE = (1, 256)


#: the parts of a material's data (:func:`material_payload`): each pass's shaders and numbers, computed only
#: where asked (a served page asks for what its pass and transmission switch need; a static folder holds all)
PARTS = ("separable", "burley", "adaptive", "transmission")
#: the adaptive pass's limits the page offers as controls: fields of ssskit's AdaptivePass (the guide's
#: AdaptiveSettings fields and the history ``frames``), with the ranges Python declares (:func:`adaptive_controls`)
ADAPTIVE_FIELDS = ("b_min", "b_max", "sigma0_sq", "kappa", "alpha")
#: the guide's rule across fields (AdaptiveSettings: the sample budget needs b_min <= b_max), sent to the page
ADAPTIVE_ORDER = (("b_min", "b_max"),)


def _tap_choice(value: object, name: str, error: ErrorClass) -> int:
    """A tap count the page offers (:data:`TAP_CHOICES`, odd counts within :data:`~ssskit.quantities.TAPS`: bounded
    work per request), an integer (not 7.0, not its text '7'), shown as given."""
    if not isinstance(value, numbers.Integral) or value not in TAP_CHOICES:
        raise fail(error, CHOICE, name=name, choices=", ".join(map(str, TAP_CHOICES)), actual=repr(value))
    return int(value)


def _kernel(value: object, name: str, error: ErrorClass) -> str:
    """A kernel method spec, the rule of ``ssskit render``'s ``kernel`` (RenderSettings): one that
    :func:`ssskit.kernels.parse_method_spec` parses (a value's text: 5 is an unknown method '5'), returned in its
    canonical spelling. Declared here and not taken from RenderSettings with ``like``, so that importing the viewer
    does not import the pipeline (0.2 s of every ``ssskit view``'s start)."""
    from ..kernels import parse_method_spec

    return parse_method_spec(value)[2]  # type: ignore[arg-type]


def _adaptive(value: object, name: str, error: ErrorClass) -> Any:
    from ..screenspace.adaptive import AdaptiveSettings

    return check_instance(value, AdaptiveSettings, name, error, optional=True)


@dataclass(frozen=True)
class MaterialRequest(Settings):
    """A material for the page: a preset name or material file (``material``), or artists' terms
    (``albedo`` with ``mfp`` in mm, 3 values each), the separable pass's options and the adaptive pass's
    guide (:class:`~ssskit.screenspace.AdaptiveSettings`; ssskit's defaults, Xie 2020 Fig. 9's setting).
    Checked when made, wherever it enters (the server's API, ssskit view), before any work: each field by its
    declared rule (the kernel and the jitter as ``ssskit render`` declares them), then the material given once."""

    material: str | None = setting(None, "skin1")
    albedo: tuple[float, float, float] | None = setting(BURLEY_ALBEDO, None, optional=True, rgb=True)
    mfp: tuple[float, float, float] | None = setting(MFP_MM, None, optional=True, rgb=True)
    kernel: str = setting(Rule("kernel", _kernel), DEFAULT_KERNEL)
    taps: int = setting(Rule("taps", _tap_choice), DEFAULT_TAPS)
    jitter: float = setting(JITTER, 0.1)
    adaptive: Any = setting(Rule("adaptive", _adaptive), None)

    def __post_init__(self) -> None:
        super().__post_init__()
        artist = self.albedo is not None or self.mfp is not None
        if artist == (self.material is not None):
            raise SsskitError("give the material once: a preset name or file, or albedo with mfp")
        if artist and (self.albedo is None or self.mfp is None):
            raise SsskitError("artists' terms need albedo and mfp together (3 values each)")

    def resolve(self) -> Any:
        """The :class:`~ssskit.materials.Material`."""
        return _resolve(self.material, self.albedo, self.mfp)

    @property
    def guide(self) -> Any:
        """The adaptive pass's :class:`~ssskit.screenspace.AdaptiveSettings` (ssskit's defaults where not given)."""
        from ..screenspace.adaptive import AdaptiveSettings

        return AdaptiveSettings() if self.adaptive is None else self.adaptive


#: the relative index of artists' terms in the viewer (``ssskit view --albedo --mfp``), and of its exports
ARTIST_ETA = 1.4


@lru_cache(maxsize=64)
def _resolve(material: str | None, albedo: tuple[float, float, float] | None,
             mfp: tuple[float, float, float] | None) -> Any:
    from ..materials import get_material
    from ..profiles.artist import ArtistMaterial, material_from_artist

    if material is not None:
        return get_material(material)
    assert albedo is not None and mfp is not None
    return material_from_artist(ArtistMaterial("artist", albedo, mfp, "mfp", ARTIST_ETA, 0.0))


def kernel_taps(req: MaterialRequest) -> tuple[Any, Any, Any]:
    """(material, kernel, taps) as ``ssskit render`` builds them (:func:`ssskit.pipeline.render`'s
    ``taps_of``): the material's profile (:data:`DEFAULT_MODEL`), the kernel on its default grid, the taps."""
    return _kernel_taps(req.resolve(), req.kernel, req.taps)


@lru_cache(maxsize=64)
def _kernel_taps(mat: Any, kernel_spec: str, ntaps: int) -> tuple[Any, Any, Any]:
    from ..kernels import TapKernel, build_kernel, default_grid, parse_method_spec
    from ..profiles import profile_for_material
    from ..sampling.taps import make_taps

    prof = profile_for_material(mat, DEFAULT_MODEL)
    method, params, _ = parse_method_spec(kernel_spec)
    cell, n = default_grid(prof)
    kernel = build_kernel(method.name, prof, cell, n, **params)
    taps = make_taps(kernel, None if isinstance(kernel, TapKernel) else ntaps, "importance")
    return (mat, prof), kernel, taps


# Each part of a material's data, cached in memory per material (the frozen Material: a key of its numbers) and
# per option: a material the page showed before comes back at once (a served page's material change).

@lru_cache(maxsize=64)
def _separable_part(mat: Any, kernel_spec: str, ntaps: int, jitter: float) -> dict[str, Any]:
    from ..export.shaders import separable_shader
    from ..screenspace.separable import default_depth_mode

    (_, prof), _, taps = _kernel_taps(mat, kernel_spec, ntaps)
    shader = separable_shader(taps, "glsl", jitter=jitter, depth_mode=default_depth_mode(taps), stage="fragment")
    return {"albedo": [float(v) for v in prof.total_rd()],
            "separable": {"shader": shader, "terms": int(taps.rank), "kernel": kernel_spec, "taps": int(taps.taps),
                          "jitter": float(jitter), "offsets_mm": np.asarray(taps.offsets_mm).tolist(),
                          "weights": np.asarray(taps.weights).tolist()}}


@lru_cache(maxsize=64)
def _burley_plan(mat: Any) -> tuple[Any, Any]:
    from ..backends.burley_plan import build_burley_plan
    from ..screenspace.burley import burley_params_for_material

    params = burley_params_for_material(mat)
    return params, build_burley_plan({1: params}, 1.0, 1.0)


@lru_cache(maxsize=64)
def _burley_part(mat: Any) -> dict[str, Any]:
    from ..backends.gl.burley import burley_fragment_source

    params, plan = _burley_plan(mat)
    return {"shader": burley_fragment_source(plan), "dmfp_mm": [float(v) for v in params.dmfp_mm],
            "albedo": [float(v) for v in params.albedo]}


@lru_cache(maxsize=64)
def _adaptive_part(mat: Any, guide: Any) -> dict[str, Any]:
    from ..backends.adaptive_plan import as_plan
    from ..backends.gl.adaptive import adaptive_fragment_source
    from ..backends.gl.burley import burley_fragment_source

    _, plan = _burley_plan(mat)
    g = as_plan(guide)
    return {"estimate": adaptive_fragment_source(g, False), "update": adaptive_fragment_source(g, True),
            # after an orbit step: the history fetched through motion vectors, where a validity image allows
            "estimate_moved": adaptive_fragment_source(g, False, motion=True, valid=True),
            "update_moved": adaptive_fragment_source(g, True, motion=True, valid=True),
            "burley": burley_fragment_source(plan, count_image=True), "b_min": g.b_min, "b_max": g.b_max,
            "settings": {name: getattr(guide, name) for name in ADAPTIVE_FIELDS}}


@lru_cache(maxsize=64)
def _transmission_part(mat: Any) -> dict[str, Any]:
    from ..backends.gl.transmission import transmission_fragment_source
    from ..backends.transmission_plan import build_transmission_plan
    from ..screenspace.transmission import mcml_model

    return {"shader": transmission_fragment_source(build_transmission_plan({1: mcml_model(mat)})), "model": "mcml"}


def material_payload(req: MaterialRequest, parts: tuple[str, ...] = PARTS) -> dict[str, Any]:
    """The page's data for one material, the ``parts`` asked (:data:`PARTS`; all by default): its name, the
    composite's albedo (the profile's total diffuse reflectance) and the separable pass (the exported fragment
    shader, its term count, the taps) always; the Burley pass (its fragment shader; Burley parameters from the
    material, Xie 2020 Eq. 5 searchlight), the adaptive guide (Xie 2020 Sec. 4.1, ``req.guide``) and the
    transmittance pass (the material's MCML slab table) where asked. A material whose MCML slab table does not
    converge has no transmittance pass: its part holds the reason (``{"error": ...}``) and the page says so.
    Every part is cached in memory per material and options (a material shown before comes back at once)."""
    mat = req.resolve()  # (the parts: the server checks a request's, the others pass PARTS' own names)  # (the request was checked when made)
    out: dict[str, Any] = {"name": getattr(mat, "name", "material"), "parts": [p for p in PARTS if p in parts],
                           **_separable_part(mat, req.kernel, req.taps, float(req.jitter))}
    if "burley" in parts:
        out["burley"] = _burley_part(mat)
    if "adaptive" in parts:
        # Xie 2020 Sec. 4.1 with the request's guide: the estimate, the update, the Burley pass reading the counts
        out["adaptive"] = _adaptive_part(mat, req.guide)
    if "transmission" in parts:
        try:  # the transmittance pass with the material's MCML slab table (ssskit.screenspace.transmission)
            out["transmission"] = _transmission_part(mat)
        except SsskitError as exc:
            out["transmission"] = {"error": str(exc)}
    return out


def _finite(v: float) -> float | None:
    """A bound as JSON holds it: an infinite one as None (no bound)."""
    return float(v) if math.isfinite(v) else None


def adaptive_controls() -> list[dict[str, Any]]:
    """The adaptive pass's limits as the page's controls, one source: each field of ssskit's
    :class:`~ssskit.pipeline.settings.AdaptivePass` named in :data:`ADAPTIVE_FIELDS` and its ``frames`` (the
    history the page renders after a change), with the range its declared quantity (:mod:`ssskit.quantities`)
    holds, its default and its reason. The page checks an input against these before it asks the server, and
    the server checks it again through AdaptiveSettings."""
    import dataclasses

    from ..pipeline.settings import AdaptivePass

    fields = {f.name: f for f in dataclasses.fields(AdaptivePass)}
    out = []
    for name in (*ADAPTIVE_FIELDS, "frames"):
        f = fields[name]
        q = f.metadata["quantity"]
        out.append({"name": name, "lo": _finite(q.lo), "hi": _finite(q.hi), "lo_open": q.lo_open, "hi_open": q.hi_open,
                    "integer": q.integer, "default": f.default, "interval": q.interval, "reason": q.reason,
                    "served_only": name != "frames"})
    return out


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
        for mesh in read_mesh(shape["filename"]):  # (in mm, untransformed: only scenefile._primitive sets to_world)
            v = np.asarray(mesh.vertices, np.float64)
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
            "lights": _light_list(spec), "about": dict(getattr(spec, "about", ()) or ()),
            # a built-in scene's named views (the head: Xie 2020 Fig. 1's front, ear and close)
            "views": {name: {"origin": list(map(float, o)), "target": list(map(float, t)), "up": list(map(float, u)),
                             "fov_x_deg": float(f)} for name, (o, t, u, f) in dict(getattr(spec, "views", ()) or ()).items()}}


def _vertex_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Area-weighted smooth vertex normals."""
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    out = np.zeros_like(v)
    for k in range(3):
        np.add.at(out, f[:, k], n)
    length = np.linalg.norm(out, axis=1, keepdims=True)
    return out / np.where(length > 0, length, 1.0)


def _json_level(row: dict[str, Any]) -> dict[str, Any]:
    """A region's level as JSON holds it: an empty region's (NaN) level as None."""
    return {**row, "level": row["level"] if row["pixels"] else None}


def reference_payload(layers: dict[str, Any], width: int, height: int) -> dict[str, Any]:
    """The path-traced reference of a view as the page shows it beside its own ``width`` x ``height`` frame of the
    same camera (the same horizontal field of view): the image (float32 RGB, rows from the top, base64; shown
    unfiltered), each pixel's region (uint8, 1 + the index in ``regions``, 0 outside them), and per region its
    level with the standard error (:func:`ssskit.metrics.region_level`: mean(image - specular) / mean(E / pi),
    the effective albedo) over the rows the page's frame shows (a frame of another aspect crops the reference's
    rows: ``rows``) and over all of it (``levels_all``). ``layers``: :func:`ssskit.figures.head.cached_reference_layers`."""
    from ..metrics import region_level

    image = np.asarray(layers["image"], np.float64)
    h, w = image.shape[:2]
    # a page pixel's centre (x + 1/2, y + 1/2) is the reference's ((x + 1/2) w / W, h / 2 + (y + 1/2 - H / 2) w / W)
    half = height / 2 * w / width
    r0, r1 = max(0, int(math.floor(h / 2 - half))), min(h, int(math.ceil(h / 2 + half)))
    shown = np.zeros((h, w), bool)
    shown[r0:r1] = True
    part = image - np.asarray(layers["specular"], np.float64)
    e = np.asarray(layers["e_over_pi"], np.float64)
    se = np.asarray(layers["pixel_se"], np.float64)
    names = list(layers["masks"])
    labels = np.zeros((h, w), np.uint8)
    levels, levels_all = {}, {}
    for i, name in enumerate(names):
        m = np.asarray(layers["masks"][name], bool)
        labels[m] = i + 1
        levels[name] = _json_level(region_level(part, e, m & shown, se))
        levels_all[name] = _json_level(region_level(part, e, m, se))
    return {"size": [w, h], "rows": [r0, r1], "spp": int(layers["spp"]), "converged": bool(layers["converged"]),
            "driving_region": layers.get("driving_region"), "regions": names, "image": _b64(image, np.float32),
            "labels": _b64(labels, np.uint8), "levels": levels, "levels_all": levels_all}


def _request_body(req: MaterialRequest) -> dict[str, Any]:
    """The material of ``req`` as the API names it (a served page asks for more of it): albedo with mfp, or the
    preset's name."""
    if req.material is None:
        return {"albedo": list(req.albedo or ()), "mfp": list(req.mfp or ())}
    return {"material": req.material}


def engine_formats() -> list[dict[str, Any]]:
    """The engine formats of :data:`ssskit.export.FORMATS` (kind "engine"), one export button each: name, the
    suffixes it writes (the first is the button's default) and its description."""
    from ..export import FORMATS

    return [{"name": f.name, "suffixes": list(f.suffixes), "description": f.description}
            for _, f in FORMATS.items() if f.kind == "engine"]


def page_data(scene: str, materials: dict[str, MaterialRequest], default: str, served: bool) -> dict[str, Any]:
    """Everything ``data.js`` holds. A static folder holds every part of each material (:data:`PARTS`); a served
    page starts with the separable pass of its material alone and asks the server for the rest (the presets it
    lists, the parts its pass and transmission switch need)."""
    parts = ("separable",) if served else PARTS
    return {"version": 1, "served": bool(served), "scene": scene_payload(scene), "default_material": default,
            "materials": {name: {**material_payload(req, parts), "request": _request_body(req)}
                          for name, req in materials.items()},
            "presets": list(PRESETS) if served else [], "tap_choices": list(TAP_CHOICES), "spp_range": list(SPP_RANGE),
            "adaptive_controls": adaptive_controls(), "adaptive_order": [list(p) for p in ADAPTIVE_ORDER],
            "exports": engine_formats()}


def data_script(data: dict[str, Any]) -> str:
    """``data.js``: the data as a script (module docstring); ``</`` escaped so no text closes a tag."""
    return "window.SSSKIT_DATA = " + json.dumps(data, separators=(",", ":")).replace("</", "<\\/") + ";\n"


def page_file(name: str) -> bytes:
    """One of :data:`PAGE_FILES`, by its name (another name, a path into the package, is refused)."""
    return resources.files(__package__).joinpath("static", Choice("page file", PAGE_FILES).check(name)).read_bytes()


def write_static(out: str | os.PathLike[str], scene: str, materials: dict[str, MaterialRequest], default: str) -> Path:
    """``ssskit view --out DIR``: the static folder of ``scene`` with ``materials`` (name -> request; ``default``
    shown first) precomputed (:func:`page_data`, :func:`write_site`); the demo report embeds one. Returns DIR."""
    check_out(out)  # before the work (page_data checks the scene first)
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


__all__ = ["ADAPTIVE_FIELDS", "ADAPTIVE_ORDER", "ARTIST_ETA", "DEFAULT_KERNEL", "DEFAULT_MODEL", "DEFAULT_TAPS", "MESH_SUFFIXES",
           "MaterialRequest", "PAGE_FILES", "PARTS", "PRESETS", "SCENE_NAMES", "adaptive_controls", "check_out",
           "check_scene", "data_script", "engine_formats", "kernel_taps", "material_payload", "page_data", "page_file", "reference_payload", "scene_payload",
           "write_site", "write_static"]
