"""Meshes made in code, so tests, docs and figures need no download: an icosphere, a torus, and a
head-like bust with thin ears and a nose (:func:`bust`, written once to the ``meshes`` cache as PLY
by :func:`bust_path`).

The bust is the zero level set of a signed distance field built from implicit primitives
(ellipsoids, capsules, a half-space cut) joined by a smooth minimum, polygonised by marching cubes
([LLVT03], :func:`skimage.measure.marching_cubes`), with normals from the field's
gradient. Conventions of every generated mesh: mm, +Y up, the model faces +Z (glTF's convention).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from ..cache import cache_dir
from ..errors import SceneError
from ..quantities import LENGTH_MM, Quantity, checks
from ..io import atomic_output
from .meshes import Mesh, ply_bytes

#: bumped when the bust's shape changes (its cache file name carries it)
BUST_VERSION = 2
#: an icosphere's subdivisions (each splits every triangle in four)
SUBDIVISIONS = Quantity("subdivisions", 0, 8, "", "20 x 4^8 = 1.3 M faces", integer=True)


@checks(SceneError, subdivisions=(SUBDIVISIONS, "icosphere subdivisions"), radius=(LENGTH_MM, "icosphere radius"))
def icosphere(subdivisions: int = 2, radius: float = 1.0, name: str = "icosphere") -> Mesh:
    """A sphere of ``radius`` from an icosahedron whose triangles are split in four ``subdivisions``
    times, new vertices pushed onto the sphere; 20 * 4^n faces, outward winding, exact normals."""
    t = (1.0 + 5.0**0.5) / 2.0
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                  [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
                  [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
                  [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], np.int64)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for _ in range(subdivisions):
        edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
        key = np.sort(edges, axis=1)
        uniq, inv = np.unique(key, axis=0, return_inverse=True)
        mid = v[uniq[:, 0]] + v[uniq[:, 1]]
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = inv.reshape(3, -1) + len(v)  # midpoints of edges 01, 12, 20 of each face
        v = np.concatenate([v, mid])
        a, b, c = f[:, 0], f[:, 1], f[:, 2]
        f = np.concatenate([np.stack([a, m[0], m[2]], 1), np.stack([b, m[1], m[0]], 1),
                            np.stack([c, m[2], m[1]], 1), np.stack([m[0], m[1], m[2]], 1)])
    return Mesh(name, v * radius, f, v)


#: segments of a torus's ring and of its tube
TORUS_SEGMENTS = Quantity("segments", 3, 4096, "", "a ring of at least three; 4096 x 4096 is 33 M faces", integer=True)


@checks(SceneError, n_major=(TORUS_SEGMENTS, "torus segments"), n_minor=(TORUS_SEGMENTS, "torus segments"))
def torus(major: float = 1.0, minor: float = 0.3, n_major: int = 48, n_minor: int = 24, name: str = "torus") -> Mesh:
    """A torus about the +Y axis: tube radius ``minor`` around a circle of radius ``major``, an
    ``n_major`` x ``n_minor`` grid wrapped in both directions (closed, genus 1), outward winding."""
    Quantity("minor", 0.0, major, "", "the tube's radius, inside the ring's (major)", lo_open=True, hi_open=True).check(
        minor, "torus minor radius", SceneError)
    u = np.arange(n_major) * (2 * np.pi / n_major)
    w = np.arange(n_minor) * (2 * np.pi / n_minor)
    U, W = np.meshgrid(u, w, indexing="ij")
    ring = np.stack([np.cos(U), np.zeros_like(U), np.sin(U)], axis=-1)
    normal = ring * np.cos(W)[..., None] + np.array([0.0, 1.0, 0.0]) * np.sin(W)[..., None]
    verts = (ring * major + normal * minor).reshape(-1, 3)
    i = np.arange(n_major)[:, None]
    j = np.arange(n_minor)[None, :]
    a = (i * n_minor + j).ravel()
    b = (((i + 1) % n_major) * n_minor + j).ravel()
    c = (((i + 1) % n_major) * n_minor + (j + 1) % n_minor).ravel()
    d = (i * n_minor + (j + 1) % n_minor).ravel()
    faces = np.concatenate([np.stack([a, d, c], 1), np.stack([a, c, b], 1)])
    return Mesh(name, verts, faces, normal.reshape(-1, 3))


# ---- the bust --------------------------------------------------------------------------------------------

def _ellipsoid(p: np.ndarray, centre: Sequence[float], radii: Sequence[float]) -> np.ndarray:
    """Approximate signed distance to an ellipsoid: k0 (k0 - 1) / k1 with k0 = |p/r|, k1 = |p/r^2|
    (Quilez, "Ellipsoid SDF", exact on the surface, a bound elsewhere)."""
    q = p - np.asarray(centre, np.float32)
    r = np.asarray(radii, np.float32)
    k0 = np.linalg.norm(q / r, axis=-1)
    k1 = np.linalg.norm(q / (r * r), axis=-1)
    return k0 * (k0 - 1.0) / np.maximum(k1, 1e-12)


def _capsule(p: np.ndarray, a: Sequence[float], b: Sequence[float], radius: float) -> np.ndarray:
    """Signed distance to a capsule: the segment a-b swept by a ball of ``radius``."""
    a0 = np.asarray(a, np.float32)
    ab = np.asarray(b, np.float32) - a0
    h = np.clip(((p - a0) @ ab) / float(ab @ ab), 0.0, 1.0)
    return np.linalg.norm(p - a0 - h[..., None] * ab, axis=-1) - radius


def _smooth_min(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Polynomial smooth minimum of two distances with blend width ``k`` (Quilez, "smooth minimum")."""
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b + (a - b) * h - k * h * (1.0 - h)


