"""Triangle meshes from files: reading (OBJ through Mitsuba 3, PLY and glTF ``.glb``/``.gltf`` through
trimesh), the checks a mesh passes before anything is rendered, and writers for the four formats.

What is checked, and when (all before any rendering; :func:`inspect_mesh_file` runs the cheap ones
without loading the mesh):

* the file: missing, a directory, a FIFO, empty, a suffix that is none of :data:`FORMATS`;
* its size: the vertex and face counts read from the file's header (PLY, glTF) or counted (OBJ
  lines), and the memory a render of them at the asked image size would take
  (:func:`memory_estimate`) against the memory available (:func:`check_render_memory`);
* its data (:func:`check_mesh`): no faces, NaN or infinite vertex positions, face indices out of
  range;
* its topology (:func:`topology`): edges with one face (an open mesh), edges with more than two
  (non-manifold), neighbouring faces wound against each other, the signed volume. The screen-space
  passes take any mesh; the path-traced reference needs a closed, consistently wound one
  (:meth:`Topology.reference_problem` says what does not hold).

A file is one object (OBJ, PLY: Mitsuba merges an OBJ's groups into one mesh) named by its stem, or
one object per glTF material (the primitives of all nodes that share a material, with the nodes'
transforms applied), named by the material. Coordinates are in the file's units; the scene applies
``--units`` (:data:`UNITS_MM`). glTF is in metres by its specification; OBJ and PLY carry no unit.
"""

from __future__ import annotations

import hashlib
import os
import struct
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import SceneError, SsskitError
from ..quantities import FINITE, Quantity, check_finite, check_instance, check_shape, fail
from ..io import atomic_output, check_suffix, parse_document, read_input

#: mesh file suffixes and the reader of each
FORMATS = {".obj": "obj", ".ply": "ply", ".glb": "gltf", ".gltf": "gltf"}
#: the bytes a mesh file of a suffix begins with, and its format's name (the text formats OBJ and glTF have none)
MAGIC = {".ply": (b"ply", "PLY"), ".glb": (b"glTF", "binary glTF")}
#: millimetres per unit of a mesh file (ssskit's length unit is the mm: materials are in mm^-1)
UNITS_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0}
#: peak bytes per triangle of loading, checking and ray tracing a mesh: Mitsuba's scene with its BVH
#: (87 B per face measured for a 327,680-face icosphere, scalar_rgb), the checks' welded edge arrays
#: (3 edges x 2 int64 keys + sorting, ~150 B) and the reader's copies (trimesh's float64 arrays for glTF)
BYTES_PER_FACE = 400
#: peak bytes per image pixel of one frame: G-buffer layers, the three Mitsuba renders, the passes'
#: float32/float64 images and the reference's accumulators
BYTES_PER_PIXEL = 512


@dataclass(frozen=True, eq=False)
class Mesh:
    """One object: ``vertices`` (V, 3) float32 in the file's units, ``faces`` (F, 3) uint32 indices,
    ``normals`` (V, 3) float32 unit vertex normals or None (the renderer then computes smooth ones)."""

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None = None

    def __post_init__(self) -> None:
        where = f"mesh {self.name!r}"
        v = np.ascontiguousarray(check_shape(self.vertices, f"{where}: vertices", ("V", 3), SceneError), np.float32)
        f = np.ascontiguousarray(check_shape(self.faces, f"{where}: faces", ("F", 3), SceneError), dtype=np.int64)
        if f.size and (f.min() < 0 or f.max() >= len(v)):  # an index beyond the vertices crashed Mitsuba's PLY loader
            Quantity("face indices", 0, len(v) - 1, "", "the indices of the mesh's vertices", integer=True).check_array(
                f, f"{where}: face indices", SceneError, "indices")
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "faces", f.astype(np.uint32))
        if self.normals is not None:
            object.__setattr__(self, "normals", np.ascontiguousarray(check_shape(
                self.normals, f"{where}: normals", v.shape, SceneError), dtype=np.float32))

    def digest(self) -> str:
        """sha1 of the arrays (the reference cache's key for this geometry)."""
        h = hashlib.sha1(self.vertices.tobytes() + self.faces.tobytes())
        if self.normals is not None:
            h.update(self.normals.tobytes())
        return h.hexdigest()

    def scaled(self, factor: float) -> "Mesh":
        """The mesh with its vertices multiplied by ``factor`` (normals unchanged)."""
        return Mesh(self.name, self.vertices * np.float32(factor), self.faces, self.normals)

    def flipped(self) -> "Mesh":
        """The faces wound the other way and the normals reversed (inside out)."""
        n = None if self.normals is None else -self.normals
        return Mesh(self.name, self.vertices, self.faces[:, ::-1], n)


