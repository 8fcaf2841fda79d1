"""Scene files (TOML) and mesh scenes: one description of shapes, materials, camera and lights that
loads into the same :class:`~ssskit.scenes.scenes.SceneSpec` as the built-in scenes (which are
written in it: ``src/ssskit/scenes/builtin/*.toml``), and :func:`resolve_scene`, which turns a
``--scene`` value into what the pipeline renders.

A scene file::

    name = "head"                 # optional (default: the file's stem)
    units = "m"                   # of every mesh file (mm, cm, m), unless a shape names its own
    lit_from_behind = false       # true: every light is behind the SSS objects (--transmission auto runs
                                  # the transmittance pass; default false)

    [camera]                      # explicit: origin, target, up (world mm), fov (degrees, horizontal)
    view = "front"                # or automatic framing: view = front | profile | close, or
    # azimuth = 30.0; elevation = 10.0; distance = 1.0   (degrees; multiple of the framing distance)
    # up = [0, 1, 0]; front = [0, 0, 1]                  (the model's up and facing axes: glTF's)

    [shapes.head]                 # one table per shape, its id after the dot
    type = "mesh"                 # mesh | generated | sphere | rectangle | cube
    file = "head.glb"             # relative to the scene file
    materials = { skin = "skin1", lips = "skin2" }   # per glTF material (or material = "skin1")

    [lights.key]                  # relative to the view: azimuth/elevation (degrees, from the camera's
    azimuth = 40.0                # direction), distance (bounding radii), size (radius in bounding
    elevation = 35.0              # radii; 0: a point light), intensity (E / pi at the model's centre)
    intensity = 1.0

Shapes: ``mesh`` (``file``, ``units``, ``material`` or ``materials``; SSS unless ``sss = false``;
one SSS shape per object of the file: :mod:`ssskit.scenes.meshes`), ``generated`` (``generator`` =
:data:`GENERATORS`, ``params``), ``sphere`` (``center``, ``radius``), ``rectangle`` / ``cube``
(``translate``, ``scale``: to_world = translate x scale). Lights: relative ones as above, or
explicit Mitsuba ones (``type = "point"``, ``position``, ``intensity``; ``type = "sphere"``,
``center``, ``radius``, ``radiance``). A relative light named key, fill or back takes each field it omits
from :data:`DEFAULT_LIGHTS`, one of another name from :data:`OTHER_LIGHT`; every light's numbers must be
finite, intensities and radiances not negative.

Framing (:func:`framing`): the camera looks at the centre of the bounding sphere (radius R) from
the view's direction at distance k * R / sin(fov_v / 2) * 1.1, fov_v the vertical field of view of
a 4:3 image (so the sphere fits with a 10% margin), k the view's distance factor.

Light intensity: a sphere light of radius a at distance d gives the irradiance E = pi L (a / d)^2
at the centre on a surface facing it (a uniformly bright sphere subtends a cap of sin^2 alpha =
(a/d)^2: [PJH23], ch. 4, radiometric integrals), a point light of
intensity I gives E = I / d^2; ``intensity`` = E / pi, the diffuse layer a white surface facing
the light at the centre would show.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import SceneError
from ..quantities import (LENGTH_MM, TYPE, Choice, Flag, Quantity, Rule, check_fields, check_instance, check_keys,
                          check_shape, checks, fail, refuse_twice, refuse_unused)
from ..io import read_document
from .meshes import FORMATS, UNITS_MM, Mesh, bounding_sphere, inspect_mesh_file, read_mesh, topology
from .scenes import IMAGE_SIZE, SCENES, SceneSpec, _T, _ply

#: the built-in scenes' files (each registered into SCENES under its stem)
BUILTIN_DIR = Path(__file__).parent / "builtin"
#: --view presets: (azimuth, elevation) in degrees from the model's front, distance factor
VIEWS: dict[str, tuple[float, float, float]] = {"front": (0.0, 0.0, 1.0), "profile": (90.0, 0.0, 1.0),
                                                "close": (20.0, 5.0, 0.45)}
#: the view's aliases (Xie 2020, Fig. 1: close, ear and front views)
VIEW_ALIASES = {"ear": "profile"}
#: the default lights of a mesh scene: key, fill, back (relative to the view)
DEFAULT_LIGHTS: dict[str, dict[str, float]] = {
    "key": {"azimuth": 50.0, "elevation": 40.0, "distance": 6.0, "size": 0.2, "intensity": 1.0},
    "fill": {"azimuth": -70.0, "elevation": 15.0, "distance": 6.0, "size": 0.4, "intensity": 0.3},
    "back": {"azimuth": 150.0, "elevation": 35.0, "distance": 6.0, "size": 0.2, "intensity": 0.5},
}
#: the omitted fields of a relative light named other than key, fill or back
OTHER_LIGHT: dict[str, float] = {"azimuth": 0.0, "elevation": 0.0, "distance": 4.0, "size": 0.15, "intensity": 1.0}
DEFAULT_FOV = 30.0
#: the model's axes when a scene names none: glTF's (+Y up, facing +Z)
DEFAULT_UP = (0.0, 1.0, 0.0)
DEFAULT_FRONT = (0.0, 0.0, 1.0)
#: the units a mesh file is read in when none are given: glTF's specification says metres; OBJ and PLY
#: carry none, and ssskit's length unit is the mm
DEFAULT_UNITS = {"gltf": "m", "obj": "mm", "ply": "mm"}
#: a plausible size of a translucent object (bounding-sphere diameter, mm), for the units hint
PLAUSIBLE_MM = (5.0, 3000.0)
#: the model sizes (bounding-sphere diameter, mm) a scene renders right: 200 nm to 1000 km. Below, Mitsuba's lighting
#: comes out too dark (measured on a sphere against the same sphere in mm: the mean diffuse 0.513 at 1 um and 200
#: nm, as in mm; 0.211 at 20 nm, 0.142 at 2 nm); beyond, its float32 fails (a 1e30 mm model's point light, ~1e61, overflows:
#: the trial's render of one gave Mitsuba's "Invalid sample value" and a frame with no SSS pixel)
MODEL_SIZE_MM = (2e-4, 1e9)
MODEL_SIZE = Quantity("model size", *MODEL_SIZE_MM, "mm", "200 nm to 1000 km: the renderer's lighting goes wrong "
                      "below, its float32 lights overflow far beyond")
#: the largest intensity or radiance a light may give Mitsuba: its float32 arithmetic overflows not far beyond
#: (3.4e38; a key light of intensity 1e36 rendered 64,000 "Invalid sample value" warnings and a NaN diffuse layer)
EMITTER_MAX = 1e30

#: the numbers of a scene file, each declared once (the readers below check every field by its quantity)
_ANY = dict(lo_open=True, hi_open=True)
ANGLE_DEG = Quantity("angle", -math.inf, math.inf, "degrees", "an angle about the model", **_ANY)
ELEVATION_DEG = Quantity("elevation", -90.0, 90.0, "degrees", "a view above or below the model, not along its up "
                         "axis", **_ANY)
VIEW_DISTANCE = Quantity("distance", 0.05, 100.0, "", "a multiple of the framing distance")
FOV_DEG = Quantity("fov", 1.0, 150.0, "degrees", "a horizontal field of view")
COORDINATE = Quantity("coordinate", -math.inf, math.inf, "", "a point or direction in the scene", **_ANY)
EMITTED = Quantity("intensity", 0.0, EMITTER_MAX, "", "the renderer's float32 arithmetic overflows not far beyond")


def _triple(q: Quantity) -> Rule:
    """Three numbers [x, y, z], each of quantity ``q`` (a point, a direction, a cube's scale)."""
    return Rule(q.name, lambda v, name, error: q.check_array(check_shape(v, name, (3,), error), name, error).tolist())


POINT = _triple(COORDINATE)
#: a primitive's fields (docs/meshes.md), in the scene's mm (a rectangle's are a cube's); a shape of no extent
#: holds no pixel (a sphere's radius, each of a cube's half-sides: its scale)
PRIMITIVE_FIELDS: dict[str, dict[str, Quantity | Rule]] = {
    "sphere": {"center": POINT, "radius": LENGTH_MM}, "cube": {"translate": POINT, "scale": _triple(LENGTH_MM)}}
#: a light placed relative to the framing (docs/meshes.md): its distance and size in bounding radii
RELATIVE_LIGHT: dict[str, Quantity] = {
    "azimuth": ANGLE_DEG, "elevation": ANGLE_DEG,
    "distance": Quantity("distance", 1.0, math.inf, "bounding radii", "a light outside the model's bounding sphere",
                         **_ANY),
    "size": Quantity("size", 0.0, math.inf, "bounding radii", "a light's radius; 0 is a point light", hi_open=True),
    "intensity": Quantity("intensity", 0.0, math.inf, "", "the irradiance at the model's centre over pi",
                          hi_open=True)}
#: the keys of an explicit Mitsuba light, by its type (each required)
EXPLICIT_KEYS = {"point": ("intensity", "position"), "sphere": ("center", "radiance", "radius")}
#: a scene file's numbers and flags at its top level, and their defaults
ORBIT = Quantity("orbit", -math.inf, math.inf, "degrees per frame", "the camera's or the lights' turn per frame",
                 **_ANY)
SCENE_FIELDS: dict[str, Quantity | Flag] = {"orbit_deg_per_frame": ORBIT, "light_orbit_deg_per_frame": ORBIT,
                                            "lit_from_behind": Flag("lit_from_behind")}
SCENE_DEFAULTS = {"orbit_deg_per_frame": 2.0, "light_orbit_deg_per_frame": 0.0, "lit_from_behind": False}
#: a shape's types (docs/meshes.md)
SHAPE_TYPE = Choice("type", ("mesh", "generated", "sphere", "rectangle", "cube"))
#: an explicit Mitsuba light's numbers (the ones that take one number or three [R, G, B]; the points take three)
EXPLICIT_LIGHT: dict[str, Quantity] = {
    "intensity": EMITTED, "radiance": EMITTED,
    "radius": Quantity("radius", 0.0, math.inf, "", "a sphere light's radius", **_ANY)}


def _generated(kind: str, params: Mapping[str, Any]) -> tuple[Mesh | None, dict | None]:
    """A generated shape: (Mesh, None) for the mesh generators, (None, Mitsuba dict) for the built-in
    scenes' own geometry (kept bit-identical to the dicts they always had)."""
    from . import generated, scenes

    try:
        if kind == "bust":
            (bust,) = read_mesh(generated.bust_path(**params))  # (the cached PLY's object, renamed)
            return Mesh("bust", bust.vertices, bust.faces, bust.normals), None
        if kind == "icosphere":
            return generated.icosphere(**params), None
        if kind == "torus":
            return generated.torus(**params), None
        if kind == "ellipsoid":
            args = {k: tuple(v) if isinstance(v, list) else v for k, v in params.items()}
            return None, _ply("ellipsoid", *scenes._ellipsoid_geometry(**args))
        if kind == "heightfield":
            return None, _ply("bumpy", *scenes._bumpy_geometry(**params))
        from .head import head_mesh  # the scanned head (ssskit.scenes.head), scaled to mm; closed once welded

        m = head_mesh(**params)  # (the last of GENERATOR's names)
        return None, _ply("head", m.vertices, m.faces, m.normals, face_normals=False)
    except TypeError as exc:
        raise SceneError(f"generator {kind!r}: {exc}") from None


#: the shape generators of scene files; the direct ones give the built-in scenes' Mitsuba dicts as they were
GENERATORS = ("bust", "icosphere", "torus", "ellipsoid", "heightfield", "head")
GENERATOR = Choice("generator", GENERATORS)
DIRECT_GENERATORS = ("ellipsoid", "heightfield", "head")


# ---- objects: meshes with their units and materials ----------------------------------------------------

@dataclass(frozen=True)
class MeshObject:
    """One SSS object of a mesh scene: its Mitsuba shape (mm), material ("" = the render's), the
    topology problem the reference would meet (or None), and its source."""

    id: str
    name: str
    shape: dict
    material: str
    problem: str | None
    digest: str


def _shape_id(name: str, taken: set[str]) -> str:
    base = re.sub(r"[^A-Za-z0-9_]", "_", name) or "object"
    if base[0].isdigit() or base.startswith("_"):
        base = "m" + base
    sid, k = base, 2
    while sid in taken:
        sid, k = f"{base}_{k}", k + 1
    taken.add(sid)
    return sid


def _unclaimed(unknown: set[str], source: str, names: Sequence[str]) -> None:
    """A SceneError if the material map names objects (``unknown``) the scene ``source`` does not have."""
    if unknown:
        raise SceneError(f"material map names {', '.join(map(repr, sorted(unknown)))}, which {source!r} does not "
                         f"have (its objects: {', '.join(names)})")


def _mesh_objects(meshes: Sequence[Mesh], scale_mm: float, materials: Mapping[str, str], default: str,
                  source: str, taken: set[str], deferred: list[Callable[[], None]]) -> list[MeshObject]:
    names = [m.name for m in meshes]
    _unclaimed(set(materials) - set(names), source, names)
    out = []
    for m in meshes:
        topo = topology(m)
        if topo.closed and topo.misoriented_edges == 0 and topo.volume < 0:
            m = m.flipped()  # wound inside out: the medium goes inside
            topo = topology(m)
        mm = m.scaled(scale_mm)
        shape = _ply(f"mesh-{re.sub(r'[^A-Za-z0-9_]', '_', m.name)}", mm.vertices, mm.faces, mm.normals,
                     face_normals=False, deferred=deferred)
        out.append(MeshObject(_shape_id(m.name, taken), m.name, shape, materials.get(m.name, default),
                              topo.reference_problem(f"{source}:{m.name}" if len(meshes) > 1 else source),
                              mm.digest()))
    return out


# ---- units ---------------------------------------------------------------------------------------------

#: a mesh file's units (--units, a scene file's or a shape's ``units``)
UNITS = Choice("units", tuple(UNITS_MM))


def check_units(units: str | Sequence[str] | None, *given: tuple[str, Any]) -> str | None:
    """One unit name of :data:`UNITS_MM`, or None: ``units`` (``--units``, given once or several times) and the
    ``(where, value)`` pairs of a scene file's or a shape's ``units`` must name one unit; a SceneError for an
    unknown unit, or for two that disagree (refuse_twice)."""
    named = [("--units", u) for u in ([] if units is None else [units] if isinstance(units, str) else units)]
    named = [(w, UNITS.check(u, w, SceneError)) for w, u in named + [(w, v) for w, v in given if v is not None]]
    for (w1, u1), (w2, u2) in zip(named, named[1:]):
        if u1 != u2:
            refuse_twice(f"{w1} {u1}", f"{w2} {u2}", "the units", SceneError)
    return named[0][1] if named else None


def _units_note(source: str, unit: str, assumed: bool, diameter_mm: float) -> str:
    text = (f"{source}: {'assumed ' if assumed else ''}units {unit}"
            + (" (no --units given)" if assumed else "") + f"; the model is {diameter_mm:.4g} mm across "
            "(bounding-sphere diameter)")
    lo, hi = PLAUSIBLE_MM
    if assumed and not lo <= diameter_mm <= hi:
        scale = UNITS_MM[unit]
        fits = [u for u, f in UNITS_MM.items() if lo <= diameter_mm / scale * f <= hi]
        if fits:
            text += f"; if it is in {fits[0]}, give --units {fits[0]} ({diameter_mm / scale * UNITS_MM[fits[0]]:.4g} mm)"
    return text


# ---- views and lights ----------------------------------------------------------------------------------

def parse_view(view: str | Sequence[float] | None) -> tuple[float, float, float]:
    """(azimuth deg, elevation deg, distance factor) of a ``--view``: a preset of :data:`VIEWS` (or
    ``ear`` = ``profile``), ``"AZ,EL[,DIST]"`` or a sequence of 2 or 3 numbers."""
    if view is None:
        return VIEWS["front"]
    if isinstance(view, str):
        key = VIEW_ALIASES.get(view.strip().lower(), view.strip().lower())
        if key in VIEWS:
            return VIEWS[key]
    try:
        nums = [float(x) for x in (view.split(",") if isinstance(view, str) else view)]
    except (TypeError, ValueError):
        nums = []  # neither a preset nor numbers: refused below
    if len(nums) not in (2, 3):
        raise fail(SceneError, TYPE, name="view", kind=f"a preset ({', '.join([*VIEWS, *VIEW_ALIASES])}) or "
                   "AZIMUTH,ELEVATION[,DISTANCE] (degrees, degrees, a multiple of the framing distance)",
                   actual=repr(view))
    return (ANGLE_DEG.check(nums[0], "view azimuth", SceneError), ELEVATION_DEG.check(nums[1], "view elevation",
            SceneError), VIEW_DISTANCE.check(nums[2] if len(nums) == 3 else 1.0, "view distance", SceneError))


def _basis(up: Sequence[float], front: Sequence[float], where: str = "camera", front_name: str = "front",
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The camera's rule (its up and its front or view direction non-zero and not parallel) and its basis."""
    u, f = (np.asarray(_point(f"{where} {key}", v)) for key, v in (("up", up), (front_name, front)))
    if not np.linalg.norm(np.cross(u, f)) > 1e-9 * np.linalg.norm(u) * np.linalg.norm(f):
        raise SceneError(f"{where} up {up!r} and {front_name} {front!r} must be non-zero and not parallel")
    u = u / np.linalg.norm(u)
    f = f - u * (u @ f)
    f /= np.linalg.norm(f)
    return u, f, np.cross(u, f)  # up, front, side (+X for glTF's axes)


def direction(azimuth: float, elevation: float, up: Sequence[float], front: Sequence[float]) -> np.ndarray:
    """Unit vector from the model towards a viewer at ``azimuth`` (degrees about ``up``, from
    ``front`` towards the side front x up... i.e. +X for +Y up and +Z front) and ``elevation``."""
    u, f, s = _basis(up, front)
    a, e = math.radians(azimuth), math.radians(elevation)
    return math.cos(e) * (math.cos(a) * f + math.sin(a) * s) + math.sin(e) * u


def framing(centre: ArrayLike, radius: float, view: tuple[float, float, float], fov_x_deg: float, up: Sequence[float],
            front: Sequence[float]) -> np.ndarray:
    """The camera origin (module docstring, "Framing") looking at ``centre``."""
    fov_v = 2.0 * math.atan(math.tan(math.radians(fov_x_deg) / 2.0) * 0.75)
    d = view[2] * radius / math.sin(fov_v / 2.0) * 1.1
    return np.asarray(centre, float) + d * direction(view[0], view[1], up, front)


def _relative_light(name: str, spec: Mapping[str, Any], centre: np.ndarray, radius: float, cam_dir_az: float,
                    cam_el: float, up: Sequence[float], front: Sequence[float]) -> dict[str, Any]:
    check_keys(spec, f"light {name!r}", RELATIVE_LIGHT, error=SceneError)  # or type = point | sphere: explicit
    # an omitted field: the named default light's (key, fill, back: docs/meshes.md), else OTHER_LIGHT's
    spec = check_fields({**DEFAULT_LIGHTS.get(name, OTHER_LIGHT), **spec}, RELATIVE_LIGHT, f"light {name!r}", SceneError)
    d, size, inten = spec["distance"], spec["size"], spec["intensity"]
    replace(RELATIVE_LIGHT["size"], hi=d - 1.0, reason="the light stays outside the model's bounding sphere").check(
        size, f"light {name!r}: size", SceneError)
    el = float(np.clip(cam_el + float(spec["elevation"]), -89.0, 89.0))
    pos = centre + d * radius * direction(cam_dir_az + float(spec["azimuth"]), el, up, front)
    e = math.pi * inten  # irradiance at the centre (intensity = E / pi)
    if size == 0:
        value = _emitter_value(name, "intensity", e * (d * radius) ** 2, "pi intensity x (distance x R)^2")
        return {"type": "point", "position": pos.tolist(), "intensity": {"type": "rgb", "value": value}}  # E = I / d^2
    a = size * radius
    value = _emitter_value(name, "radiance", e / (math.pi * (a / (d * radius)) ** 2), "intensity x (distance / size)^2")
    return {"type": "sphere", "center": pos.tolist(), "radius": a,
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": value}}}


def _emitter_value(name: str, key: str, value: float, how: str) -> float:
    """``value`` if it is at most :data:`EMITTER_MAX`, else a SceneError naming the light (before any work: lower
    the intensity or raise the size)."""
    return float(EMITTED.check(value, f"light {name!r}: its {key} ({how})", SceneError))


def _point(where: str, value: Any) -> list[float]:
    """Three finite numbers [x, y, z] (a position, a direction), or a SceneError naming ``where``."""
    return POINT.check(value, where, SceneError)


def _explicit_light(name: str, spec: Mapping[str, Any]) -> dict:
    where = f"light {name!r}"
    kind = Choice("type", EXPLICIT_KEYS).check(spec.get("type"), f"{where}: type", SceneError)
    check_keys(spec, where, {"type", *EXPLICIT_KEYS[kind]}, EXPLICIT_KEYS[kind], SceneError)
    out = check_fields(spec, EXPLICIT_LIGHT, where, SceneError, rgb=("intensity", "radiance"))
    if kind == "point":
        return {"type": "point", "position": _point(f"{where}: position", spec["position"]),
                "intensity": {"type": "rgb", "value": spec["intensity"]}}
    return {"type": "sphere", "center": _point(f"{where}: center", spec["center"]), "radius": out["radius"],
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": spec["radiance"]}}}


def _keys(where: str, table: Mapping[str, Any], allowed: set[str], required: set[str] = frozenset()) -> None:  # type: ignore[assignment]
    check_keys(table, where, allowed, sorted(required), SceneError)


# ---- the loader ----------------------------------------------------------------------------------------

@dataclass(frozen=True)
class LoadedScene:
    """A scene file's or mesh's :class:`SceneSpec` and what loading it found out: ``notes`` (the units
    assumed and the model's size, meshes turned inside out) and each mesh object."""

    spec: SceneSpec
    notes: tuple[str, ...] = ()
    objects: tuple[MeshObject, ...] = ()
    framed: bool = False  # the camera came from the automatic framing (a --view may change it)
    document: dict = field(default_factory=dict)
    base: Path | None = None


def load_scene_file(path: str | os.PathLike[str], **options: Any) -> LoadedScene:
    """Read a TOML scene file (module docstring) into a :class:`LoadedScene`; ``options`` as for
    :func:`scene_from_document`."""
    p = Path(path)
    doc = read_document(p, "scene file", SceneError)  # (io: every input file's rules)
    doc.setdefault("name", p.stem)
    return scene_from_document(doc, base=p.parent, source=str(p), **options)


@checks(SceneError, **IMAGE_SIZE)
def scene_from_document(doc: Mapping[str, Any], base: Path | None = None, source: str = "scene", *,
                        units: str | Sequence[str] | None = None, material_map: Mapping[str, str] | None = None,
                        view: str | Sequence[float] | None = None, width: int = 256, height: int = 192,
                        default_material: str = "") -> LoadedScene:
    """A :class:`LoadedScene` from a parsed scene document.

    ``units``: the mesh files' units (``--units``; a SceneError if it conflicts with the document's
    or is given twice differently); ``material_map``: object or glTF material name -> ssskit
    material (``--material-map``; every name must be an object of the scene); ``view``: overrides
    the document's view (automatic framing only); ``width`` x ``height``: the image size the memory
    check (:func:`ssskit.scenes.meshes.check_render_memory`) is made for.
    """
    _keys(source, doc, {"name", "description", "units", "camera", "shapes", "lights", "orbit_deg_per_frame",
                        "light_orbit_deg_per_frame", "lit_from_behind", "views"}, {"shapes"})
    top = {**SCENE_DEFAULTS, **check_fields(doc, SCENE_FIELDS, source, SceneError)}  # (orbit = "x" was a ValueError)
    cli_units = check_units(units)
    doc_units = check_units(cli_units, (f"{source}: units", doc.get("units")))
    material_map = dict(material_map or {})
    for section in ("camera", "shapes", "lights", "views"):  # the file's tables (camera = 5 was a TypeError)
        check_keys(doc.get(section, {}), f"{source}: [{section}]", error=SceneError)
    shapes_doc = doc["shapes"]  # (none: no SSS shape, below)
    notes: list[str] = []
    shapes: dict[str, dict] = {}
    sss: list[str] = []
    sss_materials: list[str] = []
    objects: list[MeshObject] = []
    problems: list[str] = []
    deferred: list[Callable[[], None]] = []  # the meshes' cache files, written once every check has passed
    mesh_vertices: list[np.ndarray] = []
    about: dict[str, Any] = {}
    taken: set[str] = set()
    claimed: set[str] = set()
    for sid, table in shapes_doc.items():
        where = f"{source}: shape {sid!r}"
        kind = SHAPE_TYPE.check(check_keys(table, where, error=SceneError).get("type"), f"{where}: type", SceneError)
        is_sss = Flag("sss").check(table.get("sss", kind in ("mesh", "generated")), f"{where}: sss", SceneError)
        check_instance(table.get("material", ""), str, f"{where}: material", SceneError)
        meshes: tuple[Mesh, ...] | None = None
        if kind == "mesh":
            _keys(where, table, {"type", "file", "units", "material", "materials", "sss"}, {"file"})
            fpath = Path(check_instance(table["file"], str, f"{where}: file", SceneError))
            if base is not None and not fpath.is_absolute():
                fpath = base / fpath
            inspect_mesh_file(fpath, width, height)
            unit = check_units(cli_units, (f"{where}: units", table.get("units"))) or doc_units
            assumed = unit is None
            unit = unit or DEFAULT_UNITS[FORMATS[fpath.suffix.lower()]]
            meshes = read_mesh(fpath)
            label = str(table["file"])
        elif kind == "generated":
            _keys(where, table, {"type", "generator", "params", "material", "materials", "sss"}, {"generator"})
            gen = GENERATOR.check(table["generator"], f"{where}: generator", SceneError)
            params = dict(check_keys(table.get("params", {}), f"{where}: params", error=SceneError))
            if gen == "head":  # the scan's scale and the credit its licence asks for (ssskit.scenes.head)
                from .head import ATTRIBUTION, HEAD_SCALE, LICENCE, MM_PER_UNIT

                check_keys(params, f"{where}: the head generator's params", {"mm_per_unit"}, error=SceneError)
                head_scale = HEAD_SCALE.check(params.get("mm_per_unit", MM_PER_UNIT), "head mm_per_unit", SceneError)
                about.update({"attribution": ATTRIBUTION, "licence": LICENCE, "mm_per_unit": head_scale,
                              "scale_evidence": "docs/head.md, Scale"})
            if gen in DIRECT_GENERATORS:  # the built-in scenes' geometry, made when the scene is rendered
                shapes[sid] = {"__thunk": (gen, params)}
                taken.add(sid)
                if is_sss:
                    sss.append(sid)
                    sss_materials.append(_shape_material(sid, table, material_map, claimed))
                continue
            mesh, _ = _generated(gen, params)
            meshes = (mesh,)  # type: ignore[assignment]
            unit, assumed, label = "mm", False, str(table["generator"])
        else:
            shapes[sid] = _primitive(where, kind, table)
            taken.add(sid)
            if is_sss:
                sss.append(sid)
                sss_materials.append(_shape_material(sid, table, material_map, claimed))
            continue
        assert meshes is not None
        # a one-object file named by its stem (OBJ, PLY) or a generator takes the shape's id; glTF objects keep their
        # materials' names, one material or several (docs/meshes.md: --material-map skin=skin1 names it)
        by_material = kind == "mesh" and FORMATS[fpath.suffix.lower()] == "gltf"
        if len(meshes) == 1 and meshes[0].name != sid and not by_material:
            meshes = (Mesh(sid, meshes[0].vertices, meshes[0].faces, meshes[0].normals),)
            own = {sid: material_map[sid]} if sid in material_map else {}
        else:
            own = {m.name: material_map[m.name] for m in meshes if m.name in material_map}
        if "materials" in table:
            check_keys(table["materials"], f"{where}: materials (object name -> material)", error=SceneError)
            own = {**{str(k): str(v) for k, v in table["materials"].items()}, **own}
        claimed.update(own)
        scale = UNITS_MM[unit]
        objs = _mesh_objects(meshes, scale, own, str(table.get("material", "")), label, taken, deferred)
        centre, r = bounding_sphere(meshes, scale)
        MODEL_SIZE.check(2 * r, f"{label}: the model's bounding-sphere diameter (units {unit})", SceneError)
        if kind == "mesh":
            notes.append(_units_note(label, unit, assumed, 2 * r))
        for o in objs:
            shapes[o.id] = o.shape
            if is_sss:
                sss.append(o.id)
                sss_materials.append(o.material)
                if o.problem:
                    problems.append(o.problem)
        objects.extend(objs)
        mesh_vertices.extend(m.vertices.astype(np.float64) * scale for m in meshes)
    _unclaimed(set(material_map) - claimed, source,
               [o.name for o in objects] + [s for s in shapes if s not in {o.id for o in objects}])
    if not sss:
        raise SceneError(f"{source}: no shape is an SSS object (sss = true)")
    if default_material:
        sss_materials = [m or default_material for m in sss_materials]
    cam = dict(doc.get("camera", {}))
    explicit = "origin" in cam
    if explicit:
        if view is not None:
            raise SceneError(f"--view needs automatic framing, but {source} places its camera (origin, target)")
        origin, target, up, fov = _camera(f"{source}: [camera]", cam)
    else:
        _keys(f"{source}: [camera]", cam, {"view", "azimuth", "elevation", "distance", "fov", "up", "front"})
        if view is None and "view" in cam:
            view = cam["view"]
        elif view is None and ("azimuth" in cam or "elevation" in cam):
            view = (cam.get("azimuth", 0.0), cam.get("elevation", 0.0), cam.get("distance", 1.0))
        vw = parse_view(view)
        up_v = cam.get("up", DEFAULT_UP)
        front = cam.get("front", DEFAULT_FRONT)
        fov = FOV_DEG.check(cam.get("fov", DEFAULT_FOV), f"{source}: camera fov", SceneError)
        if not mesh_vertices:
            raise SceneError(f"{source}: automatic framing needs a mesh or generated shape; give camera origin, "
                             "target, up and fov")
        allv = np.concatenate(mesh_vertices)
        centre = 0.5 * (allv.min(axis=0) + allv.max(axis=0))
        radius = float(np.linalg.norm(allv - centre, axis=1).max())
        origin = tuple(framing(centre, radius, vw, fov, up_v, front).tolist())
        target = tuple(centre.tolist())
        up = tuple(_basis(up_v, front)[0].tolist())
    if explicit and "lights" not in doc:  # (the default lights are relative to the automatic framing)
        raise SceneError(f"{source}: a scene with an explicit camera needs explicit [lights]")
    lights: dict[str, dict] = {}
    for lid, ltable in doc.get("lights", DEFAULT_LIGHTS).items():  # (no [lights]: the relative key, fill and back)
        if "type" in check_keys(ltable, f"{source}: light {lid!r}", error=SceneError):
            lights[lid] = _explicit_light(lid, ltable)
        elif explicit:  # an explicit camera takes explicit lights only
            raise SceneError(f"{source}: light {lid!r} is placed relative to the automatic framing, but the "
                             "camera is explicit; give type = point | sphere")
        else:
            lights[lid] = _relative_light(lid, ltable, centre, radius, vw[0], vw[1], up_v, front)
    views = _named_views(source, doc.get("views", {}), explicit)
    desc = str(doc.get("description", f"meshes from {source}"))
    spec = SceneSpec(str(doc.get("name", source)), desc, origin, target, up, float(fov),
                     _frozen_dicts(shapes), tuple(sss), _frozen_dicts(lights),
                     orbit_deg_per_frame=top["orbit_deg_per_frame"],
                     light_orbit_deg_per_frame=top["light_orbit_deg_per_frame"],
                     sss_materials=tuple(sss_materials) if any(sss_materials) else (),
                     reference_problem="; ".join(problems) or None,
                     lit_from_behind=top["lit_from_behind"],
                     about=tuple(about.items()), views=views)
    from ..materials import get_material

    for mat in {m for m in sss_materials if m}:  # every material exists before a mesh's cache file is written
        get_material(mat)
    for write in deferred:
        write()
    return LoadedScene(spec, tuple(notes), tuple(objects), not explicit, dict(doc), base)


def _named_views(source: str, table: Any, explicit: bool) -> tuple[tuple[str, tuple], ...]:
    """A scene's named cameras (``[views.NAME]``: origin, target, up, fov, as an explicit [camera]): what
    ``--view NAME`` picks for that scene; only beside an explicit camera."""
    if table and not explicit:  # (a table: scene_from_document)
        raise SceneError(f"{source}: named [views] need an explicit [camera] (origin, target, up, fov)")
    return tuple((str(name).lower(), _camera(f"{source}: view {name!r}", cam)) for name, cam in table.items())


def _camera(where: str, cam: Any) -> tuple[tuple, tuple, tuple, float]:
    """An explicit camera (``[camera]`` with an origin, or a ``[views.NAME]``): its origin, target and up (points,
    world mm) and its horizontal fov (degrees), each checked."""
    _keys(where, cam, {"origin", "target", "up", "fov"}, {"origin", "target", "up", "fov"})
    origin, target, up = (tuple(_point(f"{where}: {key}", cam[key])) for key in ("origin", "target", "up"))
    _basis(up, tuple(np.subtract(target, origin).tolist()), f"{where}:", "view direction (target - origin)")
    return origin, target, up, float(FOV_DEG.check(cam["fov"], f"{where}: fov", SceneError))


def _shape_material(sid: str, table: Mapping[str, Any], material_map: Mapping[str, str], claimed: set[str]) -> str:
    """The material of a one-object SSS shape (a primitive or a built-in generator's): the material map's entry
    for its id (claimed) over the shape's ``material`` ("" = the render's)."""
    if sid in material_map:
        claimed.add(sid)
        return str(material_map[sid])
    return str(table.get("material", ""))


def _frozen_dicts(d: dict[str, dict]) -> Callable[[], dict[str, dict]]:
    """A callable returning fresh copies of Mitsuba dicts (``to_world`` transforms are built at call
    time: Mitsuba is imported only when a scene is rendered)."""
    import copy

    def make() -> dict[str, dict]:
        out = {}
        for k, v in d.items():
            if "__thunk" in v:
                direct = _generated(*v["__thunk"])[1]
                assert direct is not None  # a DIRECT_GENERATORS entry
                out[k] = direct
                continue
            entry = copy.deepcopy({kk: vv for kk, vv in v.items() if kk != "__to_world"})
            if "__to_world" in v:
                t, s = v["__to_world"]
                entry["to_world"] = _T()().translate(t) @ _T()().scale(s)
            out[k] = entry
        return out

    return make


def _primitive(where: str, kind: Any, table: Mapping[str, Any]) -> dict:
    fields = PRIMITIVE_FIELDS["sphere" if kind == "sphere" else "cube"]
    _keys(where, table, {"type", "sss", "material", *fields}, set(fields) if kind == "sphere" else set())
    out = check_fields(table, fields, where, SceneError)
    if kind == "sphere":
        return {"type": "sphere", **out}
    entry: dict[str, Any] = {"type": kind}  # a rectangle or a cube (the shape types: SHAPE_TYPE)
    if out:
        entry["__to_world"] = (out.get("translate", [0, 0, 0]), out.get("scale", [1, 1, 1]))
    return entry


# ---- the built-in scenes -------------------------------------------------------------------------------

def builtin_scene_files() -> list[Path]:
    """The built-in scenes' TOML files, in registration order."""
    order = ("sphere", "slab", "ear", "bumpy", "backlit", "leaf", "head")
    return [BUILTIN_DIR / f"{name}.toml" for name in order]


def _register_builtins() -> None:
    for path in builtin_scene_files():
        SCENES.register(path.stem, load_scene_file(path).spec)


_register_builtins()


# ---- --scene values ------------------------------------------------------------------------------------

#: meshes made in code that --scene accepts by name (the bust, and the test shapes)
GENERATED_SCENES: dict[str, dict[str, Any]] = {"bust": {"generator": "bust"},
                    "icosphere": {"generator": "icosphere", "params": {"subdivisions": 4, "radius": 40.0}},
                    "torus": {"generator": "torus", "params": {"major": 40.0, "minor": 14.0, "n_major": 96,
                                                                 "n_minor": 48}}}


#: the suffixes of the files --scene takes: a mesh, a scene file, a G-buffer
SCENE_FORMAT = Choice("format", (*FORMATS, ".toml", ".exr"))
#: what a --scene value is (:func:`resolve_scene`), in its messages
SCENE_KINDS = {"generated": "a generated mesh", "mesh": "a mesh file", "file": "a scene .toml",
               "views": "a built-in scene with named views"}
#: the --scene kinds each scene option applies to; given with another, it is refused (refuse_unused)
SCENE_OPTIONS = {"--units": ("mesh", "file"), "--material-map": ("generated", "mesh", "file"),
                 "--view": ("generated", "mesh", "file", "views")}


@dataclass(frozen=True)
class ResolvedScene:
    """What a ``--scene`` value names: ``kind`` ``builtin`` | ``generated`` | ``mesh`` | ``file`` (a scene
    TOML) with its ``spec``, or ``gbuffer`` with its ``path``; ``notes``: what loading assumed."""

    kind: str
    label: str
    spec: SceneSpec | None = None
    path: Path | None = None
    notes: tuple[str, ...] = ()
    objects: tuple[MeshObject, ...] = ()

    @property
    def materials(self) -> tuple[str, ...]:
        """The scene's own material per SSS object ("" = the render's); empty for a G-buffer."""
        if self.spec is None:
            return ()
        return self.spec.sss_materials or ("",) * len(self.spec.sss_shapes)


def parse_material_map(text: str | Mapping[str, str] | None) -> dict[str, str]:
    """``name=material,name=material`` (``--material-map``) as a dict; a SceneError if malformed or a
    name appears twice. Materials are checked by :func:`resolve_scene`."""
    if text is None:
        return {}
    if isinstance(text, Mapping):
        return {str(k): str(v) for k, v in text.items()}
    out: dict[str, str] = {}
    for item in filter(None, (s.strip() for s in str(text).split(","))):
        name, sep, mat = item.partition("=")
        if not sep or not name.strip() or not mat.strip():
            raise SceneError(f"material map entry {item!r} is not NAME=MATERIAL")
        if name.strip() in out:
            raise SceneError(f"material map names {name.strip()!r} twice")
        out[name.strip()] = mat.strip()
    return out


def with_view(spec: SceneSpec, view: Any) -> SceneSpec:
    """``spec`` seen from its named view ``view`` (``[views.NAME]`` of its scene file; ``ear`` is also
    ``profile``); a SceneError naming the scene's views otherwise."""
    import dataclasses

    names = dict(spec.views)
    key = view.strip().lower() if isinstance(view, str) else view
    if isinstance(key, str) and key not in names:
        key = {v: k for k, v in VIEW_ALIASES.items()}.get(key, key)
    key = Choice("view", tuple(names)).check(key, f"--view of the built-in scene {spec.name!r}", SceneError)
    origin, target, up, fov = names[key]
    return dataclasses.replace(spec, origin=origin, target=target, up=up, fov_x_deg=fov)


def unknown_scene_message(name: str) -> str:
    """The error of a ``--scene`` value that names no scene: every name it could be and the files it takes."""
    return (f"unknown scene {name!r} (built-in: {', '.join(SCENES.names())}; generated meshes: "
            f"{', '.join(GENERATED_SCENES)}; or a file: a mesh {', '.join(FORMATS)}, a scene .toml or a G-buffer .exr)")


def resolve_scene(value: Any, *, units: str | Sequence[str] | None = None,
                  material_map: str | Mapping[str, str] | None = None, view: str | Sequence[float] | None = None,
                  width: int = 256, height: int = 192) -> ResolvedScene:
    """Turn a ``--scene`` value into what the pipeline renders, checking everything first (no render):

    * a built-in scene name (:data:`SCENES`): its spec (``units``, ``material_map`` and ``view`` do not
      apply to its fixed camera and primitives: an error if given);
    * a generated mesh name (:data:`GENERATED_SCENES`: ``bust``, ``icosphere``, ``torus``) or a mesh file
      (:data:`~ssskit.scenes.meshes.FORMATS`): a mesh scene, framed from the bounding sphere by
      ``view``, with the default key, fill and back lights;
    * a ``.toml`` scene file: its scene (``units``, ``material_map``, ``view`` as overrides);
    * a ``.exr`` file: a G-buffer (``kind="gbuffer"``; the other options do not apply).

    Every material named by the map or the scene must exist (:func:`ssskit.materials.get_material`, checked by
    :func:`scene_from_document` before any mesh is cached).
    """
    mmap = parse_material_map(material_map)
    cli_units = check_units(units)
    if isinstance(value, SceneSpec):
        return ResolvedScene("builtin", value.name, spec=value)
    text = os.fspath(check_instance(value, (str, os.PathLike), "scene", SceneError))  # (a name or a file)
    suffix = Path(text).suffix.lower()

    if text in SCENES:
        spec = SCENES.get(text)
        kind = "views" if spec.views else "builtin"
        what = "a built-in scene" if spec.views else "a built-in scene: fixed camera and primitives"
    elif suffix == ".exr":
        kind, what = "gbuffer", "a G-buffer file"
    elif text.strip().lower() in GENERATED_SCENES:
        kind, what = "generated", "a generated mesh, made in mm"
    elif suffix in FORMATS or suffix == ".toml":
        kind, what = ("mesh", "a mesh file") if suffix in FORMATS else ("file", "a scene .toml")
    else:  # neither a scene's name nor a file of a format it takes
        if Path(text).suffix or os.sep in text or Path(text).exists():
            SCENE_FORMAT.check(suffix or "(no suffix)", f"scene {text!r}: its format", SceneError)
        raise SceneError(unknown_scene_message(text))
    for flag, given in (("--units", cli_units), ("--material-map", mmap), ("--view", view)):
        if given and kind not in SCENE_OPTIONS[flag]:
            refuse_unused([flag], "--scene", [SCENE_KINDS[k] for k in SCENE_OPTIONS[flag]], f"{text!r} ({what})",
                          SceneError)
    if kind in ("builtin", "views"):
        return ResolvedScene("builtin", spec.name, spec=spec if view is None else with_view(spec, view))
    if kind == "gbuffer":
        return ResolvedScene("gbuffer", Path(text).name, path=Path(text))
    if kind == "generated":
        name = text.strip().lower()
        doc = {"name": name, "description": f"the generated {name} (mm)",
               "shapes": {name: {"type": "generated", **GENERATED_SCENES[name]}}}
        loaded = scene_from_document(doc, None, name, material_map=mmap, view=view, width=width, height=height)
    elif kind == "mesh":
        p = Path(text)
        doc = {"name": p.stem, "description": f"the mesh {p.name}", "shapes": {p.stem: {"type": "mesh", "file": text}}}
        loaded = scene_from_document(doc, None, text, units=cli_units, material_map=mmap, view=view, width=width,
                                     height=height)
    else:
        loaded = load_scene_file(text, units=cli_units, material_map=mmap, view=view, width=width, height=height)
    return ResolvedScene(kind, loaded.spec.name, spec=loaded.spec, notes=loaded.notes, objects=loaded.objects)


__all__ = ["BUILTIN_DIR", "DEFAULT_LIGHTS", "GENERATED_SCENES", "GENERATORS", "LoadedScene", "MeshObject",
           "OTHER_LIGHT", "ResolvedScene", "UNITS", "VIEWS", "builtin_scene_files", "check_units", "direction",
           "framing", "load_scene_file", "parse_material_map", "parse_view", "resolve_scene", "scene_from_document",
           "unknown_scene_message", "with_view"]