def bust_sdf(p: np.ndarray) -> np.ndarray:
    """Signed distance (mm, negative inside) of the bust at points ``p`` (..., 3): a head (skull and jaw
    ellipsoids), a nose (capsule), two ears (plates 5 mm thick at most, standing off the head and
    joined to it by a capsule along their front edge), a neck (capsule) and
    shoulders (an ellipsoid cut flat at y = -30 mm), smoothly joined."""
    p = np.asarray(p, np.float32)
    head = _smooth_min(_ellipsoid(p, (0, 175, 0), (72, 98, 88)), _ellipsoid(p, (0, 128, 22), (52, 42, 58)), 20.0)
    nose = _capsule(p, (0, 168, 78), (0, 146, 100), 11.0)
    head = _smooth_min(head, nose, 8.0)
    for side in (-1.0, 1.0):  # a plate standing 12 mm off the head, joined to it along its front edge
        ear = _smooth_min(_ellipsoid(p, (side * 86, 165, -8), (2.5, 30.0, 18.0)),
                          _capsule(p, (side * 66, 165, 4), (side * 85, 165, 4), 6.0), 2.0)
        head = _smooth_min(head, ear, 3.0)
    neck = _capsule(p, (0, 40, -5), (0, 120, -5), 44.0)
    shoulders = np.maximum(_ellipsoid(p, (0, 0, -5), (150, 48, 72)), -30.0 - p[..., 1])
    body = _smooth_min(neck, shoulders, 25.0)
    return _smooth_min(head, body, 15.0)