@dataclass(frozen=True)
class Topology:
    """Edge statistics of a mesh after welding equal vertex positions.

    ``boundary_edges``: edges of one face (an open mesh has some); ``nonmanifold_edges``: edges of
    more than two faces; ``misoriented_edges``: edges whose two faces run along it the same way
    (wound against each other); ``volume``: the signed volume enclosed, V = 1/6 sum over faces of
    v0 . (v1 x v2) (the divergence theorem over the triangles; positive when the faces wind
    counter-clockwise seen from outside, meaningful only for a closed mesh).
    """

    vertices: int
    faces: int
    boundary_edges: int
    nonmanifold_edges: int
    misoriented_edges: int
    volume: float

    @property
    def closed(self) -> bool:
        return self.boundary_edges == 0 and self.nonmanifold_edges == 0

    def reference_problem(self, name: str) -> str | None:
        """Why the path-traced reference cannot take this mesh as a medium's boundary, or None.

        The reference puts the medium inside the surface (Mitsuba's interior medium, entered through
        a face against its normal): a hole lets paths leave the medium without crossing the boundary,
        a non-manifold edge or a face wound against its neighbours makes inside and outside ambiguous.
        """
        if self.boundary_edges:
            return (f"mesh {name!r} is open ({self.boundary_edges} edges with one face): the path-traced reference "
                    "needs a closed surface around its medium")
        if self.nonmanifold_edges:
            return (f"mesh {name!r} is non-manifold ({self.nonmanifold_edges} edges with more than two faces): "
                    "the path-traced reference needs a closed 2-manifold around its medium")
        if self.misoriented_edges:
            return (f"mesh {name!r} has faces wound against their neighbours ({self.misoriented_edges} edges): "
                    "the path-traced reference needs consistent winding to tell inside from outside")
        if not self.volume > 0:
            return f"mesh {name!r} encloses no volume (signed volume {self.volume:.3g})"
        return None


@dataclass(frozen=True)
class MeshCounts:
    """Vertex and face (triangle) counts of a mesh file, read without loading it."""

    vertices: int
    faces: int


# ---- the file ------------------------------------------------------------------------------------------

def check_mesh_path(path: str | os.PathLike[str]) -> Path:
    """``path`` as a Path, or a SceneError if it is missing, a directory, empty, or of an unknown format."""
    p = Path(path)
    if not read_input(p, "mesh", SceneError, FORMATS, size=1):  # (io: every input file's rules, its suffix too)
        raise SceneError(f"mesh {str(p)!r} is empty (0 bytes)")
    return p


def _head(p: Path, size: int = -1) -> bytes:
    """The first ``size`` bytes of the mesh file ``p`` (-1: all), or a SceneError if they do not begin with its
    format's magic (:data:`MAGIC`)."""
    with open(p, "rb") as fh:
        data = fh.read(size)
    magic, kind = MAGIC.get(p.suffix.lower(), (b"", ""))
    if not data.startswith(magic):
        raise SceneError(f"mesh {str(p)!r} is not a {kind} file (no {magic.decode()!r} magic)")
    return data


