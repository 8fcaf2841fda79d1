"""Path-traced references of the built-in scenes: the SSS objects as a homogeneous medium inside their
boundary, rendered by Mitsuba 3 ``volpathmis`` in independent chunks until a region's standard error
is small enough, and cached on disk.

What the screen-space result is compared with: it also contains what no screen-space method has
(light through thin parts, Fresnel at entry and exit, curvature, light from behind the silhouette).

The boundary (everywhere the code and the docs name it): a **rough dielectric**, Mitsuba
``roughdielectric`` with **Beckmann** microfacets of roughness alpha = :data:`COAT_ROUGHNESS`,
interior index = the material's eta, exterior index = its ``eta_ambient`` -- the same interface as
the G-buffer's specular layer. ``boundary="index-matched"`` replaces it with Mitsuba's ``null``
BSDF (no refraction, no reflection: the medium's index equals the ambient one), the set-up of
MCML at eta = 1 and the cheap units check of the reference.

Lighting matched to the G-buffer: every surface that is not an SSS object is **black** in the
reference (``surround_albedo = 0``, a diffuse BSDF of reflectance 0: it still casts shadows). The
G-buffer's diffuse layer is E / pi of the scene's lights alone (direct light, no bounce), so with
black surroundings both sides are lit by the same light: no floor bounce enters the reference that
the screen-space pass could never have. What remains different is real transport: light that
leaves an SSS object and re-enters it (concave parts), light through thin parts, Fresnel.

Convergence: the image is the mean of ``chunks`` renders of ``chunk_spp`` samples per pixel, each
a separate ``mi.render`` call with its own seed (:func:`chunk_seed`): Mitsuba seeds the sample
stream of pixel p from the base seed and p, so calls that shared a seed would replay each other's
samples shifted by a pixel. The chunks are independent batches: the per-pixel standard error is
the spread of the chunk images (batch method), and the standard error of a region's mean is the
spread of the chunks' region means. Rendering goes on until the relative standard error of the
region's mean is at most ``target_rel_se`` in every channel or ``max_spp`` is spent; both are
reported in the returned :class:`Reference`.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..cache import cache_dir, cache_file, cache_root
from ..errors import SceneError
from ..io import atomic_output, progress_bar
from ..materials import Material
from ..quantities import FRAME, REFLECTANCE, REL_SE, SEED, Choice, Quantity, check_instance, check_shape, checks

#: the path tracer's longest path (Mitsuba's max_depth): at least the camera's ray
MAX_DEPTH = Quantity("max_depth", 1, 2**31 - 1, "", "bounces of a path, the camera's ray the first", integer=True)
from .scenes import (COAT_ROUGHNESS, IMAGE_SIZE, RENDER_SPP, SceneSpec, get_scene, mitsuba, per_shape,
                     scene_dict)
from .mitsuba_variant import interruptible_render, load_scene

#: bumped when the reference renders change (invalidates the cache). 3: a unique seed per mi.render
#: call (before, chunks replayed each other shifted by a pixel), black surroundings, chunk statistics
CACHE_VERSION = 3

#: the reference's boundaries: the rough dielectric of the scenes, or an index-matched null interface
BOUNDARIES = ("rough-dielectric", "index-matched")
#: a reference's image and path-tracer options, declared once for :class:`ReferenceRenderer` and
#: :func:`render_reference` (:func:`ssskit.quantities.checks`: before any work; the boundary's canonical name keys
#: the cache)
OPTIONS: dict[str, Any] = {**IMAGE_SIZE, "max_depth": MAX_DEPTH, "seed": SEED, "frame": FRAME,
                           "surround_albedo": REFLECTANCE, "boundary": Choice("boundary", BOUNDARIES)}

#: defaults of the convergence rule: relative standard error of the region's mean, spp budget
TARGET_REL_SE = 0.01
MAX_SPP = 4096


def reference_cache_dir() -> Path:
    """Where references are cached: ``cache_dir("reference")``."""
    return cache_dir("reference")


def reference_phase_g(material: Material) -> float:
    """The one Henyey-Greenstein g of ``material`` for the reference's medium, or a SceneError.

    Mitsuba's ``hg`` phase function takes a single g, so a material whose g differs between channels
    (or a layered material, which is no single medium) cannot be path-traced as it is.
    """
    check_instance(material, Material, "the path-traced reference's material (homogeneous: sigma_a, sigma_s, g, eta)",
                   SceneError)
    g = np.asarray(material.g, dtype=float)
    if np.ptp(g) > 0:
        raise SceneError(f"the path-traced reference takes one Henyey-Greenstein g (Mitsuba's hg phase function), "
                         f"but material {material.name!r} has g = {g.tolist()} per channel")
    return float(g.flat[0])


def chunk_seed(seed: int, index: int) -> int:
    """The seed of the ``index``-th ``mi.render`` call of a reference rendered with ``seed``.

    ``(h(seed) + index) mod 2^32`` with h a splitmix64 hash of the user seed: the chunks of one
    reference get distinct consecutive seeds (Mitsuba hashes the call's seed with the pixel index,
    and consecutive call seeds give independent streams: tests/scenes), and different user seeds
    start at unrelated points of the 2^32 seed space.
    """
    z = (int(seed) * 0x9E3779B97F4A7C15 + 0xD1B54A32D192ED03) & 0xFFFFFFFFFFFFFFFF
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & 0xFFFFFFFFFFFFFFFF
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & 0xFFFFFFFFFFFFFFFF
    z ^= z >> 31
    return int(((z >> 32) + int(index)) & 0xFFFFFFFF)


def batch_mean_se(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean over axis 0 of equal-sized batches and its standard error: std(ddof=1) / sqrt(K)
    (the batch method; NaN for a single batch)."""
    v = np.asarray(values, dtype=np.float64)
    k = v.shape[0]
    mean = v.mean(axis=0)
    if k < 2:
        return mean, np.full_like(mean, np.nan)
    return mean, v.std(axis=0, ddof=1) / np.sqrt(k)


