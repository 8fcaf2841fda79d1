"""Render a scene (or a G-buffer file) with screen-space separable SSS and compare it with ground truth.

    >>> from ssskit.render import render
    >>> r = render("slab", material="skin1", kernel="preintegrated", taps=7)     # doctest: +SKIP
    >>> r.metrics["exact_2d"]["psnr"]                                               # doctest: +SKIP

Two ground truths:

* ``exact``: the full 2D convolution of the diffuse layer with the profile (paper Eq. 1), with the
  pass's own boundary rule (samples off the SSS region or off the image take the centre value):
  M = (m E) * K + E (1 - m * K), K the profile's exact cell integrals normalised to 1, on the pixel
  grid at the region's median depth. Exact for a fronto-parallel surface (the slab scene); on curved
  surfaces it ignores the footprint's change with depth, as the pass does not.
* ``reference``: a volumetric path-traced image of the same scene (Mitsuba ``volpathmis``), which
  also contains what no screen-space method has: light through thin parts, Fresnel at entry and
  exit, curvature, light from behind the silhouette.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .errors import SsskitError
from .io import atomic_output, check_suffix


@dataclass
class RenderResult:
    gbuffer: Any
    taps: Any
    kernel: Any
    sss: np.ndarray  # blurred diffuse layer (H, W, 3)
    image: np.ndarray  # composite albedo * sss + specular
    exact: np.ndarray | None = None  # blurred diffuse layer by the exact 2D convolution
    reference: np.ndarray | None = None  # path-traced image
    metrics: dict[str, Any] = field(default_factory=dict)
    settings: dict[str, Any] = field(default_factory=dict)


def exact_screen_space(gbuffer, profile, fraction: float = 0.999) -> np.ndarray | None:
    """The exact 2D convolution of the diffuse layer on each SSS region (module docstring).

    Returns None if the pixels are not square (the profile's cells are square).
    """
    from scipy.signal import fftconvolve

    cam = gbuffer.camera
    if abs(cam.fx - cam.fy) > 1e-6 * cam.fx:
        return None
    out = gbuffer.diffuse.astype(np.float64).copy()
    e = gbuffer.diffuse.astype(np.float64)
    radius = float(np.max(profile.radius_at_fraction(fraction)))
    for pid in np.unique(gbuffer.profile_id[gbuffer.profile_id > 0]):
        m = (gbuffer.profile_id == pid).astype(np.float64)
        z_mm = float(np.median(gbuffer.depth[m > 0])) / cam.world_units_per_mm
        pixel_mm = z_mm / cam.fx
        half = int(min(np.ceil(radius / pixel_mm), max(gbuffer.shape)))
        cells = profile.discretize_2d(pixel_mm, 2 * half + 1)
        cells = cells / cells.sum(axis=(0, 1))
        res = np.empty_like(e)
        for c in range(3):
            k = cells[..., c]
            res[..., c] = fftconvolve(m * e[..., c], k, mode="same") + e[..., c] * (1.0 - fftconvolve(m, k, mode="same"))
        out[m > 0] = res[m > 0]
    return out.astype(np.float32)


def region_metrics(reference: np.ndarray, test: np.ndarray, mask: np.ndarray, perceptual: bool = True) -> dict:
    """Errors inside ``mask`` (RMSE, relative RMSE, PSNR with the reference's peak) and, over the whole
    image, FLIP of the tone-mapped images."""
    from . import metrics

    r = np.asarray(reference)[mask][None]  # the masked pixels as a (1, N, 3) image
    t = np.asarray(test)[mask][None]
    out = {"rmse": metrics.rmse(r, t), "relative_rmse": metrics.relative_rmse(r, t), "psnr": metrics.psnr(r, t)}
    if perceptual:
        out["flip"] = metrics.flip(reference, test)
    return out


def render(scene: str | Path = "slab", material: str = "skin1", kernel: str = "preintegrated", taps: int = 7,
           tap_method: str = "importance", jitter: float = 0.1, width: int = 256, height: int = 192, spp: int = 32,
           seed: int = 0, frame: int = 0, model: str = "dipole", photons: int = 200_000, depth_mode: str | None = None,
           exact: bool = True, reference: bool = False, reference_spp: int = 64, backend: str = "numba",
           perceptual: bool = True, progress: Callable[[str], None] | None = None) -> RenderResult:
    """Render ``scene`` with separable SSS (module docstring).

    ``scene``: a built-in scene name, a G-buffer ``.exr`` path, or a :class:`GBuffer` already in memory
    (to run several kernels on one render; ``reference`` is then refused).
    """
    from .kernels import build_kernel, default_grid, parse_method_spec
    from .materials import get_material
    from .profiles import profile_for_material
    from .sampling.taps import make_taps
    from .scenes.render3d import SCENES, render_gbuffer, render_reference
    from .screenspace import GBuffer, load_gbuffer, separable_sss

    say = progress or (lambda msg: None)
    mat = get_material(material)
    opts = {"photons": photons} if model == "montecarlo" else {}
    profile = profile_for_material(mat, model, **opts)
    albedo = np.clip(profile.total_rd(), 0.0, 1.0)
    path = Path(str(scene)) if not isinstance(scene, GBuffer) else None
    if path is None:
        gb = scene
        scene_name = str(gb.meta.get("scene", "G-buffer"))
    elif path.suffix.lower() == ".exr":
        gb = load_gbuffer(path)
        scene_name = path.name
    else:
        SCENES.get(str(scene))
        say(f"rendering the {scene} G-buffer ({width}x{height}, {spp} spp, Mitsuba scalar_rgb)")
        gb = render_gbuffer(str(scene), albedo, eta=mat.eta, width=width, height=height, spp=spp, seed=seed,
                            frame=frame, material=mat.name)
        scene_name = str(scene)
    method, params, _label = parse_method_spec(kernel)
    cell, n = default_grid(profile)
    k = build_kernel(method.name, profile, cell, n, **params)
    t = make_taps(k, taps, tap_method)
    say(f"separable pass: {kernel}, {t.taps} {tap_method} taps, jitter {jitter:g}")
    sss = separable_sss(gb, t, jitter=jitter, frame=frame, seed=seed, depth_mode=depth_mode, backend=backend)
    res = RenderResult(gb, t, k, sss, gb.composite(sss), settings={
        "scene": scene_name, "material": mat.name, "model": model, "kernel": kernel, "taps": t.taps,
        "tap_method": tap_method, "jitter": jitter, "seed": seed, "frame": frame, "size": list(gb.shape[::-1])})
    mask = gb.mask
    if exact and mask.any():
        say("exact 2D convolution (FFT)")
        res.exact = exact_screen_space(gb, profile)
        if res.exact is not None:
            res.metrics["exact_2d"] = region_metrics(gb.composite(res.exact), res.image, mask, perceptual)
    if reference:
        if path is None or path.suffix.lower() == ".exr":
            raise SsskitError("--reference needs a built-in scene (a G-buffer has no scene to path-trace)")
        res.reference = render_reference(str(scene), mat, width=width, height=height, spp=reference_spp, seed=seed,
                                         frame=frame, progress=progress is not None)
        hit = np.isfinite(gb.depth)
        res.metrics["path_traced"] = region_metrics(res.reference, res.image, mask, perceptual)
        res.metrics["path_traced"]["mean_ratio_in_mask"] = (
            (res.image[mask].mean(axis=0) / np.maximum(res.reference[mask].mean(axis=0), 1e-12)).tolist()
            if mask.any() else None)
        res.metrics["path_traced"]["pixels_with_surface"] = int(hit.sum())
    return res


def save_image(path: str | Path, image: np.ndarray, layers: dict[str, np.ndarray] | None = None) -> None:
    """``.exr``: linear float32 RGB (plus extra named RGB layers) via OpenEXR; ``.png``: tone-mapped sRGB."""
    suffix = check_suffix(path, (".exr", ".png"), "--out")
    img = np.ascontiguousarray(image, dtype=np.float32)
    if suffix == ".exr":
        import OpenEXR

        channels = {"RGB": img}
        for name, arr in (layers or {}).items():
            channels[name] = np.ascontiguousarray(arr, dtype=np.float32)
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        with atomic_output(path) as tmp:
            with OpenEXR.File(header, channels) as f:
                f.write(str(tmp))
        return
    from .metrics import tonemap
    from .plots import _pyplot

    peak = float(np.percentile(img, 99.5)) or 1.0
    ldr = np.clip(tonemap(img, peak), 0.0, 1.0)
    with atomic_output(path) as tmp:
        _pyplot().imsave(tmp, ldr, format="png")
