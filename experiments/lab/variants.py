"""Controlled variants of the built-in scenes: each switches off ONE cause of a difference between the
screen-space model and the path-traced reference, so that the difference it removes can be measured
(:mod:`lab.attribution`).

* :func:`scaled_scene` (curvature): every length of the scene -- shapes, lights, camera -- times k,
  the material unchanged. The image is the same (the direct light E / pi is scale-free: an area
  light's radiance and solid angle do not change, a point light's intensity goes with k^2), but
  each pixel covers k times more mm, so the surface's curvature relative to the profile's reach
  falls by k. As k grows the surface under one profile radius becomes flat.
* :func:`backed_scene` (transmission): a black shell just outside the part of each SSS object's
  surface that the camera does not see. No light enters the medium there: light that arrives
  through the back (through a thin part or around the silhouette) is removed, while everything the
  camera sees, and the light on every surface it sees, stays the same (the shell is behind that
  surface; tests/scenes check the G-buffer's mask and E / pi). Light leaving the medium through its
  back is lost with or without the shell (the surroundings are black in the reference and the
  objects are convex).
* :func:`~ssskit.scenes.thickness.thin_scene` (thickness, a flat control; in the product, re-exported
  here): each SSS box of the scene (the slab) cut to a finite thickness t below its top face; everything
  the camera sees stays. Light that a semi-infinite medium would return leaves through the bottom face
  into the black surroundings: the reference's plateau level falls to MCML's Rd(t) / Rd(inf).
* :func:`deepened_scene` (thickness, the curved object's control): each SSS mesh's half that faces
  away from the camera stretched by a factor along the mesh's shortest axis. The seen surface (its
  vertices and normals), and with it the G-buffer, stay bit for bit; behind it the medium is ``factor``
  times deeper, so light entering the seen surface of a thin object (the ear, 4 mm) is no longer lost
  through its back. With :func:`backed_scene` on top (no light enters the unseen surface) it
  separates the thin object's back losses from its transmission.

The variants are :class:`~ssskit.scenes.scenes.SceneSpec` values; :func:`ssskit.scenes.render_gbuffer`
and :func:`ssskit.scenes.render_reference` take them wherever they take a scene name.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from ssskit.errors import SceneError
from ssskit.scenes.scenes import SceneSpec, _ellipsoid_geometry, _ply, _T, camera_pose, get_scene
from ssskit.quantities import SCALE
from ssskit.scenes.thickness import box_thickness_mm, thin_scene  # noqa: F401  (re-exported)

#: how far (mm) the backing shell lies outside the surface (beyond the deviation of the shell's mesh
#: from an analytic surface): small against a pixel (~0.5 mm), so that it shadows little light
#: arriving at the seen surface at grazing angles (tests/scenes measure E / pi with and without it),
#: but more than the few um by which Mitsuba spawns a ray off a surface at these coordinates: a
#: shell at 0.002 mm was skipped by most shadow rays leaving the ear (80% of the key light still
#: came through), at 0.005 mm 0.3%, at 0.01 mm 0.01% (tests/scenes/test_variants.py)
BACKING_OFFSET_MM = 0.01


def _check_factor(k) -> float:
    if isinstance(k, bool) or not (isinstance(k, (int, float, np.integer, np.floating)) and math.isfinite(k) and k > 0):
        raise SceneError(f"the scale factor must be a positive number, got {k!r}")
    return float(k)


def _scaled_shape(shape: dict, k: float) -> dict:
    d = dict(shape)
    if d.get("type") == "sphere" and "to_world" not in d:
        # centre and radius kept as such (scene_lights orbits a sphere light's centre)
        d["center"] = (np.asarray(d.get("center", (0.0, 0.0, 0.0)), float) * k).tolist()
        d["radius"] = float(d.get("radius", 1.0)) * k
    else:
        d["to_world"] = _T()().scale([k, k, k]) @ d.get("to_world", _T()())
    return d


def _scaled_light(light: dict, k: float) -> dict:
    d = dict(light)
    if d.get("type") == "point":
        d["position"] = (np.asarray(d["position"], float) * k).tolist()
        inten = dict(d["intensity"])
        value = np.asarray(inten["value"], float) * k * k  # E = I cos / d^2: the same at k x the distance
        inten["value"] = value.tolist() if value.ndim else float(value)
        d["intensity"] = inten
        return d
    if d.get("type") == "sphere":  # a spherical area light: same radiance, same solid angle
        return _scaled_shape(d, k)
    raise SceneError(f"cannot scale a light of type {d.get('type')!r}")


def scaled_scene(scene: str | SceneSpec, k: float) -> SceneSpec:
    """``scene`` with every length times ``k`` (shapes, lights, camera position and target; the field
    of view and the material unchanged): the same image with k times the mm per pixel, so the
    surface's curvature relative to the profile's reach is 1/k of the original's (module docstring).
    Named ``<name>-x<k>``."""
    spec = get_scene(scene)
    k = _check_factor(k)

    def shapes() -> dict[str, dict]:
        return {sid: _scaled_shape(d, k) for sid, d in spec.shapes().items()}

    def lights() -> dict[str, dict]:
        return {lid: _scaled_light(d, k) for lid, d in spec.lights().items()}

    return dataclasses.replace(
        spec, name=f"{spec.name}-x{k:g}", description=f"{spec.description}; every length x {k:g}",
        origin=tuple(float(v) * k for v in spec.origin), target=tuple(float(v) * k for v in spec.target),
        shapes=shapes, lights=lights)


def _read_ply(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Vertices, faces and (if stored) normals of a binary PLY written by ``scenes._ply``."""
    data = Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    nv = int(next(line.split()[2] for line in header if line.startswith("element vertex")))
    nf = int(next(line.split()[2] for line in header if line.startswith("element face")))
    nprop = sum(1 for line in header if line.startswith("property float"))
    vdata = np.frombuffer(data, dtype="<f4", count=nv * nprop, offset=end).reshape(nv, nprop).astype(float)
    fdata = np.frombuffer(data, dtype=[("n", "u1"), ("i", "<u4", (3,))], count=nf, offset=end + vdata.size * 4)
    return vdata[:, :3], fdata["i"].astype(np.int64), (vdata[:, 3:6] if nprop >= 6 else None)


