"""G-buffers of the built-in scenes (:mod:`ssskit.scenes.scenes`), rendered by Mitsuba 3
(``scalar_rgb``, CPU), pixel-aligned, one frame or a sequence along the camera and light paths.

Layers (section 6 of the separable-SSS paper splits the frame the same way):

* ``diffuse``: direct lighting of white Lambertian surfaces (radiance E / pi), shadows included;
* ``specular``: the reflection of the SSS objects' rough dielectric boundary (Mitsuba
  ``roughplastic`` with no diffuse part, Beckmann alpha = :data:`COAT_ROUGHNESS`, interior index =
  the material's eta), black elsewhere;
* ``albedo``: the profile's total diffuse reflectance per channel on SSS objects,
  :data:`FLOOR_ALBEDO` elsewhere, 0 where no surface;
* ``depth``, ``normal``, ``profile_id``: one sample per pixel from Mitsuba's AOV integrator
  (positions converted to linear camera depth with the camera built from the same look-at).
"""

from __future__ import annotations

import inspect
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import SceneError, check_keywords
from ..quantities import FRAME, FRAMES, REFLECTANCE, Quantity, check_shape, checks

#: a surface's refractive index in the G-buffer render (its boundary): positive
INDEX = Quantity("eta", 0.0, 1e6, "", "a refractive index", lo_open=True)
from ..screenspace.gbuffer import GBuffer
from .scenes import (COAT_ROUGHNESS, FLOOR_ALBEDO, IMAGE_SIZE, RENDER_SPP, SceneSpec, get_scene, per_shape,
                     render_dict, scene_camera, scene_dict)


#: the AOV pass tells SSS shapes apart by the green channel of their albedo tag: id / ID_SCALE (exact in
#: float32 for ids below ID_SCALE)
ID_SCALE = 1024.0


def _numbers_per_shape(name: str, value: ArrayLike, n: int, shape: tuple[int, ...], quantity: Quantity) -> np.ndarray:
    """``value`` for each of the ``n`` SSS shapes, (n, *shape) float64: one value (of ``shape``, or a number) for
    all, or one per shape (:func:`~ssskit.scenes.scenes.per_shape`), each a real in ``quantity``'s range."""
    arr = np.asarray(value)
    one = arr.shape in (shape, (), (1,))
    values = per_shape(name, np.broadcast_to(arr.reshape(shape if arr.shape == shape else ()), shape) if one else arr,
                       n, lambda _: one)
    return quantity.check_array(check_shape(values, name, (n, *shape), SceneError), name, SceneError)


def _light_layers(spec: SceneSpec, width: int, height: int, frame: int, wanted: bool) -> dict:
    if not wanted:
        return {}
    from .lightspace import light_layers

    depth, light = light_layers(spec, width, height, frame)
    return {"light_depth": depth.astype(np.float32), "light": light}


