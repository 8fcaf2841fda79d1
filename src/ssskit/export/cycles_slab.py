"""The Cycles slab scene: a standalone script run by a Python that has ``bpy`` (Blender 4.2's wheel), never
imported by ssskit (it needs only bpy and numpy).

    python cycles_slab.py CONFIG.json OUT.npz

A thick box (the slab, its top face at z = 0) carries the material that an exported ssskit Blender script
creates; a sun straight down (angle 0: a sharp shadow) is blocked for x < 0 by a plane seen only by shadow
rays; an orthographic camera looks straight down at the strip x in [-extent, extent]; Cycles on the CPU,
box pixel filter, no denoising, no adaptive sampling, black world, Standard view transform, float EXR.
Each render of CONFIG's ``renders`` list (``script``: the exported material script, ``extent_m``,
``width`` x ``height`` pixels, ``samples``, ``seed``, optional ``method`` to override the subsurface
method) is written as an (H, W, 3) float32 array; ``white`` renders the same view with a white Lambertian
material (Diffuse BSDF, colour 1): the irradiance reference E / pi of the plateau.

``engine`` "BLENDER_EEVEE_NEXT" renders the same view in EEVEE Next (``samples``: its TAA render samples;
``variant``: the exported script's "cycles" or "eevee" radius); its edge is then a spot cone's rim
(``light`` "SPOT", the default; "SUN" keeps the sun, which EEVEE renders without the blocker's shadow).
"""

from __future__ import annotations

import json
import math
import os
import runpy
import sys
import tempfile
import time
from typing import Any

import bpy
import numpy as np


def _eevee(scene: Any, samples: int, job: dict[str, Any]) -> None:
    """EEVEE Next's render settings: ``samples`` TAA render samples; ``sss_samples`` is set but EEVEE Next
    4.2 gathers 16 samples per pixel whatever it says (docs/engines/eevee-sss-albedo-fit.md); film filter
    ``filter_size`` (0 by default: each pixel its own samples); no raytracing or AO; shadows on."""
    eevee = scene.eevee
    eevee.taa_render_samples = samples
    eevee.sss_samples = int(job.get("sss_samples", 7))
    eevee.sss_jitter_threshold = float(job.get("sss_jitter_threshold", 0.3))
    eevee.use_raytracing = False
    eevee.use_gtao = False
    # never write the deprecated ``use_bloom`` (EEVEE Next has no bloom): in bpy 4.2.0 setting it False also clears
    # use_shadows, use_soft_shadows and use_taa_reprojection, and EEVEE then casts no shadow at all
    # (docs/engines/eevee-sun-shadow.md)
    eevee.use_shadows = True
    scene.render.filter_size = float(job.get("filter_size", 0.0))


def _spot_edge(scene: Any, extent: float, sun: Any, blocker: Any) -> None:
    """EEVEE Next renders no shadow of the blocker under this sun (docs/engines/eevee-sun-shadow.md), so its edge is the hard rim of a spot cone instead: a point spot
    (radius 0, blend 0) at height H = 1000 extent straight down, its axis at x = R = 100 extent, so the
    cone's rim crosses the view at x = 0 (lit for x > 0). Across the view the rim's curvature moves it by
    (h / 2)^2 / (2 R) < 1e-4 extent and the irradiance varies by 3 R / H^2 < 4e-4 per extent (cos^3 / H^2);
    the white reference render divides out what remains. Its power gives about 1 W/m^2 at the slab."""
    bpy.data.objects.remove(blocker)
    bpy.data.objects.remove(sun)
    height, rim = 1000.0 * extent, 100.0 * extent
    data = bpy.data.lights.new("spot", type="SPOT")
    data.shadow_soft_size = 0.0
    data.spot_blend = 0.0
    data.spot_size = 2.0 * math.atan(rim / height)
    data.energy = 4.0 * math.pi * height**2  # a spot's intensity is a point light's of the same power
    data.use_shadow = False
    spot = bpy.data.objects.new("spot", data)
    spot.location = (rim, 0.0, height)
    scene.collection.objects.link(spot)


def _settings(scene: Any, engine: str, width: int, height: int, samples: int, seed: int, threads: int) -> None:
    """The render settings every ssskit bpy scene shares (this slab, ``head_scene.py``): ``engine``; Cycles on
    the CPU with ``samples`` and ``seed``, box pixel filter, no denoising or adaptive sampling; ``threads``;
    the size; Standard view transform (no tone mapping); float EXR; a black world."""
    scene.render.engine = engine
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.seed = seed
    scene.cycles.use_animated_seed = False
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = False
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 1.0
    scene.cycles.max_bounces = 8
    scene.cycles.caustics_reflective = False
    scene.cycles.caustics_refractive = False
    scene.render.threads_mode = "FIXED"
    scene.render.threads = threads
    scene.render.resolution_x = width
    scene.render.resolution_y = height
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    world = bpy.data.worlds.new("black")
    world.use_nodes = False
    world.color = (0.0, 0.0, 0.0)
    scene.world = world