def _gltf_json(p: Path) -> dict:
    """The JSON document of a .gltf file or of a .glb file's first chunk."""
    data = _head(p)
    if p.suffix.lower() == ".glb":
        length, kind = struct.unpack_from("<I4s", data.ljust(20, b"\0"), 12)
        if kind != b"JSON" or 20 + length > len(data):
            raise SceneError(f"mesh {str(p)!r}: the binary glTF's first chunk is not its JSON")
        text = data[20:20 + length]
    else:
        text = data
    try:
        doc = parse_document(text.decode("utf-8"), ".json")
    except (UnicodeDecodeError, ValueError):
        raise SceneError(f"mesh {str(p)!r} is not a glTF file (its JSON does not parse)") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("asset"), dict):
        raise SceneError(f"mesh {str(p)!r} is not a glTF file (no 'asset' object)")
    for key in ("accessors", "meshes", "nodes"):  # glTF 2.0's arrays of objects ("meshes": {} was an AttributeError)
        for item in check_instance(doc.get(key, []), list, f"mesh {str(p)!r}: {key}", SceneError):
            check_instance(item, dict, f"mesh {str(p)!r}: each of its {key}", SceneError)
    return doc


def _gltf_counts(p: Path) -> MeshCounts:
    doc = _gltf_json(p)
    accessors = doc.get("accessors", [])
    uses = [0] * len(doc.get("meshes", []))
    for node in doc.get("nodes", []):
        if isinstance(node.get("mesh"), int) and 0 <= node["mesh"] < len(uses):
            uses[node["mesh"]] += 1
    nv = nf = 0
    try:
        for i, mesh in enumerate(doc.get("meshes", [])):
            for prim in mesh.get("primitives", []):
                if prim.get("mode", 4) != 4:
                    raise SceneError(f"mesh {str(p)!r}: primitive mode {prim['mode']} is not triangles (4); "
                                     "only triangle meshes are supported")
                v = int(accessors[prim["attributes"]["POSITION"]]["count"])
                n = int(accessors[prim["indices"]]["count"]) if "indices" in prim else v
                nv += v * max(uses[i], 1)
                nf += n // 3 * max(uses[i], 1)
    except (AttributeError, KeyError, IndexError, TypeError, ValueError):
        raise SceneError(f"mesh {str(p)!r}: a glTF primitive has no valid POSITION or indices accessor") from None
    return MeshCounts(nv, nf)


def ply_header(p: Path, size: int = -1) -> tuple[list[str], bytes]:
    """The header lines of the PLY file ``p`` (in its first ``size`` bytes; -1: all) and the bytes after them, or a
    SceneError without the PLY magic or an ``end_header``."""
    data = _head(p, size)
    end = data.find(b"end_header")
    if end < 0:
        raise SceneError(f"mesh {str(p)!r}: PLY header has no end_header")
    return data[:end].decode("ascii", "replace").splitlines(), data[end + len(b"end_header\n"):]


def _ply_counts(p: Path) -> MeshCounts:
    counts = {}
    for line in ply_header(p, 1 << 16)[0]:
        parts = line.split()
        if len(parts) == 3 and parts[0] == "element" and parts[2].isdigit():
            counts[parts[1]] = int(parts[2])
    return MeshCounts(counts.get("vertex", 0), counts.get("face", 0))


def _obj_counts(p: Path) -> MeshCounts:
    nv = nf = 0
    tail = b"\n"
    with open(p, "rb") as fh:
        while block := fh.read(1 << 22):
            text = tail + block
            nv += text.count(b"\nv ")
            nf += text.count(b"\nf ")
            tail = text[-2:] if not text.endswith(b"\n") else b"\n"
    return MeshCounts(nv, nf)


def mesh_counts(path: str | os.PathLike[str]) -> MeshCounts:
    """Vertex and face counts of a mesh file without loading it: the PLY header's elements, the glTF
    accessors' counts (times the nodes that instance each mesh), an OBJ's ``v`` and ``f`` lines (a
    polygon line counts as one face: a lower bound)."""
    p = check_mesh_path(path)
    kind = FORMATS[p.suffix.lower()]
    return {"ply": _ply_counts, "gltf": _gltf_counts, "obj": _obj_counts}[kind](p)


def memory_estimate(counts: MeshCounts, width: int, height: int) -> int:
    """Bytes a frame of this mesh at ``width`` x ``height`` needs at its peak (an estimate:
    :data:`BYTES_PER_FACE` per triangle + :data:`BYTES_PER_PIXEL` per pixel)."""
    return int(counts.faces) * BYTES_PER_FACE + int(width) * int(height) * BYTES_PER_PIXEL


