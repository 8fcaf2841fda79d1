"""The scanned head both papers render: Lee Perry-Smith's head scan by Infinite-Realities (CC BY 3.0),
the mesh of the separable-SSS demo (Jimenez et al. 2015 thank Infinite-Realities and Lee Perry-Smith for
it; Xie et al. 2020 render it as the "Infinite-Realities head" in Figs. 7 and 9), shipped as package
data (``data/head.npz``: the PLY's float32 positions, normals and texture coordinates and int32
triangles, unchanged; ``data/HEAD-LICENSE.md``: its licence and credit).

Whoever shows it credits :data:`ATTRIBUTION`. Its file units are not millimetres: :data:`MM_PER_UNIT`
is the scale ssskit uses, fixed by the head's breadth (euryon-euryon) and length (glabella-opisthocranion)
against adult male means (docs/head.md, "Scale"; [PH06], British men aged 19-65: head breadth 155 mm,
head length 195 mm): breadth 0.5824 units gives 266 mm per unit, length 0.7738 units 252 mm
per unit; their geometric mean, 259 mm per unit, puts both within one standard deviation (6 and 8 mm) of
the means. Axes as stored: +Y up, the face looks toward -Z, the ears at X = +-0.33 units.

:func:`write_head_data` regenerates the shipped file from the PLY (``docs/head_data.py`` runs it).
"""

from __future__ import annotations

import functools
import io
import os
import zipfile
from pathlib import Path

import numpy as np

from ..errors import SceneError
from ..quantities import Quantity, checks
from ..settings import HEAD_ATTRIBUTION
from .meshes import Mesh, ply_header

#: the credit the licence (CC BY 3.0) asks of whoever ships or shows the scan
ATTRIBUTION = HEAD_ATTRIBUTION
LICENCE = "CC BY 3.0 (Creative Commons Attribution 3.0 Unported)"
#: mm per file unit (module docstring; docs/head.md "Scale")
MM_PER_UNIT = 259.0
#: the scales a head scene accepts (mm per unit): a head 0.58 units across from 58 mm to 580 mm; their quantity
MM_PER_UNIT_RANGE = (100.0, 1000.0)
HEAD_SCALE = Quantity("mm_per_unit", *MM_PER_UNIT_RANGE, "", "the head 0.58 units across is 58 to 580 mm wide; "
                      f"ssskit's scale: {MM_PER_UNIT:g}")
#: the shipped file beside this module
DATA_PATH = Path(__file__).parent / "data" / "head.npz"
#: the PLY's vertex and face counts (the scan as the separable-SSS demo ships it)
VERTICES, FACES = 36978, 70736
_ARRAYS = ("vertices", "normals", "uvs", "faces")