@checks(SceneError, **IMAGE_SIZE, spp=RENDER_SPP)
def render_gbuffer(scene: str | SceneSpec, albedo: ArrayLike, eta: float | ArrayLike = 1.4, width: int = 256,
                   height: int = 192, spp: int = 32, seed: int = 0, frame: int = 0,
                   material: str | tuple[str, ...] = "material", light_layers: bool = False) -> GBuffer:
    """Render the named scene's G-buffer (module docstring) at ``frame`` with Mitsuba ``scalar_rgb``.

    ``albedo``: (3,) diffuse albedo of the SSS objects (the profile's total reflectance), or (n, 3)
    one per SSS shape; ``eta``: their refractive index (specular layer), one or n; ``material``:
    its name, or n names. SSS shape i (``spec.sss_shapes[i]``) gets profile id i + 1, so a scene
    with n SSS shapes has ids 1..n and ``materials`` of length n (one name repeated if one is
    given); meta holds scene, frame, spp, seed, eta (a list if several). ``light_layers``: also the
    optional light layers of the transmittance pass (:func:`ssskit.scenes.lightspace.light_layers`: the
    first light's ray-cast translucency shadow map at the frame's size and its projection).
    """
    spec = get_scene(scene)
    n = len(spec.sss_shapes)
    alb = _numbers_per_shape("albedo", albedo, n, (3,), REFLECTANCE)
    etas = _numbers_per_shape("eta", eta, n, (), INDEX)
    names = tuple(map(str, per_shape("material names", material, n, lambda m: isinstance(m, str))))
    ids = {sid: i + 1 for i, sid in enumerate(spec.sss_shapes)}
    white = {"type": "diffuse", "reflectance": {"type": "rgb", "value": 1.0}}
    black = {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.0}}

    def coat(sid: str) -> dict:
        if sid not in ids:
            return black
        return {"type": "roughplastic", "diffuse_reflectance": {"type": "rgb", "value": 0.0},
                "int_ior": float(etas[ids[sid] - 1]), "distribution": "beckmann", "alpha": COAT_ROUGHNESS}

    direct = {"type": "direct", "emitter_samples": 1, "bsdf_samples": 1}

    diffuse = render_dict(scene_dict(spec, width, height, spp, seed, frame, direct, lambda sid: white))
    specular = render_dict(scene_dict(spec, width, height, spp, seed + 1, frame, direct, coat))
    # Mitsuba merges meshes that share a material, so shapes are told apart by an albedo tag in the
    # AOV pass (red 1 on SSS objects, 0.25 elsewhere, 0 where no surface; green: the profile id /
    # ID_SCALE) rather than by shape index.
    tagged = {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.25}}

    def tag_for(sid: str) -> dict:
        if sid not in ids:
            return tagged
        return {"type": "diffuse", "reflectance": {"type": "rgb", "value": [1.0, ids[sid] / ID_SCALE, 0.0]}}

    aov_int = {"type": "aov", "aovs": "pos:position,nn:sh_normal,alb:albedo"}
    aov = render_dict(scene_dict(spec, width, height, 1, seed + 2, frame, aov_int, tag_for))
    pos, normal, tag = aov[..., 0:3], aov[..., 3:6], aov[..., 6]
    hit = tag > 0.1
    sss = tag > 0.6
    pid = np.where(sss, np.clip(np.rint(aov[..., 7] * ID_SCALE), 1, n), 0).astype(np.uint32)
    cam = scene_camera(spec, width, height, frame)
    cam_pos = pos @ cam.world_to_camera[:3, :3].T + cam.world_to_camera[:3, 3]
    depth = np.where(hit, cam_pos[..., 2], np.inf).astype(np.float32)
    table = np.concatenate([np.full((1, 3), FLOOR_ALBEDO), alb]).astype(np.float32)
    albedo_layer = table[pid]
    albedo_layer[~hit] = 0.0
    meta = {"scene": spec.name, "frame": int(frame), "spp": int(spp), "seed": int(seed),
            "renderer": "mitsuba3 scalar_rgb", "eta": float(etas[0]) if n == 1 or np.ptp(etas) == 0 else etas.tolist()}
    return GBuffer(diffuse=np.maximum(diffuse[..., :3], 0), albedo=albedo_layer, depth=depth,
                   profile_id=pid, camera=cam, specular=np.maximum(specular[..., :3], 0),
                   normal=np.where(hit[..., None], normal, 0).astype(np.float32), materials=names, meta=meta,
                   **_light_layers(spec, width, height, frame, light_layers))


@checks(SceneError, frames=FRAMES.within(hi=2**31 - 1), first=(FRAME, "first frame"))
def render_sequence(scene: str, albedo: ArrayLike, frames: int, first: int = 0, **kw: Any) -> list[GBuffer]:
    """G-buffers of ``frames`` consecutive frames ``first, first + 1, ...`` along the scene's camera and
    light paths (each with its camera and its frame index in ``meta["frame"]``); ``kw`` as for
    :func:`render_gbuffer` (except ``frame``)."""
    takes = [k for k in inspect.signature(render_gbuffer).parameters if k not in ("scene", "albedo", "frame")]
    check_keywords("render_sequence", kw, takes, SceneError)  # (frame: first= and frames= say which)
    return [render_gbuffer(scene, albedo, frame=int(first) + f, **kw) for f in range(int(frames))]