def available_memory() -> int:
    """Bytes of memory available to a new allocation: ``MemAvailable`` of /proc/meminfo, else the
    physical memory."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))


def _gb(n: float) -> str:
    return f"{n / 2**30:.1f} GiB"


def check_render_memory(what: str, counts: MeshCounts, width: int, height: int, available: int | None = None) -> int:
    """The :func:`memory_estimate` of rendering ``what`` (a mesh, a built-in, generated or file scene with the
    ``counts`` of its triangle meshes) at ``width`` x ``height``, or a SceneError saying it exceeds the memory
    available (:func:`available_memory`): the same check for every scene kind, before any work."""
    need = memory_estimate(counts, width, height)
    have = available_memory() if available is None else int(available)
    if need > have:
        raise SceneError(f"{what}: rendering it at {width}x{height} needs about {_gb(need)} ({BYTES_PER_FACE} B per "
                         f"face, {BYTES_PER_PIXEL} B per pixel), more than the {_gb(have)} of memory available")
    return need


def shape_counts(shapes: Sequence[dict]) -> MeshCounts:
    """Vertex and face counts of Mitsuba shape dicts: a ``ply`` shape's from its header (the meshes ssskit
    writes to its cache); analytic shapes (spheres, rectangles) count none."""
    nv = nf = 0
    for shape in shapes:
        if shape.get("type") == "ply" and "filename" in shape:
            c = _ply_counts(Path(shape["filename"]))
            nv, nf = nv + c.vertices, nf + c.faces
    return MeshCounts(nv, nf)


def inspect_mesh_file(path: str | os.PathLike[str], width: int, height: int) -> MeshCounts:
    """The checks that need no loading (:func:`check_mesh_path`, :func:`mesh_counts`,
    :func:`check_render_memory`); returns the counts."""
    counts = mesh_counts(path)
    if counts.faces == 0:
        raise SceneError(f"mesh {str(path)!r} has no faces")
    check_render_memory(f"mesh {str(path)!r} has {counts.faces:,} faces", counts, width, height)
    return counts


# ---- reading -------------------------------------------------------------------------------------------

def _mitsuba_message(exc: Exception) -> str:
    text = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
    return text.rsplit("]: ", 1)[-1].rsplit("] ", 1)[-1].strip()


def _read_mitsuba(p: Path, kind: str) -> tuple[Mesh, ...]:
    from .mitsuba_variant import mitsuba, warnings_dropped

    mi = mitsuba()
    with warnings_dropped():  # the checks of read_mesh report a degenerate mesh
        # absolute: Mitsuba resolves a relative name against the folder it was first imported in, not the current one
        shape = mi.load_dict({"type": kind, "filename": str(p.absolute())})  # (its errors: read_mesh)
    params = mi.traverse(shape)
    verts = np.array(params["vertex_positions"], dtype=np.float32).reshape(-1, 3)
    faces = np.array(params["faces"], dtype=np.uint32).reshape(-1, 3)
    normals = None
    if "vertex_normals" in params and shape.has_vertex_normals():
        normals = np.array(params["vertex_normals"], dtype=np.float32).reshape(-1, 3)
    return (Mesh(p.stem, verts, faces, normals if normals is not None and len(normals) == len(verts) else None),)


def _read_gltf(p: Path) -> tuple[Mesh, ...]:
    doc = _gltf_json(p)
    prims = [prim for mesh in doc.get("meshes", []) for prim in mesh.get("primitives", [])]
    has_normals = bool(prims) and all("NORMAL" in prim.get("attributes", {}) for prim in prims)
    import trimesh  # (a core dependency)

    scene: Any = trimesh.load(str(p), force="scene", process=False)  # (its errors: read_mesh)
    groups: dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray | None]]] = {}
    for node in scene.graph.nodes_geometry:
        transform, gname = scene.graph[node]
        geom = scene.geometry[gname]
        if not hasattr(geom, "faces"):
            continue
        material = getattr(getattr(geom, "visual", None), "material", None)
        mname = str(getattr(material, "name", None) or "default")
        t = np.asarray(transform, dtype=np.float64)
        v = np.asarray(geom.vertices, dtype=np.float64) @ t[:3, :3].T + t[:3, 3]
        n = None
        if has_normals:
            # normals transform by the inverse transpose of the node's linear part
            n = np.asarray(geom.vertex_normals, dtype=np.float64) @ np.linalg.inv(t[:3, :3])
            n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
            if np.linalg.det(t[:3, :3]) < 0:
                n = -n
        groups.setdefault(mname, []).append((v, np.asarray(geom.faces, dtype=np.int64), n))
    # the file's material order (trimesh's node order is not the file's)
    order = [str(m.get("name")) for m in doc.get("materials", []) if isinstance(m, dict)]
    rank = {name: (order.index(name) if name in order else len(order), name) for name in groups}
    meshes = []
    for name, parts in sorted(groups.items(), key=lambda kv: rank[kv[0]]):
        offsets = np.cumsum([0] + [len(v) for v, _, _ in parts])
        verts = np.concatenate([v for v, _, _ in parts])
        faces = np.concatenate([f + o for (_, f, _), o in zip(parts, offsets)])
        normals = None if not has_normals else np.concatenate([n for _, _, n in parts if n is not None])
        meshes.append(Mesh(name, verts, faces, normals))
    return tuple(meshes)


def _read_ply(p: Path) -> tuple[Mesh, ...]:
    """A PLY file's arrays through trimesh's PLY parser (ASCII and binary; polygons triangulated), so that its
    face indices are checked (:class:`Mesh`) before any renderer sees them: Mitsuba's own PLY loader takes an
    index beyond the vertices as it is and crashes the process (exit 139) building the shape."""
    import trimesh
    from trimesh.exchange.ply import load_ply

    with open(p, "rb") as fh:
        kw = load_ply(fh)  # (its errors, and the triangulation's: read_mesh)
    faces = kw.get("faces")
    if faces is None or len(faces) == 0:  # a mesh without faces: read_mesh's check_mesh refuses it
        tri = np.zeros((0, 3), np.int64)
    elif isinstance(faces, np.ndarray) and faces.ndim == 2 and faces.shape[1] == 3:
        tri = np.asarray(faces, dtype=np.int64)
    else:  # polygons: fan-triangulated by trimesh, indices kept as they are (checked by Mesh)
        tri = np.asarray(trimesh.geometry.triangulate_quads(faces), dtype=np.int64)
    normals = kw.get("vertex_normals")
    verts = np.asarray(kw.get("vertices", np.zeros((0, 3))), dtype=np.float32).reshape(-1, 3)
    if normals is not None:
        normals = np.asarray(normals, dtype=np.float32).reshape(-1, 3)
        if len(normals) != len(verts):
            normals = None
        else:  # unit length, as Mitsuba's loader leaves them (a zero normal stays zero)
            normals = normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), np.float32(1e-30))
    return (Mesh(p.stem, verts, tri, normals),)


def read_mesh(path: str | os.PathLike[str]) -> tuple[Mesh, ...]:
    """The objects of a mesh file (module docstring), each checked by :class:`Mesh` (face indices within the
    vertices) and :func:`check_mesh`: OBJ through Mitsuba's loader (which refuses an index out of range), PLY and
    glTF through trimesh."""
    p = check_mesh_path(path)
    kind = FORMATS[p.suffix.lower()]
    reader = {"gltf": _read_gltf, "ply": _read_ply}.get(kind)
    try:
        meshes = reader(p) if reader is not None else _read_mitsuba(p, kind)
    except SsskitError:  # (the checks', and Mitsuba's absence)
        raise
    except Exception as exc:  # noqa: BLE001 - Mitsuba and trimesh raise many kinds of errors on a corrupt file
        msg = str(exc) if reader is not None else _mitsuba_message(exc)
        if "invalid vertex position" in msg:  # (Mitsuba's OBJ loader refuses NaN and inf itself)
            raise fail(SceneError, FINITE, name=f"mesh {str(p)!r}: vertex positions", actual=f"NaN or inf (Mitsuba: {msg})"
                       ) from None
        fmt = {"gltf": "glTF"}.get(kind, kind.upper())
        raise SceneError(f"mesh {str(p)!r} cannot be read as {fmt}: {msg}") from None
    if not meshes:
        raise SceneError(f"mesh {str(p)!r} holds no triangle mesh")
    for m in meshes:
        check_mesh(m, str(p))
    check_area(meshes, str(p))
    return meshes


def surface_area(mesh: Mesh) -> float:
    """The total area of the mesh's triangles (float64; half the norm of each edge cross product)."""
    v = mesh.vertices.astype(np.float64)
    a, b, c = (v[mesh.faces[:, k]] for k in range(3))
    return float(0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())