def read_head_ply(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """The arrays of the head's binary little-endian PLY (``x y z nx ny nz s t`` float32 per vertex, a
    uchar-counted int32 list per face, every face a triangle): ``vertices``, ``normals``, ``uvs``
    (V, 3|2) float32 and ``faces`` (F, 3) int32, values as stored."""
    header, body = ply_header(Path(path))  # (the PLY magic and end_header: meshes' rules)
    props = [ln.split()[-1] for ln in header if ln.startswith("property float")]
    counts = {ln.split()[1]: int(ln.split()[2]) for ln in header if ln.startswith("element")}
    if ("format binary_little_endian 1.0" not in header or props != ["x", "y", "z", "nx", "ny", "nz", "s", "t"]
            or "property list uchar int vertex_indices" not in header):
        raise SceneError(f"{str(path)!r}: not the head's PLY layout (binary little-endian x y z nx ny nz s t, "
                         "uchar/int faces)")
    nv, nf = counts["vertex"], counts["face"]
    vert = np.frombuffer(body, dtype="<f4", count=nv * 8).reshape(nv, 8)
    rec = np.frombuffer(body, dtype=np.dtype([("n", "u1"), ("i", "<i4", (3,))]), count=nf, offset=nv * 32)
    if not (rec["n"] == 3).all() or len(body) != nv * 32 + nf * 13:
        raise SceneError(f"{str(path)!r}: every face must be a triangle and the file end after the faces")
    return {"vertices": np.ascontiguousarray(vert[:, 0:3]), "normals": np.ascontiguousarray(vert[:, 3:6]),
            "uvs": np.ascontiguousarray(vert[:, 6:8]), "faces": np.ascontiguousarray(rec["i"])}


def write_head_data(ply: str | os.PathLike[str], out: str | os.PathLike[str] = DATA_PATH) -> Path:
    """Write the head's arrays (:func:`read_head_ply`) as a compressed ``.npz`` with fixed member times, so
    the same PLY always gives the same bytes."""
    from ..io import atomic_output

    arrays = read_head_ply(ply)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=9) as zf:
        for name in _ARRAYS:
            member = io.BytesIO()
            np.lib.format.write_array(member, arrays[name], allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            zf.writestr(info, member.getvalue())
    with atomic_output(Path(out)) as tmp:
        tmp.write_bytes(buf.getvalue())
    return Path(out)


@functools.lru_cache(maxsize=1)
def head_arrays() -> dict[str, np.ndarray]:
    """The shipped arrays (read-only): ``vertices``, ``normals``, ``uvs`` float32, ``faces`` int32."""
    with np.load(DATA_PATH, allow_pickle=False) as z:
        out = {k: z[k] for k in _ARRAYS}
    for a in out.values():
        a.setflags(write=False)
    return out


@checks(SceneError, mm_per_unit=(HEAD_SCALE, "head mm_per_unit"))
def head_mesh(mm_per_unit: float = MM_PER_UNIT) -> Mesh:
    """The head in mm: the scan's vertices times ``mm_per_unit``, its normals and triangles; a closed
    2-manifold once equal positions are welded (the scan's texture seams split vertices)."""
    a = head_arrays()
    return Mesh("head", a["vertices"] * np.float32(mm_per_unit), a["faces"], a["normals"])


def head_measures(mesh: Mesh | None = None) -> dict[str, float]:
    """The head's breadth and length in file units, or in ``mesh``'s (a :func:`head_mesh`), measured on
    sections of the surface (trimesh's plane sections): ``breadth``, the widest section across X of the
    horizontal sections above the ears (Y from 0.18 to 0.40 units: euryon-euryon, ears excluded);
    ``length``, in the mid-sagittal section (X = 0) from the glabella (the most anterior point of the
    forehead above the nasion, Y from 0.16 to 0.30 units) to the opisthocranion (the most posterior
    point of the skull)."""
    import trimesh

    a = head_arrays()
    s = 1.0 if mesh is None else float(np.linalg.norm(mesh.vertices) / np.linalg.norm(a["vertices"]))
    tm = trimesh.Trimesh(a["vertices"].astype(np.float64), a["faces"], process=False)
    tm.merge_vertices()
    breadth = 0.0
    for y in np.linspace(0.18, 0.40, 45):
        sec = tm.section(plane_origin=[0.0, y, 0.0], plane_normal=[0.0, 1.0, 0.0])
        if sec is not None:
            breadth = max(breadth, float(np.ptp(sec.vertices[:, 0])))
    section = tm.section(plane_origin=[0.0, 0.0, 0.0], plane_normal=[1.0, 0.0, 0.0])
    if section is None:
        raise SceneError("the head mesh has no midsagittal section (x = 0): not the shipped scan")
    mid = section.vertices
    brow = mid[(mid[:, 1] >= 0.16) & (mid[:, 1] <= 0.30)]
    skull = mid[mid[:, 1] >= 0.0]
    length = float(skull[:, 2].max() - brow[:, 2].min())
    return {"breadth": breadth * s, "length": length * s}


__all__ = ["ATTRIBUTION", "DATA_PATH", "FACES", "LICENCE", "MM_PER_UNIT", "MM_PER_UNIT_RANGE", "VERTICES",
           "HEAD_SCALE", "head_arrays", "head_measures", "head_mesh", "read_head_ply", "write_head_data"]