def _vertex_normals(verts: np.ndarray, faces: np.ndarray) -> np.ndarray:
    fn = np.cross(verts[faces[:, 1]] - verts[faces[:, 0]], verts[faces[:, 2]] - verts[faces[:, 0]])
    n = np.zeros_like(verts)
    for c in range(3):
        np.add.at(n, faces[:, c], fn)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)


def surface_mesh(shape: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(vertices (V, 3), faces (F, 3), unit outward vertex normals (V, 3), sag) of an SSS shape: an
    analytic sphere (a 96 x 192 UV mesh on it; ``sag``: how far its flat faces dip below the sphere,
    mm) or a PLY mesh (the surface itself: sag 0); a SceneError for any other shape."""
    kind = shape.get("type")
    if kind == "sphere" and "to_world" not in shape:
        r = float(shape.get("radius", 1.0))
        c = tuple(float(v) for v in shape.get("center", (0.0, 0.0, 0.0)))
        v, f, n = (np.asarray(a) for a in _ellipsoid_geometry(radii=(r, r, r), center=c))
        v, f, n = v.astype(float), f.astype(np.int64), n.astype(float)
        centroids = v[f].mean(axis=1)
        sag = float(np.max(r - np.linalg.norm(centroids - np.asarray(c), axis=1)))
        return v, f, n, sag
    if kind == "ply":
        v, f, n = _read_ply(shape["filename"])
        if n is None:
            n = _vertex_normals(v, f)
        # outward: the normals point away from the centroid on a convex closed mesh; flip if not
        if np.mean(np.sum((v - v.mean(axis=0)) * n, axis=1)) < 0:
            n = -n
        return v, f, n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300), 0.0
    raise SceneError(f"no backing for a shape of type {kind!r} (an analytic sphere or a PLY mesh)")


def backing_faces(verts: np.ndarray, faces: np.ndarray, normals: np.ndarray, eye, grazing_cos: float = 0.0) -> np.ndarray:
    """(F,) bool: the faces whose three vertices all have n . (eye - v) / |eye - v| < ``grazing_cos``:
    with 0 the surface the camera cannot see; with a positive value also the surface it sees at
    grazing angles (a thin object's edge, seen edge-on)."""
    d = np.asarray(eye, float) - verts
    away = np.sum(normals * d, axis=1) < grazing_cos * np.linalg.norm(d, axis=1)
    return away[faces].all(axis=1)


def backed_scene(scene: str | SceneSpec, offset_mm: float = BACKING_OFFSET_MM, frame: int = 0,
                 grazing_cos: float = 0.0) -> SceneSpec:
    """``scene`` with a black shell ``offset_mm`` (beyond the sag of its mesh, :func:`surface_mesh`)
    outside the part of each SSS object's surface that the camera (at ``frame``) does not see: no light
    enters the medium through its back (module docstring). The shell is a shape that is not an SSS object, so it is black in the reference.
    With ``grazing_cos`` > 0 the shell also covers the surface seen at grazing angles, cos < grazing_cos
    (:func:`backing_faces`): a thin object's edge, where the light of a back light enters and which
    the image resolves in less than a pixel; that shell hides those slivers of the seen surface
    (compare the G-buffers' masks). Named ``<name>-backed`` (``<name>-backed<cos>`` with a grazing cos)."""
    spec = get_scene(scene)
    if not (isinstance(offset_mm, (int, float, np.floating)) and math.isfinite(offset_mm) and offset_mm > 0):
        raise SceneError(f"the backing offset must be a positive number of mm, got {offset_mm!r}")
    if not (isinstance(grazing_cos, (int, float, np.floating)) and 0.0 <= grazing_cos < 1.0):
        raise SceneError(f"grazing_cos must lie in [0, 1), got {grazing_cos!r}")
    eye = camera_pose(spec, frame)[0]

    def shapes() -> dict[str, dict]:
        d = spec.shapes()
        for sid in spec.sss_shapes:
            v, f, n, sag = surface_mesh(d[sid])
            keep = backing_faces(v, f, n, eye, grazing_cos)
            d[f"{sid}-backing"] = _ply(f"{sid}-backing", v + (sag + float(offset_mm)) * n, f[keep])
        return d

    return dataclasses.replace(spec, name=f"{spec.name}-backed" + (f"{grazing_cos:g}" if grazing_cos else ""),
                               description=f"{spec.description}; black backing behind the unseen surface",
                               shapes=shapes)


def short_axis(verts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centre, unit axis): the vertices' centroid and the principal axis of least spread (the
    eigenvector of the smallest eigenvalue of their covariance): a flattened object's thickness axis."""
    c = verts.mean(axis=0)
    w, v = np.linalg.eigh(np.cov((verts - c).T))
    return c, v[:, 0] / np.linalg.norm(v[:, 0])


def deepen_mesh(verts: np.ndarray, normals: np.ndarray, eye, factor: float) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, unit normals) of a mesh whose half beyond its mid-plane (through the centroid, normal to
    :func:`short_axis`) on the side away from ``eye`` is stretched by ``factor`` along that axis:
    v' = v + (factor - 1) ((v - c) . a) a there (vertices on the mid-plane, to rounding, stay). Normals
    of the stretched half transform with the inverse transpose, n' ~ n + (1 / factor - 1) (n . a) a; the other half is returned unchanged."""
    c, a = short_axis(verts)
    if np.dot(np.asarray(eye, float) - c, a) > 0:  # a points away from the camera
        a = -a
    h = (verts - c) @ a
    back = h > 1e-9 * float(np.ptp(h))  # the vertices on the mid-plane stay where they are
    v = verts.copy()
    v[back] += (factor - 1.0) * h[back, None] * a
    n = normals.copy()
    n[back] += (1.0 / factor - 1.0) * (n[back] @ a)[:, None] * a
    n[back] /= np.linalg.norm(n[back], axis=1, keepdims=True)
    return v, n