def check_area(meshes: Sequence[Mesh], source: str) -> None:
    """A SceneError if the meshes' faces have no area (each one a line or a point: e.g. collinear vertices):
    nothing of them can be seen, so a render would have no SSS pixel to measure. "No area": at most 1e-12
    of the squared bounding-box diagonal (rounding leaves collinear float vertices a sliver)."""
    area = sum(surface_area(m) for m in meshes)
    v = np.concatenate([m.vertices.astype(np.float64) for m in meshes])
    diag2 = float(np.sum((v.max(axis=0) - v.min(axis=0)) ** 2))
    if not area > 1e-12 * diag2:
        faces = sum(len(m.faces) for m in meshes)
        raise SceneError(f"mesh {source!r} is degenerate: its {faces:,} face{'s' if faces != 1 else ''} "
                         f"{'have' if faces != 1 else 'has'} zero area (collinear or coincident vertices), so no "
                         "surface can be seen and there is nothing to render or measure")


def check_mesh(mesh: Mesh, source: str = "") -> None:
    """A SceneError if the mesh has no faces or a NaN or infinite vertex position."""
    where = f"mesh {source!r} (object {mesh.name!r})" if source else f"mesh {mesh.name!r}"
    if len(mesh.faces) == 0:
        raise SceneError(f"{where} has no faces")
    check_finite(mesh.vertices, f"{where}: vertex positions", SceneError, "coordinates")