def _scene(extent: float, width: int, height: int, samples: int, seed: int, threads: int,
           job: dict[str, Any] | None = None) -> tuple[Any, Any]:
    job = job or {}
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    engine = job.get("engine", "CYCLES")
    _settings(scene, engine, width, height, samples, seed, threads)
    # the slab: a box much wider than the view and deep enough for any walk (top face at z = 0)
    size = 40.0 * extent
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, -size / 2.0))
    slab = bpy.context.active_object
    slab.scale = (size, size, size)
    slab.name = "slab"
    # the blocker: x < 0, seen by shadow rays only
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(-size / 4.0, 0.0, 0.05 * extent))
    blocker = bpy.context.active_object
    blocker.scale = (size / 2.0, size, 1.0)
    for attr in ("visible_camera", "visible_diffuse", "visible_glossy", "visible_transmission",
                 "visible_volume_scatter"):
        setattr(blocker, attr, False)
    # the sun: straight down, strength 1 (W/m^2 of irradiance), angle 0 (a delta light: a sharp edge)
    sun_data = bpy.data.lights.new("sun", type="SUN")
    sun_data.energy = 1.0
    sun_data.angle = 0.0
    sun = bpy.data.objects.new("sun", sun_data)
    scene.collection.objects.link(sun)
    # the camera: orthographic, straight down; ortho_scale spans the image width (2 extent)
    cam_data = bpy.data.cameras.new("camera")
    cam_data.type = "ORTHO"
    cam_data.ortho_scale = 2.0 * extent
    cam_data.sensor_fit = "HORIZONTAL"
    cam_data.clip_start = 1e-4 * extent
    cam_data.clip_end = 10.0 * extent
    cam = bpy.data.objects.new("camera", cam_data)
    cam.location = (0.0, 0.0, 1.0 * extent)
    scene.collection.objects.link(cam)
    scene.camera = cam
    if engine != "CYCLES":
        _eevee(scene, samples, job)
        if job.get("light", "SPOT") == "SPOT":
            _spot_edge(scene, extent, sun, blocker)
            scene.eevee.use_shadows = False  # the spot casts none; EEVEE's shadow maps cost ~3x on llvmpipe
        elif "shadow_texel" in job:  # the sun kept (light "SUN"): its virtual shadow map's finest texel
            sun_data.shadow_maximum_resolution = float(job["shadow_texel"])
    return scene, slab


def _render(scene: Any, path: str) -> np.ndarray:
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(path)
    w, h = img.size
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(h, w, 4)[::-1, :, :3].copy()  # Blender's rows run bottom-up


def _white() -> Any:
    mat = bpy.data.materials.new("white")
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    diff = nodes.new("ShaderNodeBsdfDiffuse")
    diff.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    diff.inputs["Roughness"].default_value = 0.0
    mat.node_tree.links.new(diff.outputs["BSDF"], out.inputs["Surface"])
    return mat


def _job_material(job: dict[str, Any], name: str | None = None) -> Any:
    """A job's material: the white Lambertian (``white``) or the one the exported ``script`` makes (its
    ``variant``; ``method`` overrides the subsurface method), named ``material_name`` or ``name``."""
    if job.get("white"):
        return _white()
    ns = runpy.run_path(job["script"], run_name="ssskit_material")
    mat = ns["ssskit_material"](job.get("material_name") or name, job.get("variant") or "cycles")
    if job.get("method"):
        ns["set_method"](mat, job["method"])
    return mat


def _save(out_path: str, arrays: dict[str, np.ndarray], seconds: dict[str, float]) -> None:
    """OUT.npz (one array per render key) and OUT.npz.json (the seconds per render, Blender's version)."""
    np.savez(out_path, allow_pickle=True, **arrays)  # the default, named so no array can take its place
    with open(out_path + ".json", "w") as fh:
        json.dump({"seconds": seconds, "blender": bpy.app.version_string}, fh)


def main(argv: list[str]) -> int:
    config_path, out_path = argv[0], argv[1]
    with open(config_path) as fh:
        config = json.load(fh)
    threads = int(config.get("threads", 2))
    arrays: dict[str, np.ndarray] = {}
    seconds: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for i, job in enumerate(config["renders"]):
            t0 = time.perf_counter()
            scene, slab = _scene(float(job["extent_m"]), int(job["width"]), int(job["height"]),
                                 int(job["samples"]), int(job["seed"]), threads, job)
            slab.data.materials.clear()
            slab.data.materials.append(_job_material(job))
            arrays[job["key"]] = _render(scene, os.path.join(tmp, f"r{i}.exr"))
            seconds[job["key"]] = time.perf_counter() - t0
    _save(out_path, arrays, seconds)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
