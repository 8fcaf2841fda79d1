"""Inputs of the passes: procedural test signals (irradiance images) and built-in 3D scenes rendered by
Mitsuba 3 into G-buffers, with camera/light paths over frames and path-traced references.

* :mod:`.signals`: ``make_signal(name, size)`` for the kernel evaluations (:data:`SIGNALS`);
* :mod:`.scenes`: the scene registry :data:`SCENES` (:class:`SceneSpec`: geometry, lights, camera),
  ``scene_camera``, ``scene_lights`` and the Mitsuba scene dictionaries;
* :mod:`.scenefile`: scene files (TOML; the built-in scenes are written in it), mesh scenes with
  automatic framing, ``--view`` and key/fill/back lights, and ``resolve_scene`` (a ``--scene`` value);
* :mod:`.meshes`: mesh files (OBJ, PLY, glTF), their checks and writers; :mod:`.generated`: the
  icosphere, torus and head-like bust made in code;
* :mod:`.gbuffers`: ``render_gbuffer`` (one frame) and ``render_sequence`` (consecutive frames);
* :mod:`.reference`: ``render_reference``, a volumetric path trace of the same scene in independent
  chunks until a region's standard error is small (:class:`Reference`), cached.

Mitsuba is imported when a scene is first rendered, not here.
"""

from ..errors import SceneError
from .gbuffers import render_gbuffer, render_sequence
from .reference import Reference, reference_cache_dir, reference_phase_g, render_reference, sss_region
from .scenefile import GENERATED_SCENES, ResolvedScene, load_scene_file, resolve_scene
from .scenes import (COAT_ROUGHNESS, FLOOR_ALBEDO, SCENES, SceneSpec, camera_pose, front_lit_scenes, scene_camera,
                     scene_lights)
from .signals import SIGNALS, make_signal

__all__ = [
    "COAT_ROUGHNESS",
    "FLOOR_ALBEDO",
    "GENERATED_SCENES",
    "Reference",
    "ResolvedScene",
    "SCENES",
    "SIGNALS",
    "SceneError",
    "SceneSpec",
    "camera_pose",
    "front_lit_scenes",
    "load_scene_file",
    "make_signal",
    "reference_cache_dir",
    "reference_phase_g",
    "render_gbuffer",
    "render_reference",
    "render_sequence",
    "resolve_scene",
    "scene_camera",
    "scene_lights",
    "sss_region",
]