def topology(mesh: Mesh) -> Topology:
    """The mesh's :class:`Topology`: vertices at equal positions are welded first (a reader that splits
    vertices at seams of normals or texture coordinates leaves the surface closed)."""
    _, inverse = np.unique(mesh.vertices, axis=0, return_inverse=True)
    f = inverse.reshape(-1)[mesh.faces.astype(np.int64)]
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 2] != f[:, 0])]  # drop collapsed faces
    a = f.reshape(-1)
    b = f[:, [1, 2, 0]].reshape(-1)
    n = int(inverse.max(initial=0)) + 1
    undirected = np.minimum(a, b) * n + np.maximum(a, b)
    _, counts = np.unique(undirected, return_counts=True)
    directed = a * n + b
    _, dcounts = np.unique(directed, return_counts=True)
    v = mesh.vertices.astype(np.float64)
    tri = v[mesh.faces.astype(np.int64)]
    volume = float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0)
    return Topology(vertices=n, faces=len(f), boundary_edges=int((counts == 1).sum()),
                    nonmanifold_edges=int((counts > 2).sum()), misoriented_edges=int((dcounts > 1).sum()),
                    volume=volume)


def bounding_sphere(meshes: Sequence[Mesh], scale: float = 1.0) -> tuple[np.ndarray, float]:
    """(centre (3,), radius) of a sphere around every vertex: the centre of the axis-aligned bounding
    box and the largest distance from it, times ``scale``."""
    v = np.concatenate([m.vertices for m in meshes]).astype(np.float64) * scale
    centre = 0.5 * (v.min(axis=0) + v.max(axis=0))
    return centre, float(np.linalg.norm(v - centre, axis=1).max())


# ---- writing -------------------------------------------------------------------------------------------

def _trimesh(mesh: Mesh, material: bool = False) -> Any:
    """The mesh as a ``trimesh.Trimesh`` (arrays as they are: no merging or reordering), its normals stored only
    when it has some; ``material``: a glTF PBR material named after the object (grey, not metallic)."""
    import trimesh

    t = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False, vertex_normals=mesh.normals)
    if material:
        t.visual = trimesh.visual.TextureVisuals(material=trimesh.visual.material.PBRMaterial(
            name=mesh.name, baseColorFactor=[204, 204, 204, 255], metallicFactor=0.0))
    return t