@dataclass(frozen=True)
class Reference:
    """A converged (or budget-limited) path-traced image and its error bars.

    ``image``: (H, W, 3) mean radiance; ``pixel_se``: (H, W, 3) per-pixel batch standard error;
    ``region``: (H, W) bool, the pixels whose mean decided convergence; ``region_mean`` /
    ``region_se``: (3,) that region's mean and its batch standard error (spread of the chunks'
    region means); ``spp`` = ``chunks`` x ``chunk_spp``; ``converged``: the relative standard error
    reached ``target_rel_se`` in every channel before ``max_spp`` was spent.
    """

    image: np.ndarray
    pixel_se: np.ndarray
    region: np.ndarray
    region_mean: np.ndarray
    region_se: np.ndarray
    spp: int
    chunks: int
    chunk_spp: int
    target_rel_se: float
    max_spp: int
    converged: bool
    boundary: str
    surround_albedo: float
    seed: int
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def shape(self) -> tuple[int, ...]:
        return self.image.shape

    def __array__(self, dtype=None, copy=None):
        return self.image if dtype is None else self.image.astype(dtype)

    @property
    def rel_se(self) -> np.ndarray:
        """Relative standard error of the region's mean per channel (3,)."""
        return self.region_se / np.maximum(np.abs(self.region_mean), 1e-300)

    def region_stats(self, mask: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(mean, standard error) per channel of the mean over ``mask`` (H, W) bool.

        The standard error is sqrt(sum of the pixels' squared standard errors) / N: distinct pixels
        draw from independent random streams, so their errors add in quadrature.
        """
        m = check_shape(mask, "region", self.image.shape[:2], SceneError, "iufb", bool)
        n = int(m.sum())
        if n == 0:
            return np.full(3, np.nan), np.full(3, np.nan)
        mean = self.image[m].astype(np.float64).mean(axis=0)
        se = np.sqrt(np.sum(self.pixel_se[m].astype(np.float64) ** 2, axis=0)) / n
        return mean, se

    def summary(self) -> dict[str, Any]:
        """JSON-ready: spp, chunks, the region's mean, standard error and relative standard error per
        channel, the target, the budget and whether it converged, the boundary and surroundings."""
        return {"spp": int(self.spp), "chunks": int(self.chunks), "chunk_spp": int(self.chunk_spp),
                "region_pixels": int(self.region.sum()), "region_mean": self.region_mean.tolist(),
                "region_se": self.region_se.tolist(), "rel_se": self.rel_se.tolist(),
                "target_rel_se": float(self.target_rel_se), "max_spp": int(self.max_spp),
                "converged": bool(self.converged), "boundary": self.boundary,
                "surround_albedo": float(self.surround_albedo), "seed": int(self.seed)}


class ReferenceRenderer:
    """One scene loaded once in Mitsuba; :meth:`chunk` renders chunk ``i`` with its own seed.

    The medium: the material's sigma_a, sigma_s (mm^-1 = per world unit) and one Henyey-Greenstein g
    (:func:`reference_phase_g`) inside the boundary (``rough-dielectric``: Mitsuba
    ``roughdielectric``, Beckmann alpha = :data:`COAT_ROUGHNESS`, int_ior = eta, ext_ior =
    eta_ambient; ``index-matched``: Mitsuba ``null``); every other surface diffuse with reflectance
    ``surround_albedo`` (0: black); ``volpathmis`` with ``max_depth`` bounces (high-albedo media need
    long random walks). ``crop`` = (x0, y0, w, h): render only that window of the width x height
    image (every sample lands in it; a region's error falls faster).
    """

    @checks(SceneError, **OPTIONS)
    def __init__(self, scene: str | SceneSpec, material: Material | Sequence[Material], width: int, height: int, max_depth: int = 1024, seed: int = 0,
                 frame: int = 0, boundary: str = "rough-dielectric", surround_albedo: float = 0.0,
                 crop: tuple[int, int, int, int] | None = None) -> None:
        self.spec = get_scene(scene)
        check_reference_scene(self.spec)
        mats = shape_materials(self.spec, material)
        self.g = reference_phase_g(mats[0])
        interiors = {sid: _interior(m, boundary) for sid, m in zip(self.spec.sss_shapes, mats)}
        surround = {"type": "diffuse", "reflectance": {"type": "rgb", "value": float(surround_albedo)}}

        def bsdf_for(sid):
            return interiors.get(sid, surround)

        self.seed = int(seed)
        self.width, self.height = int(width), int(height)
        integrator = {"type": "volpathmis", "max_depth": int(max_depth)}
        mi = mitsuba()
        # the sampler's own base seed stays 0: the per-call seed of mi.render makes each chunk's stream
        d = scene_dict(self.spec, width, height, 1, 0, frame, integrator, bsdf_for)
        if crop is not None:
            x0, y0, cw, ch = (int(v) for v in crop)
            if not (0 <= x0 and 0 <= y0 and cw >= 1 and ch >= 1 and x0 + cw <= width and y0 + ch <= height):
                raise SceneError(f"crop window {crop!r} does not lie inside the {width}x{height} image")
            d["sensor"]["film"].update(crop_offset_x=x0, crop_offset_y=y0, crop_width=cw, crop_height=ch)
        self._scene = load_scene(d)
        self._mi = mi

    def chunk(self, index: int, spp: int) -> np.ndarray:
        """Chunk ``index`` with ``spp`` samples per pixel, seeded by :func:`chunk_seed`; (H, W, 3) float64."""
        img = interruptible_render(self._scene, seed=chunk_seed(self.seed, index), spp=int(spp))
        return np.array(img, dtype=np.float64)[..., :3]


def _interior(material: Any, boundary: str) -> dict[str, Any]:
    """The BSDF (boundary) and interior medium of one SSS shape (:class:`ReferenceRenderer`)."""
    g = reference_phase_g(material)
    sigma_t = np.asarray(material.sigma_a, float) + np.asarray(material.sigma_s, float)
    scale = float(sigma_t.max())  # (> 0: a Material's sigma_t is, reference_phase_g's check above)
    single = np.where(sigma_t > 0, np.asarray(material.sigma_s, float) / np.maximum(sigma_t, 1e-300), 0.0)
    # RGB values of a Mitsuba medium must lie in [0, 1]: sigma_t is given relative to its maximum
    medium = {"type": "homogeneous", "sigma_t": {"type": "rgb", "value": (sigma_t / scale).tolist()},
              "albedo": {"type": "rgb", "value": single.tolist()}, "phase": {"type": "hg", "g": g}, "scale": scale}
    if boundary == "rough-dielectric":
        shell = {"type": "roughdielectric", "int_ior": float(material.eta),
                 "ext_ior": float(getattr(material, "eta_ambient", 1.0)), "distribution": "beckmann",
                 "alpha": COAT_ROUGHNESS}
    else:
        shell = {"type": "null"}
    return {**shell, "__medium": medium}


def check_reference_scene(spec: SceneSpec) -> None:
    """A SceneError if the path-traced reference cannot render ``spec`` (an open or non-manifold SSS
    mesh: :meth:`ssskit.scenes.meshes.Topology.reference_problem`); the pipeline calls it before any work."""
    if spec.reference_problem:
        raise SceneError(spec.reference_problem)


def shape_materials(spec: SceneSpec, material: Any) -> tuple[Any, ...]:
    """One material per SSS shape of ``spec``: ``material`` (a Material) for each, or a sequence of
    len(sss_shapes) Materials (the scene's own per-object materials, resolved by the caller)."""
    return per_shape("the reference's materials", material, len(spec.sss_shapes),
                     lambda m: not isinstance(m, (list, tuple)))


def geometry_key(spec: SceneSpec) -> str:
    """The scene's shapes, lights and camera as a cache key's text. A mesh ssskit wrote to its cache is named by
    its content's digest (:func:`ssskit.scenes.scenes._ply`) and keyed by that name, relative to the cache root, so
    the key does not depend on where the cache lies (``$SSSKIT_CACHE_DIR``; before, a cache moved or copied to
    another folder rendered every mesh scene's references again, under other names). A mesh outside the cache
    (a user's file) keeps its absolute path."""
    root = str(cache_root()) + "/"

    def portable(value: Any) -> Any:
        if isinstance(value, dict):
            return {k: portable(v) for k, v in value.items()}
        return value[len(root):] if isinstance(value, str) and value.startswith(root) else value

    return json.dumps([portable(spec.shapes()), spec.lights(), spec.origin, spec.fov_x_deg], default=str)


@checks(SceneError, **IMAGE_SIZE)
def sss_region(scene: str | SceneSpec, width: int, height: int, frame: int = 0) -> np.ndarray:
    """(H, W) bool: the pixels that see an SSS object of ``scene`` (one AOV sample per pixel)."""
    spec = get_scene(scene)
    white = {"type": "diffuse", "reflectance": {"type": "rgb", "value": 1.0}}
    tagged = {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.25}}
    aov = {"type": "aov", "aovs": "alb:albedo"}
    d = scene_dict(spec, width, height, 1, 0, frame, aov, lambda sid: white if sid in spec.sss_shapes else tagged)
    img = np.array(interruptible_render(load_scene(d), seed=0))
    return img[..., 0] > 0.6


@checks(SceneError, spp=RENDER_SPP, chunk_spp=RENDER_SPP, target_rel_se=(REL_SE, "target relative standard error"),
        **OPTIONS)
def render_reference(scene: str | SceneSpec, material: Material | Sequence[Material], width: int = 128, height: int = 96, spp: int = 64,
                     max_spp: int | None = None, target_rel_se: float = TARGET_REL_SE, region: ArrayLike | None = None,
                     max_depth: int = 1024, seed: int = 0, frame: int = 0, chunk_spp: int = 8,
                     boundary: str = "rough-dielectric", surround_albedo: float = 0.0, use_cache: bool = True,
                     progress: bool = True, cache_only: bool = False) -> Reference:
    """Volumetric path-traced image of the scene at ``frame`` with its standard errors (module docstring).

    The SSS objects are a homogeneous medium with the material's sigma_a, sigma_s and one
    Henyey-Greenstein g inside a rough dielectric (Mitsuba ``roughdielectric``, Beckmann alpha =
    :data:`COAT_ROUGHNESS`, the G-buffer specular layer's boundary) or, with ``boundary=
    "index-matched"``, a ``null`` interface; every other surface has diffuse reflectance
    ``surround_albedo`` (0: black, so both the reference and the G-buffer see only the lights).

    At least ``spp`` samples per pixel, in chunks of ``chunk_spp`` (one ``mi.render`` call and one
    seed each); then more chunks until the relative standard error of the mean over ``region``
    ((H, W) bool; default: the pixels of the SSS objects) is at most ``target_rel_se`` in every
    channel, or until ``max_spp`` (default: ``spp``, i.e. a fixed budget) is spent. Cached in
    :func:`reference_cache_dir`, keyed by every input; ``cache_only``: the cached render or a SceneError saying
    none is cached (nothing is rendered: the live viewer asks so).
    """
    spec = get_scene(scene)
    max_spp = int(spp) if max_spp is None else max_spp  # (an integer at least spp, so at least 1:)
    RENDER_SPP.within(lo=spp, reason="the spp budget: at least the minimum spp").check(max_spp, "max_spp", SceneError)
    check_reference_scene(spec)
    mats = shape_materials(spec, material)
    g = reference_phase_g(mats[0])
    for m in mats[1:]:
        reference_phase_g(m)
    if region is None:
        region = sss_region(spec, width, height, frame)
    region = check_shape(region, "region", (height, width), SceneError, "iufb", bool)
    if not region.any():
        raise SceneError("the convergence region holds no pixel")
    first = mats[0]
    media = {} if len(set(map(id, mats))) == 1 else {
        "media": [[list(m.sigma_a), list(m.sigma_s), reference_phase_g(m), m.eta,
                   float(getattr(m, "eta_ambient", 1.0))] for m in mats]}
    jitter = {"jitter": list(spec.pixel_jitter)} if any(spec.pixel_jitter) else {}  # (unjittered keys unchanged)
    key = json.dumps({**media, **jitter, "scene": spec.name, "sa": list(first.sigma_a), "ss": list(first.sigma_s), "g": g,
                      "eta": first.eta, "eta_amb": float(getattr(first, "eta_ambient", 1.0)),
                      "w": width, "h": height, "spp": spp, "max_spp": max_spp, "rel_se": float(target_rel_se),
                      "chunk": chunk_spp, "d": max_depth, "seed": seed, "frame": frame, "v": CACHE_VERSION,
                      "boundary": boundary, "surround": float(surround_albedo), "alpha": COAT_ROUGHNESS,
                      "region": hashlib.sha1(np.packbits(region).tobytes()).hexdigest(),
                      "geometry": geometry_key(spec)},
                     sort_keys=True)
    path = cache_file("reference", spec.name, hashlib.sha1(key.encode()).hexdigest()[:16], ".npz")
    opts = dict(target_rel_se=float(target_rel_se), max_spp=int(max_spp), boundary=boundary,
                surround_albedo=float(surround_albedo), seed=int(seed), chunk_spp=int(chunk_spp))
    if use_cache and path.is_file():
        try:
            return _load(path, region, opts)
        except Exception:  # noqa: BLE001 - a truncated or foreign file is rendered again
            pass
    if cache_only:
        raise SceneError(f"no path-traced reference of {spec.name} with these settings is cached")
    renderer = ReferenceRenderer(spec, mats if media else first, width, height, max_depth, seed, frame, boundary,
                                 surround_albedo)
    min_chunks = -(-int(spp) // chunk_spp)
    max_chunks = max(int(max_spp) // chunk_spp, min_chunks)
    acc = np.zeros((height, width, 3))
    acc2 = np.zeros((height, width, 3))
    means = []
    bar = progress_bar(max_chunks, f"path tracing {spec.name}", "chunks", enabled=progress, leave=False)
    converged = False
    try:
        for i in range(max_chunks):
            img = renderer.chunk(i, chunk_spp)
            acc += img
            acc2 += img * img
            means.append(img[region].mean(axis=0))
            bar.update(1)
            if i + 1 >= max(min_chunks, 2):
                mean, se = batch_mean_se(np.array(means))
                rel = se / np.maximum(np.abs(mean), 1e-300)
                bar.set_postfix_str(f"{(i + 1) * chunk_spp} spp, rel. SE {rel.max():.2%}")
                if np.all(rel <= target_rel_se):
                    converged = True
                    break
    finally:
        bar.close()
    if use_cache:
        with atomic_output(path) as tmp:
            with open(tmp, "wb") as fh:
                np.savez(fh, acc=acc, acc2=acc2, means=np.array(means), converged=np.array(converged))
    return _assemble(acc, acc2, np.array(means), region, converged, opts)


def _assemble(acc: np.ndarray, acc2: np.ndarray, means: np.ndarray, region: np.ndarray, converged: bool,
              opts: dict[str, Any]) -> Reference:
    k = means.shape[0]
    image = acc / k
    if k > 1:
        var = np.maximum(acc2 / k - image**2, 0.0) * k / (k - 1)
        pixel_se = np.sqrt(var / k)
    else:
        pixel_se = np.full_like(image, np.nan)
    mean, se = batch_mean_se(means)
    return Reference(image=image.astype(np.float32), pixel_se=pixel_se.astype(np.float32), region=region,
                     region_mean=mean, region_se=se, spp=k * opts["chunk_spp"], chunks=k, converged=bool(converged),
                     **opts)


def _load(path: Path, region: np.ndarray, opts: dict[str, Any]) -> Reference:
    with np.load(path) as z:
        return _assemble(z["acc"], z["acc2"], z["means"], region, bool(z["converged"]), opts)


__all__ = ["BOUNDARIES", "CACHE_VERSION", "MAX_SPP", "TARGET_REL_SE", "Reference", "ReferenceRenderer",
           "batch_mean_se", "check_reference_scene", "chunk_seed", "reference_cache_dir", "reference_phase_g", "render_reference",
           "shape_materials", "sss_region"]
