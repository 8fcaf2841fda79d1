"""The head in Blender: Cycles and EEVEE Next render ssskit's Blender export on the scanned head (the mesh ssskit
renders, in its mm scale; one of its views; its key light), and what they show is measured against each other.

:func:`render_head` writes the job (``head_scene.py``'s CONFIG) and runs it in a Python that has ``bpy``
(:func:`ssskit.export.blender.find_blender_python`), as the slab's runner does. :func:`compare_head` renders one
exported material in both engines with the key light casting no shadow, so the light ends only at the terminator
(N . L = 0), the same line in both, and measures with :func:`spill` what a screen-space pass and a path tracer
must agree on: the light that leaves the skin where the key light does not reach (the pixels both engines' white
references leave unlit, :func:`dark_mask`). It is 0 without subsurface transport and grows with the profile's
width d (as d past a step of light, as d^2 past the terminator's ramp; Burley's profile R(r; d) = f(r / d) / d^2,
Xie 2020 Eq. 4 [XOKN20]). Summed over thousands of pixels it is far steadier than an edge distance.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..quantities import Choice
from .blender import run_bpy_job

#: the head's key light (the scene's ``key``: E / pi = 1 at the head's centre)
KEY_LIGHT = "key"
#: the white reference's level (of its 98th percentile over the head) below which a pixel counts as unlit
UNLIT = 1e-3


def head_job(view: str = "close") -> dict[str, Any]:
    """The head's geometry for ``head_scene.py``: the mesh file's arrays in metres (ssskit's head_mesh, mm,
    times 1e-3), the camera of view ``view`` and the key light (intensity in W/sr: the scene's mm^2 value
    times 1e-6), from the built-in scene ``head`` (src/ssskit/scenes/builtin/head.toml)."""
    from ..scenes.head import head_mesh
    from ..scenes.scenes import get_scene, scene_lights

    spec = get_scene("head")
    views = dict(spec.views)
    view = Choice("the head's view", list(views)).check(view)
    origin, target, up, fov = views[view]
    light = scene_lights(spec)[KEY_LIGHT]
    mesh = head_mesh()
    return {"arrays": {"vertices": (mesh.vertices.astype(np.float64) * 1e-3).astype(np.float32),
                       "faces": np.asarray(mesh.faces, dtype=np.int32),
                       "normals": np.asarray(mesh.normals, dtype=np.float32)},
            "camera": {"origin": [v * 1e-3 for v in origin], "target": [v * 1e-3 for v in target],
                       "up": list(up), "fov_x_deg": float(fov)},
            "light": {"position": [v * 1e-3 for v in light["position"]],
                      "intensity": float(light["intensity"]["value"]) * 1e-6},
            "view": view}


def render_head(renders: list[dict[str, Any]], view: str = "close", shadow: bool = True, timeout: float = 900.0,
                python: str | None = None) -> dict[str, Any]:
    """Render ``renders`` (``head_scene.py``'s job list: ``key``, ``engine``, ``width``, ``height``,
    ``samples``, ``seed``, ``script`` and ``variant`` or ``white``) on the head's view ``view`` in one bpy process.
    Returns {"images": {key: (H, W, 3) float32 linear}, "seconds": {key: s}, "blender": version}; nothing is
    kept of a render that failed or was interrupted."""
    job = head_job(view)
    images, meta = run_bpy_job(Path(__file__).with_name("head_scene.py"),
                               {"camera": job["camera"], "light": {**job["light"], "shadow": shadow},
                                "renders": renders}, "the head render", timeout, python, arrays={"mesh": job["arrays"]})
    return {"images": {r["key"]: images[r["key"]] for r in renders}, "seconds": meta["seconds"],
            "blender": meta["blender"], "view": view}


def dark_mask(whites: list[np.ndarray], level: float = UNLIT) -> np.ndarray:
    """The pixels every white reference (E / pi, (H, W, 3) or (H, W)) leaves unlit: below ``level`` times the 98th
    percentile of the first. Cycles zeroes light where the geometric normal faces away from it, EEVEE where the
    shading normal does, so each engine's N . L = 0 line is a pixel or two from the other's: the common mask
    compares the same pixels."""
    ws = [np.asarray(w, dtype=float) for w in whites]
    ws = [w.mean(axis=2) if w.ndim == 3 else w for w in ws]
    ref = float(np.percentile(ws[0], 98))
    return np.logical_and.reduce([w <= level * ref for w in ws])


def spill(image: np.ndarray, albedo: np.ndarray, dark: np.ndarray) -> np.ndarray:
    """Per channel, the light that leaves the skin where the key light does not reach, over the albedo:
    sum over ``dark`` of I_c / A_c (in pixels times E / pi). Without subsurface transport it is 0 (a Lambertian
    surface is black where E = 0); with it, it is the light that crossed the terminator (or a shadow's edge),
    which grows with the profile's width d: as d for a step of light (the light past a line, the integral of the
    edge response F(u) over u > 0, is 2.5 d / pi for Burley's untruncated profile, Xie 2020 Eq. 4: its mean
    radius 2.5 d over pi), as d^2 for a ramp that starts at the line (the terminator's E = E' max(x, 0): the
    light past it is E' times the profile's second moment of x, proportional to d^2)."""
    img = np.asarray(image, dtype=float)
    return np.array([float(img[..., c][dark].sum()) / float(albedo[c]) for c in range(3)])


def plateau(image: np.ndarray, white: np.ndarray, albedo: np.ndarray, level: float = 0.5) -> np.ndarray:
    """Per channel, the lit pixels' light over the white reference's times the albedo: sum I_c / (A_c sum E/pi)
    over the pixels lit above ``level`` times the white's 98th percentile (1 where the renderer keeps the
    exported albedo and little light leaves the lit part)."""
    w = np.asarray(white, dtype=float)
    w = w.mean(axis=2) if w.ndim == 3 else w
    lit = w > level * float(np.percentile(w, 98))
    img = np.asarray(image, dtype=float)
    return np.array([float(img[..., c][lit].sum()) / (float(albedo[c]) * float(w[lit].sum())) for c in range(3)])


def compare_head(script: str | Path, albedo: np.ndarray, width: int = 160, height: int = 120, view: str = "close",
                 taa: int = 64, spp: int = 64, repeats: int = 3, variants: tuple[str, ...] = ("cycles", "eevee"),
                 seed: int = 1, python: str | None = None, timeout: float = 1800.0) -> dict[str, Any]:
    """Cycles (``spp``, the Cycles export) and EEVEE Next (``taa`` TAA render samples, each variant ``repeats``
    times: EEVEE on llvmpipe differs run to run) render the exported ``script`` on the head's view ``view``
    under its key light with no cast shadow (``head_scene.py``: the light ends at the terminator, the same line
    in both), in one bpy process, with a white reference per engine. Returns per variant and repeat EEVEE's
    :func:`spill` over Cycles' (per channel) and its :func:`plateau`, Cycles' plateau, the pixel counts, the
    seconds and Blender's version."""
    e = "BLENDER_EEVEE_NEXT"
    size = {"width": width, "height": height}
    renders = [{"key": "cycles_white", "engine": "CYCLES", "samples": 16, "seed": seed, "white": True, **size},
               {"key": "cycles", "engine": "CYCLES", "samples": spp, "seed": seed, "script": str(script),
                "variant": "cycles", **size},
               {"key": "eevee_white", "engine": e, "samples": taa, "seed": seed, "white": True, **size}]
    for k in range(repeats):
        renders += [{"key": f"{v}_{k}", "engine": e, "samples": taa, "seed": seed, "script": str(script),
                     "variant": v, **size} for v in variants]
    out = render_head(renders, view, shadow=False, timeout=timeout, python=python)
    img = out["images"]
    a = np.asarray(albedo, dtype=float)
    dark = dark_mask([img["cycles_white"], img["eevee_white"]])
    ref = spill(img["cycles"], a, dark)
    runs = {v: [{"spill_ratio": (spill(img[f"{v}_{k}"], a, dark) / ref).tolist(),
                 "plateau": plateau(img[f"{v}_{k}"], img["eevee_white"], a).tolist()} for k in range(repeats)]
            for v in variants}
    return {"view": view, "width": width, "height": height, "taa": taa, "spp": spp, "repeats": repeats,
            "dark_pixels": int(dark.sum()), "cycles_spill": ref.tolist(),
            "cycles_plateau": plateau(img["cycles"], img["cycles_white"], a).tolist(), "eevee": runs,
            "seconds": out["seconds"], "blender": out["blender"]}


__all__ = ["KEY_LIGHT", "UNLIT", "compare_head", "dark_mask", "head_job", "plateau", "render_head", "spill"]