def ply_bytes(verts: np.ndarray, faces: np.ndarray, normals: np.ndarray | None = None) -> bytes:
    """A binary little-endian PLY file of a triangle mesh (float32 positions and normals, int32 indices), written
    by trimesh's PLY exporter."""
    from trimesh.exchange.ply import export_ply

    mesh = Mesh("ply", verts, faces, normals)
    return bytes(export_ply(_trimesh(mesh), encoding="binary", vertex_normal=normals is not None,
                            include_attributes=False))


def _merged(meshes: Sequence[Mesh]) -> Mesh:
    if len(meshes) == 1:
        return meshes[0]
    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes])
    normals = None
    if all(m.normals is not None for m in meshes):
        normals = np.concatenate([m.normals for m in meshes if m.normals is not None])
    return Mesh("merged", np.concatenate([m.vertices for m in meshes]),
                np.concatenate([m.faces.astype(np.int64) + o for m, o in zip(meshes, offsets)]), normals)


def _obj_text(meshes: Sequence[Mesh]) -> str:
    """An OBJ file of the objects, one ``o`` group each, positions and normals as float32 writes them (``%.9g``:
    exact). Kept by hand: trimesh 4's OBJ export of several objects (a Scene) drops their given vertex normals
    (``Scene.dump`` copies the geometry without them) and writes fixed-point numbers (8 decimals by default)."""
    lines = ["# written by ssskit"]
    base = 1
    for m in meshes:
        lines.append(f"o {m.name}")
        lines.extend(f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in m.vertices.tolist())
        if m.normals is not None:
            lines.extend(f"vn {x:.9g} {y:.9g} {z:.9g}" for x, y, z in m.normals.tolist())
            lines.extend(f"f {a}//{a} {b}//{b} {c}//{c}" for a, b, c in (m.faces.astype(np.int64) + base).tolist())
        else:
            lines.extend(f"f {a} {b} {c}" for a, b, c in (m.faces.astype(np.int64) + base).tolist())
        base += len(m.vertices)
    return "\n".join(lines) + "\n"


def write_mesh(path: str | os.PathLike[str], meshes: Mesh | Sequence[Mesh]) -> Path:
    """Write ``meshes`` to ``path`` (format from the suffix, atomically), PLY and glTF with trimesh's exporters:
    ``.obj`` (one ``o`` group per object: :func:`_obj_text`), ``.ply`` (binary; several objects are merged), ``.glb`` / ``.gltf`` (glTF 2.0, one
    node, mesh and material per object named after it; a ``.gltf`` embeds its buffer as a data URI)."""
    import trimesh

    p = Path(path)
    items = (meshes,) if isinstance(meshes, Mesh) else tuple(meshes)
    if not items:
        raise SceneError("write_mesh needs at least one mesh")
    kind = FORMATS[check_suffix(p, tuple(FORMATS), "mesh", SceneError)]
    if kind == "ply":
        m = _merged(items)
        data = ply_bytes(m.vertices, m.faces, m.normals)
    elif kind == "obj":
        data = _obj_text(items).encode("ascii")
    else:
        scene = trimesh.Scene()
        for m in items:
            scene.add_geometry(_trimesh(m, material=True), geom_name=m.name, node_name=m.name)
        if p.suffix.lower() == ".glb":
            data = scene.export(file_type="glb")
        else:
            from trimesh.exchange.gltf import export_gltf

            files = export_gltf(scene, embed_buffers=True)
            data = files["model.gltf"]
    with atomic_output(p) as tmp:
        tmp.write_bytes(data)
    return p


__all__ = ["BYTES_PER_FACE", "BYTES_PER_PIXEL", "FORMATS", "Mesh", "MeshCounts", "Topology", "UNITS_MM",
           "available_memory", "bounding_sphere", "check_area", "check_mesh", "check_mesh_path",
           "check_render_memory", "inspect_mesh_file", "memory_estimate", "mesh_counts", "ply_bytes", "read_mesh",
           "ply_header", "shape_counts", "surface_area", "topology", "write_mesh"]