def _narrow_band_field(sdf: Callable[[np.ndarray], np.ndarray], axes: list[np.ndarray], h: float,
                       block: int = 6) -> np.ndarray:
    """``sdf`` sampled on the grid of ``axes`` (spacing ``h``) where it matters to marching cubes: the
    field is evaluated at the centre of each ``block``^3 group of nodes, and at every node only of
    the groups whose centre lies within 1.5 x their half-diagonal (+ 2 h) of the surface (a distance
    field changes by at most the distance moved; 1.5 covers the ellipsoids' approximate distance);
    elsewhere a node takes its group centre's value, whose sign it shares."""
    shape = tuple(len(a) for a in axes)
    nb = tuple(-(-n // block) for n in shape)
    centres = [a[0] + (np.arange(m) * block + (block - 1) / 2) * h for a, m in zip(axes, nb)]
    cgrid = np.stack(np.meshgrid(*centres, indexing="ij"), axis=-1).astype(np.float32)
    coarse = sdf(cgrid)
    near = np.abs(coarse) < 1.5 * (0.5 * np.sqrt(3.0) * block * h) + 2 * h
    field = np.repeat(np.repeat(np.repeat(coarse, block, 0), block, 1), block, 2)[:shape[0], :shape[1], :shape[2]]
    field = np.ascontiguousarray(field, dtype=np.float32)
    offs = np.stack(np.meshgrid(*[np.arange(block)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    idx = (np.argwhere(near)[:, None, :] * block + offs[None]).reshape(-1, 3)
    idx = idx[np.all(idx < np.array(shape), axis=1)]
    pts = np.stack([axes[k][idx[:, k]] for k in range(3)], axis=-1)
    field[idx[:, 0], idx[:, 1], idx[:, 2]] = sdf(pts)
    return field


#: the bust's voxel size
VOXEL_MM = Quantity("voxel size", 0.5, 10.0, "mm", "a bust of seconds to build, whose features survive")


@checks(SceneError, voxel_mm=(VOXEL_MM, "bust voxel size"))
def bust(voxel_mm: float = 1.5) -> Mesh:
    """The bust (:func:`bust_sdf`) polygonised on a ``voxel_mm`` grid by marching cubes: a closed
    2-manifold about 300 mm wide and 305 mm tall, outward winding, normals from the field's
    central-difference gradient."""
    from skimage.measure import marching_cubes

    lo = np.array([-160.0, -40.0, -85.0])
    hi = np.array([160.0, 280.0, 120.0])
    axes = [np.arange(lo[i] - 2 * voxel_mm, hi[i] + 2 * voxel_mm, voxel_mm, dtype=np.float32) for i in range(3)]
    field = _narrow_band_field(bust_sdf, axes, voxel_mm)
    field[[0, -1], :, :] = field[:, [0, -1], :] = field[:, :, [0, -1]] = 1.0  # closed at the box
    verts, faces, _, _ = marching_cubes(field, level=0.0, spacing=(voxel_mm,) * 3, method="lewiner")
    verts = verts + np.array([a[0] for a in axes])
    e = 0.25 * voxel_mm
    grad = np.stack([bust_sdf(verts + d) - bust_sdf(verts - d) for d in np.eye(3) * e], axis=-1)
    normals = grad / np.maximum(np.linalg.norm(grad, axis=1, keepdims=True), 1e-12)
    mesh = Mesh("bust", verts, faces, normals)
    tri = mesh.vertices.astype(np.float64)[mesh.faces.astype(np.int64)]
    if np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() < 0:  # signed volume < 0
        mesh = Mesh("bust", mesh.vertices, mesh.faces[:, ::-1], normals)
    return mesh


@functools.lru_cache(maxsize=None)
@checks(SceneError, voxel_mm=(VOXEL_MM, "bust voxel size"))  # (its file is named by it: before bust's own check)
def bust_path(voxel_mm: float = 1.5) -> Path:
    """The bust as a binary PLY in the ``meshes`` cache, generated on first use (a few seconds)."""
    path = cache_dir("meshes") / f"bust-v{BUST_VERSION}-{voxel_mm:g}mm.ply"
    if not path.is_file():
        m = bust(voxel_mm)
        with atomic_output(path) as tmp:
            tmp.write_bytes(ply_bytes(m.vertices, m.faces, m.normals))
    return path


__all__ = ["BUST_VERSION", "bust", "bust_path", "bust_sdf", "icosphere", "torus"]