def deepened_scene(scene: str | SceneSpec, factor: float, frame: int = 0) -> SceneSpec:
    """``scene`` with each SSS mesh's half facing away from the camera (at ``frame``) ``factor`` times
    deeper along the mesh's shortest axis (:func:`deepen_mesh`; module docstring): the ear's 2 mm back
    half becomes 2 ``factor`` mm, its seen half and the G-buffer stay the same. A SceneError for an
    SSS shape that is not a PLY mesh. Named ``<name>-deep<factor>``."""
    spec = get_scene(scene)
    k = float(SCALE.check(factor, "the depth factor", SceneError))
    if k < 1:
        raise SceneError(f"the depth factor must be at least 1, got {factor!r}")
    base = spec.shapes()
    for sid in spec.sss_shapes:
        if base[sid].get("type") != "ply":
            raise SceneError(f"cannot deepen SSS shape {sid!r} of type {base[sid].get('type')!r} (a PLY mesh)")
    eye = camera_pose(spec, frame)[0]

    def shapes() -> dict[str, dict]:
        d = spec.shapes()
        for sid in spec.sss_shapes:
            v, f, n = _read_ply(d[sid]["filename"])  # the stored normals: the seen half is written back bit for bit
            v2, n2 = deepen_mesh(v, _vertex_normals(v, f) if n is None else n, eye, k)
            d[sid] = _ply(f"{sid}-deep", v2, f, n2)
        return d

    return dataclasses.replace(spec, name=f"{spec.name}-deep{k:g}",
                               description=f"{spec.description}; its unseen half {k:g} x deeper", shapes=shapes)


__all__ = ["BACKING_OFFSET_MM", "backed_scene", "backing_faces", "box_thickness_mm", "deepen_mesh", "deepened_scene",
           "scaled_scene", "short_axis", "surface_mesh", "thin_scene"]
