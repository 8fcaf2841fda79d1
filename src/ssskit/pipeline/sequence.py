"""The inputs of a frame sequence along a built-in scene's camera and light paths: one G-buffer per frame
(:func:`sequence_gbuffers`, rendered once and cached) and one converged reference per frame
(:func:`sequence_references`, the Burley pass's limit with its standard error). The sequence itself runs
through the one frame loop, :func:`ssskit.screenspace.frames.run_frames` (adaptive or fixed counts, TAA,
per-frame PSNR), which :func:`ssskit.pipeline.adaptive.render_adaptive` drives for ``ssskit render``.

    >>> from ssskit.materials import get_material                                       # doctest: +SKIP
    >>> from ssskit.pipeline.sequence import sequence_gbuffers, sequence_references    # doctest: +SKIP
    >>> from ssskit.screenspace import AdaptiveSettings, BurleySettings, run_frames    # doctest: +SKIP
    >>> from ssskit.screenspace.burley import burley_params_for_material              # doctest: +SKIP
    >>> from ssskit.screenspace.taa import TAASettings                                 # doctest: +SKIP
    >>> params = burley_params_for_material(get_material("skin1"))                     # doctest: +SKIP
    >>> gbs = sequence_gbuffers("sphere", "skin1", 2, width=40, height=30, spp=4)      # doctest: +SKIP
    >>> refs = sequence_references(gbs, params, spp=256)                               # doctest: +SKIP
    >>> run = run_frames(gbs, params, BurleySettings(), adaptive=AdaptiveSettings(),   # doctest: +SKIP
    ...                  taa=TAASettings(), references=[r.sss for r in refs])
    >>> len(run.psnr)                                                                  # doctest: +SKIP
    2

(Skipped under doctest: the G-buffers are path traced (Mitsuba) on a first run; tests/pipeline/test_sequence.py
runs the example as written, its G-buffers from the cache the tests fill.)

The G-buffers are cached per frame (``cache_dir("gbuffers")``), the references by
:func:`ssskit.pipeline.burley_frame.burley_reference` (``cache_dir("reference")``).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..cache import cache_dir
from ..errors import SceneError, SettingsError
from ..io import atomic_output
from ..materials import Material, homogeneous
from ..screenspace.burley import BurleyParams
from ..screenspace import Camera, GBuffer
from ..quantities import FRAME, FRAMES, REFERENCE_SPP, checks
from ..scenes.scenes import IMAGE_SIZE, RENDER_SPP

#: bumped when the cached G-buffers' contents change
GBUFFER_VERSION = 1


def _gbuffer_path(key: dict[str, Any]) -> Path:
    digest = hashlib.sha1(json.dumps({**key, "v": GBUFFER_VERSION}, sort_keys=True).encode()).hexdigest()[:16]
    return cache_dir("gbuffers") / f"{key['scene']}-{key['frame']}-{digest}.npz"


def _save_gbuffer(path: Path, gb: GBuffer) -> None:
    with atomic_output(path) as tmp:
        with open(tmp, "wb") as fh:
            assert gb.specular is not None and gb.normal is not None  # the scenes render both
            arrays: dict[str, Any] = dict(
                diffuse=gb.diffuse, albedo=gb.albedo, depth=gb.depth, profile_id=gb.profile_id, specular=gb.specular,
                normal=gb.normal, camera=np.array(json.dumps(gb.camera.to_dict())), meta=np.array(json.dumps(gb.meta)),
                materials=np.array(json.dumps(list(gb.materials))))
            if gb.light_depth is not None:  # the transmittance pass's light layers
                arrays.update(light_depth=gb.light_depth, light=np.array(json.dumps(gb.light)))
            np.savez(fh, **arrays)


def _load_gbuffer(path: Path) -> GBuffer | None:
    try:
        with np.load(path) as z:
            light = {} if "light_depth" not in z else {"light_depth": z["light_depth"],
                                                       "light": json.loads(str(z["light"]))}
            return GBuffer(diffuse=z["diffuse"], albedo=z["albedo"], depth=z["depth"], profile_id=z["profile_id"],
                           camera=Camera.from_dict(json.loads(str(z["camera"]))), specular=z["specular"],
                           normal=z["normal"], materials=tuple(json.loads(str(z["materials"]))),
                           meta=json.loads(str(z["meta"])), **light)
    except (OSError, ValueError, KeyError):  # a damaged cache entry is rendered again
        return None


@checks(SceneError, **IMAGE_SIZE, spp=RENDER_SPP)
def sequence_gbuffers(scene: str, material: str | Material, frames: int, first: int = 0, *, width: int = 160, height: int = 120,
                      spp: int = 64, seed: int = 0, static: bool = False, use_cache: bool = True,
                      progress: Callable[[str], None] | None = None, light_layers: bool = False) -> list[GBuffer]:
    """G-buffers of frames ``first .. first + frames - 1`` of the built-in ``scene`` along its camera and
    light paths (:func:`ssskit.scenes.render_sequence`), each rendered once and cached as ``.npz``
    keyed by everything that shapes it. ``material``: a material name or object (its Burley albedo
    and eta); ``static``: every frame is frame ``first`` (a still camera and light); ``light_layers``: with
    the transmittance pass's light layers of each frame's light (:func:`ssskit.scenes.render_gbuffer`)."""
    from ..materials import MATERIALS
    from ..scenes import render_gbuffer
    from ..scenes.scenes import SCENES
    from ..screenspace.burley import burley_params_for_material

    SCENES.get(scene)
    frames = int(FRAMES.check(frames, "frames", SettingsError))
    first = int(FRAME.within(hi=FRAME.hi - frames).check(first, "first", SettingsError))
    given = MATERIALS.get(material) if isinstance(material, str) else material
    mat = homogeneous(given, "the Burley pass", SettingsError)
    albedo = np.clip(burley_params_for_material(mat).albedo, 0.0, 1.0)
    out: list[GBuffer] = []
    cache: dict[int, GBuffer] = {}
    for f in range(frames):
        frame = first if static else first + f
        if frame in cache:
            out.append(cache[frame])
            continue
        key = {"scene": scene, "frame": int(frame), "albedo": [float(a) for a in albedo], "eta": float(mat.eta),
               "size": [int(width), int(height)], "spp": int(spp), "seed": int(seed), "material": mat.name}
        if light_layers:  # (only then: the keys of the G-buffers cached before the layers existed stay)
            key["light_layers"] = True
        path = _gbuffer_path(key)
        gb = _load_gbuffer(path) if use_cache and path.is_file() else None
        if gb is None:
            if progress is not None:
                progress(f"G-buffer {scene} frame {frame} ({width}x{height}, {spp} spp, Mitsuba)")
            gb = render_gbuffer(scene, albedo, eta=mat.eta, width=width, height=height, spp=spp, seed=seed,
                                frame=frame, material=mat.name, light_layers=light_layers)
            if use_cache:
                _save_gbuffer(path, gb)
        cache[frame] = gb
        out.append(gb)
    return out


@dataclass(frozen=True)
class SequenceReference:
    """A frame's converged reference: ``sss`` (H, W, 3), the mean of two independent runs of the exact
    sampler without mips at ``spp`` / 2 samples each (:func:`ssskit.pipeline.burley_frame.burley_reference`,
    cached), and ``stderr`` (H, W, 3), its standard error estimated from the two halves,
    |a - b| / 2 (the variance of the mean of two independent estimates is (a - b)^2 / 4 in expectation)."""

    sss: np.ndarray
    stderr: np.ndarray
    spp: int


#: samples per pixel of a sequence reference: two independent halves (the error estimate), each at least one
_SEQUENCE_SPP = REFERENCE_SPP.within(2, 2 * 65536)


def sequence_references(gbuffers: Sequence[GBuffer], params: BurleyParams | Mapping[int, BurleyParams], spp: int = 8192, seed: int = 1000,
                        backend: str = "numba", use_cache: bool = True,
                        progress: Callable[[str], None] | None = None) -> list[SequenceReference]:
    """One :class:`SequenceReference` per G-buffer (identical G-buffers share theirs)."""
    from .burley_frame import burley_reference

    spp = int(_SEQUENCE_SPP.check(spp, "spp", SettingsError))
    half = spp // 2
    out: list[SequenceReference] = []
    seen: dict[int, SequenceReference] = {}
    for i, gb in enumerate(gbuffers):
        if id(gb) in seen:
            out.append(seen[id(gb)])
            continue
        if progress is not None:
            progress(f"reference {i + 1}/{len(gbuffers)} ({spp} spp, exact sampler, no mips; cached)")
        a = burley_reference(gb, params, spp=half, seed=seed, backend=backend, use_cache=use_cache).astype(np.float64)
        b = burley_reference(gb, params, spp=half, seed=seed + 1, backend=backend,
                             use_cache=use_cache).astype(np.float64)
        ref = SequenceReference(sss=(0.5 * (a + b)).astype(np.float32), stderr=np.abs(a - b) / 2.0, spp=2 * half)
        seen[id(gb)] = ref
        out.append(ref)
    return out


__all__ = ["GBUFFER_VERSION", "SequenceReference", "sequence_gbuffers", "sequence_references"]
