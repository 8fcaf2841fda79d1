"""The head scene in Blender: a standalone script run by a Python that has ``bpy`` (Blender 4.2's wheel), never
imported by ssskit (it needs only bpy, numpy and ``cycles_slab.py`` beside it).

    python head_scene.py CONFIG.json OUT.npz

CONFIG (written by :func:`ssskit.export.blender_head.render_head`): ``mesh``, an ``.npz`` with the head's
``vertices`` (metres: ssskit's mm scale, 259 mm per file unit, times 1e-3), ``faces`` and ``normals`` (the
scan's own, set as custom split normals, every face smooth); ``camera`` (``origin``, ``target``, ``up`` in
metres, ``fov_x_deg``: one of the head's views, a perspective camera whose horizontal field of view is
``fov_x_deg``); ``light`` (``position`` in metres, ``intensity`` in W/sr: the head's key light, a point light of
radius 0, power 4 pi I); ``threads``; and ``renders``, each with ``key``, ``engine`` ("CYCLES" or
"BLENDER_EEVEE_NEXT"), ``width`` x ``height``, ``samples`` (Cycles' spp or EEVEE's TAA render samples),
``seed``, and either ``script`` (an exported ssskit Blender script, applied with its ``variant``) or ``white``
(a white Lambertian: the irradiance reference E / pi). The render settings are the slab's
(``cycles_slab._settings``, ``cycles_slab._eevee``: Standard view transform, float EXR, black world); Cycles
traces ``bounces`` (0 by default: direct light only, as EEVEE without raytracing or probes draws it; the
subsurface walk is not a bounce); with ``light.shadow`` false EEVEE's shadow maps are off as well. Each render
is written as an (H, W, 3) float32 linear array; OUT.npz.json holds the seconds per render and Blender's version.
"""

from __future__ import annotations

import importlib
import json
import math
import os
import sys
import tempfile
import time
from typing import Any

import bpy
import mathutils
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
_slab = importlib.import_module("cycles_slab")  # the slab's script beside this one: its settings, render, white
_eevee, _render, _settings = _slab._eevee, _slab._render, _slab._settings


def _mesh(path: str) -> Any:
    """The head as one smooth-shaded mesh object with the scan's normals as custom split normals."""
    with np.load(path) as z:
        v = np.asarray(z["vertices"], dtype=np.float32)
        f = np.asarray(z["faces"], dtype=np.int32)
        n = np.asarray(z["normals"], dtype=np.float32)
    me = bpy.data.meshes.new("head")
    me.vertices.add(len(v))
    me.vertices.foreach_set("co", v.ravel())
    me.loops.add(3 * len(f))
    me.loops.foreach_set("vertex_index", f.ravel())
    me.polygons.add(len(f))
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * len(f), 3, dtype=np.int32))
    me.update()
    me.polygons.foreach_set("use_smooth", np.ones(len(f), dtype=bool))
    nn = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    me.normals_split_custom_set_from_vertices([tuple(x) for x in nn])
    me.update()
    obj = bpy.data.objects.new("head", me)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _camera(scene: Any, cam: dict[str, Any]) -> None:
    """A perspective camera at ``origin`` looking at ``target`` with ``up`` (Blender's camera looks down its
    local -Z with +Y up), horizontal field of view ``fov_x_deg``."""
    o, t, u = (np.asarray(cam[k], dtype=float) for k in ("origin", "target", "up"))
    fwd = (t - o) / np.linalg.norm(t - o)
    right = np.cross(fwd, u)
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, up, -fwd, o
    data = bpy.data.cameras.new("camera")
    data.type = "PERSP"
    data.sensor_fit = "HORIZONTAL"
    data.angle = math.radians(float(cam["fov_x_deg"]))
    dist = float(np.linalg.norm(t - o))
    data.clip_start = 0.05 * dist
    data.clip_end = 20.0 * dist
    obj = bpy.data.objects.new("camera", data)
    scene.collection.objects.link(obj)
    obj.matrix_world = mathutils.Matrix([list(row) for row in m])
    scene.camera = obj


def _light(scene: Any, light: dict[str, Any]) -> None:
    """The key light: a point light of radius 0 (a sharp shadow) and power 4 pi I; ``shadow`` false: no cast
    shadow (EEVEE's ``use_shadow`` off, the head invisible to Cycles' shadow rays): the light then ends only at
    the terminator, N . L = 0, which both engines draw alike."""
    data = bpy.data.lights.new("key", type="POINT")
    data.shadow_soft_size = 0.0
    data.energy = 4.0 * math.pi * float(light["intensity"])
    data.use_shadow = bool(light.get("shadow", True))
    obj = bpy.data.objects.new("key", data)
    obj.location = tuple(float(x) for x in light["position"])
    scene.collection.objects.link(obj)


def main(argv: list[str]) -> int:
    config_path, out_path = argv[0], argv[1]
    with open(config_path) as fh:
        config = json.load(fh)
    threads = int(config.get("threads", 2))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    head = _mesh(config["mesh"])
    shadow = bool(config["light"].get("shadow", True))
    head.visible_shadow = shadow  # Cycles: no cast shadow either
    _camera(scene, config["camera"])
    _light(scene, config["light"])
    arrays: dict[str, np.ndarray] = {}
    seconds: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for i, job in enumerate(config["renders"]):
            t0 = time.perf_counter()
            engine = job.get("engine", "CYCLES")
            _settings(scene, engine, int(job["width"]), int(job["height"]), int(job["samples"]), int(job["seed"]),
                      threads)
            scene.cycles.max_bounces = int(job.get("bounces", 0))
            if engine != "CYCLES":
                _eevee(scene, int(job["samples"]), job)
                # no cast shadow asked: EEVEE's shadow maps off too (on llvmpipe they cost about 3x the render)
                scene.eevee.use_shadows = shadow
            head.data.materials.clear()
            head.data.materials.append(_slab._job_material(job, f"m{i}"))
            arrays[job["key"]] = _render(scene, os.path.join(tmp, f"r{i}.exr"))
            seconds[job["key"]] = time.perf_counter() - t0
    _slab._save(out_path, arrays, seconds)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
