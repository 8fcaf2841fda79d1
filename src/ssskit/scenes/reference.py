"""Path-traced references of the built-in scenes: the SSS objects as a homogeneous medium inside their
rough dielectric boundary, rendered by Mitsuba 3 ``volpathmis`` and cached on disk.

What the screen-space result is compared with: it also contains what no screen-space method has
(light through thin parts, Fresnel at entry and exit, curvature, light from behind the silhouette).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from ..cache import cache_dir
from ..errors import SceneError
from ..io import atomic_output
from .scenes import COAT_ROUGHNESS, FLOOR_ALBEDO, SCENES, check_size, check_spp, render_dict, scene_dict

#: bumped when the reference renders change (invalidates the cache)
CACHE_VERSION = 2


def reference_cache_dir() -> Path:
    """Where references are cached: ``cache_dir("reference")``."""
    return cache_dir("reference")


def reference_phase_g(material) -> float:
    """The one Henyey-Greenstein g of ``material`` for the reference's medium, or a SceneError.

    Mitsuba's ``hg`` phase function takes a single g, so a material whose g differs between channels
    (or a layered material, which is no single medium) cannot be path-traced as it is.
    """
    for attr in ("sigma_a", "sigma_s", "g", "eta"):
        if not hasattr(material, attr):
            raise SceneError(f"the path-traced reference needs a homogeneous material (sigma_a, sigma_s, g, eta); "
                             f"{getattr(material, 'name', material)!r} is a {type(material).__name__}")
    g = np.asarray(material.g, dtype=float)
    if np.ptp(g) > 0:
        raise SceneError(f"the path-traced reference takes one Henyey-Greenstein g (Mitsuba's hg phase function), "
                         f"but material {material.name!r} has g = {g.tolist()} per channel")
    return float(g.flat[0])


def render_reference(scene: str, material, width: int = 128, height: int = 96, spp: int = 64, max_depth: int = 1024,
                     seed: int = 0, frame: int = 0, chunk_spp: int = 8, use_cache: bool = True,
                     progress: bool = True) -> np.ndarray:
    """Volumetric path-traced image (H, W, 3) of the scene at ``frame``.

    The SSS objects are a homogeneous medium with the material's sigma_a, sigma_s (mm^-1 = per world
    unit) and Henyey-Greenstein g (one value: :func:`reference_phase_g`), inside a rough dielectric of
    index eta (Mitsuba ``roughdielectric``, Beckmann alpha = :data:`COAT_ROUGHNESS`, the same boundary
    as the G-buffer's specular layer); Mitsuba ``volpathmis`` with a high ``max_depth`` (high-albedo
    media need long random walks). Rendered in chunks of ``chunk_spp`` (a progress bar with
    ``progress``) and cached in :func:`reference_cache_dir`, keyed by every input.
    """
    spec = SCENES.get(scene)
    check_size(width, height)
    check_spp(spp)
    g = reference_phase_g(material)
    key = json.dumps({"scene": spec.name, "sa": list(material.sigma_a), "ss": list(material.sigma_s), "g": g,
                      "eta": material.eta, "w": width, "h": height, "spp": spp, "d": max_depth, "seed": seed,
                      "frame": frame, "v": CACHE_VERSION,
                      "geometry": json.dumps([spec.shapes(), spec.lights(), spec.origin, spec.fov_x_deg], default=str)},
                     sort_keys=True)
    path = reference_cache_dir() / f"{spec.name}-{hashlib.sha1(key.encode()).hexdigest()[:16]}.npy"
    if use_cache and path.is_file():
        return np.load(path)
    sigma_t = np.asarray(material.sigma_a, float) + np.asarray(material.sigma_s, float)
    scale = float(sigma_t.max())
    if scale <= 0:
        raise SceneError("the material has no extinction (sigma_a + sigma_s = 0)")
    single = np.where(sigma_t > 0, np.asarray(material.sigma_s, float) / np.maximum(sigma_t, 1e-300), 0.0)
    # RGB values of a Mitsuba medium must lie in [0, 1]: sigma_t is given relative to its maximum
    medium = {"type": "homogeneous", "sigma_t": {"type": "rgb", "value": (sigma_t / scale).tolist()},
              "albedo": {"type": "rgb", "value": single.tolist()}, "phase": {"type": "hg", "g": g}, "scale": scale}
    boundary = {"type": "roughdielectric", "int_ior": float(material.eta), "ext_ior": float(material.eta_ambient),
                "distribution": "beckmann", "alpha": COAT_ROUGHNESS}
    grey = {"type": "diffuse", "reflectance": {"type": "rgb", "value": FLOOR_ALBEDO}}

    def bsdf_for(sid):
        return {**boundary, "__medium": medium} if sid in spec.sss_shapes else grey

    integrator = {"type": "volpathmis", "max_depth": int(max_depth)}
    chunks = [chunk_spp] * (spp // chunk_spp) + ([spp % chunk_spp] if spp % chunk_spp else [])
    from tqdm import tqdm

    acc = np.zeros((height, width, 3))
    for i, n in enumerate(tqdm(chunks, desc=f"path tracing {spec.name} ({spp} spp)", unit="chunk",
                               disable=not progress)):
        img = render_dict(scene_dict(spec, width, height, n, seed * 1000 + i, frame, integrator, bsdf_for))
        acc += img[..., :3] * n
    out = (acc / spp).astype(np.float32)
    if use_cache:
        with atomic_output(path) as tmp:
            with open(tmp, "wb") as fh:
                np.save(fh, out)
    return out
