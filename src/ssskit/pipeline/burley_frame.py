"""Render one frame with the Burley Monte Carlo pass (Xie 2020 Sec. 4.2, 5) and compare it with ground
truth, beside :func:`ssskit.pipeline.render` (the separable pass).

    >>> from ssskit.pipeline import BurleyPass, RenderSettings
    >>> from ssskit.pipeline.burley_frame import render_burley
    >>> r = render_burley("slab", RenderSettings(pass_=BurleyPass(spp=64)))  # doctest: +SKIP
    >>> r.metrics["exact_2d"]["psnr"]                                          # doctest: +SKIP

The steps: material -> Burley profile (:func:`ssskit.profiles.burley_profile`: A from the dipole's
total reflectance, d from the searchlight configuration of Eq. 5) -> per-id :class:`BurleyParams`
-> G-buffer (a built-in scene rendered by Mitsuba, a G-buffer file, or a GBuffer) -> the Burley pass
(``settings.pass_``, a :class:`~ssskit.pipeline.settings.BurleyPass`, with the tree's frame, seed and
backend: :meth:`RenderSettings.burley_settings`) -> composite albedo * sss + specular -> ground truths
(:func:`ssskit.pipeline.frame.ground_truths`, shared with the separable pass).

``settings`` (:class:`RenderSettings`) also supplies the material, the scene's size, G-buffer samples
and seed, and which ground truths to compute. Every check (the scene, the material, the backend having
the Burley pass) runs before any work.

Ground truths:

* ``exact``: :func:`burley_exact`, the limit of the pass on a fronto-parallel surface: the exact 2D
  convolution of the diffuse layer with R(r) under Eq. 24's boundary rule (samples off the region
  dropped from both sums), per profile id at its median depth;
* ``reference``: the path-traced image, as for the separable pass (converged to ``reference_rel_se``
  within ``reference_max_spp``).

On curved scenes the pass's own converged reference is :func:`burley_reference` (the exact sampler
at 4096 samples per pixel without mips, cached).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..backends import warm_up_in_background
from ..backends.plan import per_id as params_of_ids
from ..errors import SettingsError
from ..materials import homogeneous
from ..quantities import check_instance
from ..screenspace import BurleyParams, BurleySettings, GBuffer, burley_sss
from ..screenspace.burley import burley_backend
from .frame import (BurleyInput, ImageLayers, Progress, SceneInput, ScenePlan, finite, frame_gbuffer, ground_truths,
                    material_label, metric_lines, per_id, plan_scene, reference_line)
from .settings import AdaptivePass, BurleyPass, RenderSettings
from .transmission import TransmissionInfo, transmission_passes, with_transmission


def burley_exact(gbuffer: GBuffer, params_by_id: BurleyParams | Mapping[int, BurleyParams]) -> np.ndarray | None:
    """The Burley pass's limit (exact sampler, no mips) on a fronto-parallel surface, (H, W, 3) float32;
    None if the pixels are not square.

    Per region m (the pixels of one profile id) at its median depth z (pixel size z / fx mm), with
    K_c the exact cell integrals of R_c (Xie 2020 Eq. 4) over every offset the image holds:

        M_c = ((m E_c) * K_c) / (m * K_c)

    (Eq. 24's self-normalised estimator drops samples off the region from both sums; the nearest-texel
    fetch makes its expectation exactly this sum of cell integrals). Pixels without SSS keep their
    diffuse value. Where the region covers the whole kernel this equals
    :func:`ssskit.truth.exact_screen_space`, which keeps the centre value for the uncovered share instead.
    """
    from ..compute.fft import fft_convolve

    cam = gbuffer.camera
    if abs(cam.fx - cam.fy) > 1e-6 * cam.fx:
        return None
    h, w = gbuffer.shape
    e = gbuffer.diffuse.astype(np.float64)
    out = e.copy()
    ids = [int(i) for i in np.unique(gbuffer.profile_id[gbuffer.profile_id > 0])]
    for pid, p in params_of_ids(params_by_id, BurleyParams, ids, "Burley parameters").items():  # (the pass's rule)
        region = gbuffer.profile_id == pid
        m = region.astype(np.float64)[..., None]
        z = float(np.median(gbuffer.depth_mm[region]))
        k = p.profile().discretize_2d(z / cam.fx, 2 * max(h, w) + 1)
        num = fft_convolve(m * e, k, "same", axes=(0, 1))
        den = fft_convolve(np.broadcast_to(m, e.shape), k, "same", axes=(0, 1))
        out[region] = (num / np.maximum(den, 1e-300))[region]
    return out.astype(np.float32)


#: bumped when the pass's estimator changes (invalidates cached converged references)
REFERENCE_VERSION = 1


def burley_reference(gbuffer: GBuffer, params_by_id: BurleyParams | Mapping[int, BurleyParams], spp: int = 4096, seed: int = 0, backend: str = "numba",
                     use_cache: bool = True) -> np.ndarray:
    """A converged reference for any G-buffer (curved surfaces included): the pass with the exact sampler,
    ``spp`` samples per pixel (Xie 2020's reference: 2k spp; here 4096) and no mips, (H, W, 3) float32.

    Cached in ``cache_dir("reference")`` (``burley-<hash>.npy``) keyed by the G-buffer's layers and
    camera, the parameters of every id, ``spp``, ``seed`` and :data:`REFERENCE_VERSION`, like the
    path-traced references (:func:`ssskit.scenes.render_reference`).
    """
    import hashlib
    import json

    from ..cache import cache_dir
    from ..io import atomic_output
    from ..screenspace.burley import _params_by_id

    by_id = _params_by_id(params_by_id, [int(i) for i in np.unique(gbuffer.profile_id[gbuffer.profile_id > 0])])
    digest = hashlib.sha1()
    for arr in (gbuffer.diffuse, gbuffer.depth, gbuffer.profile_id):
        digest.update(np.ascontiguousarray(arr).tobytes())
    digest.update(json.dumps({"camera": gbuffer.camera.to_dict(), "spp": int(spp), "seed": int(seed),
                              "params": {str(k): [p.albedo, p.d_mm] for k, p in sorted(by_id.items())},
                              "v": REFERENCE_VERSION}, sort_keys=True).encode())
    path = cache_dir("reference") / f"burley-{digest.hexdigest()[:16]}.npy"
    if use_cache and path.is_file():
        return np.load(path)
    out = burley_sss(gbuffer, by_id, spp=spp, seed=seed, sampler="exact", mips=False, backend=backend)
    if use_cache:
        with atomic_output(path) as tmp:
            with open(tmp, "wb") as fh:
                np.save(fh, out)
    return out


@dataclass
class BurleyResult(ImageLayers):
    """One frame of the Burley pass: inputs, output, ground truths and errors."""

    scene: str
    settings: RenderSettings
    burley: BurleySettings
    material: Any
    params: Any  # BurleyParams, or a mapping profile id -> BurleyParams (a scene with a material map)
    gbuffer: GBuffer
    sss: np.ndarray  # blurred diffuse layer (H, W, 3)
    image: np.ndarray  # composite albedo * sss + specular
    exact: np.ndarray | None = None
    reference: np.ndarray | None = None
    reference_info: Any = None  # the path trace's ssskit.scenes.Reference (standard errors, spp, convergence)
    metrics: dict[str, Any] = field(default_factory=dict)
    source: Path | None = None
    transmitted: np.ndarray | None = None  # the transmitted radiance in the image (H, W, 3), when the pass ran
    transmission: TransmissionInfo = field(default_factory=lambda: TransmissionInfo("off", False))
    #: profile id -> material name where a material map gives the ids different materials (else empty)
    id_materials: dict[int, str] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (the keys of :meth:`ssskit.pipeline.render.RenderResult.to_dict` where they apply)."""
        h, w = self.gbuffer.shape
        return {"scene": self.scene, "pass": "burley", "material": material_label(self.material, self.id_materials),
                **({"materials": {str(k): v for k, v in self.id_materials.items()}} if self.id_materials else {}),
                "size": [int(w), int(h)], "burley_params": _params_dict(self.params),
                "settings": self.settings.replace(width=int(w), height=int(h)).to_dict(), "burley": self.burley.to_dict(),
                "transmission": self.transmission.to_dict(), "metrics": finite(self.metrics)}

    def lines(self) -> list[str]:
        """The human-readable summary ``ssskit render`` prints."""
        b = self.burley
        h, w = self.gbuffer.shape
        by_id = self.params if isinstance(self.params, Mapping) else {1: self.params}
        d = "; ".join(", ".join(f"{x:.3g}" for x in p.d_mm) + " mm" + (f" ({self.id_materials[k]}, id {k})" if k in
                                                                        self.id_materials else "") for k, p in by_id.items())
        out = [f"# {self.scene}: Burley d = {d}, {b.sampler} sampler, "
               f"{b.spp} spp, {'mips' if b.mips else 'no mips'}, {w}x{h}, {b.backend} backend"]
        out.append(self.transmission.line())
        out += metric_lines(self.metrics)
        if self.reference_info is not None:
            out.append(reference_line(self.reference_info))
        return out


def _params_dict(params: BurleyInput) -> dict[str, Any]:
    """JSON of one BurleyParams ({albedo, d_mm}) or of a mapping id -> params ({"1": {...}, ...})."""
    if isinstance(params, Mapping):
        return {str(k): _params_dict(v) for k, v in params.items()}
    return {"albedo": list(params.albedo), "d_mm": list(params.d_mm)}


def _on_params(params: BurleyInput, fn: Callable[[BurleyParams], Any]) -> Any:
    """``fn`` of one BurleyParams, or a mapping id -> ``fn`` of each."""
    return {k: fn(v) for k, v in params.items()} if isinstance(params, Mapping) else fn(params)


def plan_burley(scene: SceneInput, settings: RenderSettings,
                params: BurleyInput | None = None) -> tuple[ScenePlan, BurleyInput]:
    """Check everything :func:`render_burley` (or the adaptive run) needs, doing no work: the scene
    (:func:`~ssskit.pipeline.frame.plan_scene`), the backend having the Burley pass, the parameters;
    returns (scene plan, params): ``params`` (BurleyParams or a mapping profile id -> BurleyParams), the
    settings' own (``albedo`` and ``dmfp_mm``) or the materials' Burley profiles (one per profile id
    when a material map gives the scene's objects their own materials)."""
    from ..screenspace.burley import burley_params_for_material

    check_instance(settings, RenderSettings, 'settings', SettingsError)
    b = settings.burley_settings()  # a SettingsError when the settings run no Burley pass
    plan = plan_scene(scene, settings)
    burley_backend(b.backend)
    if params is not None:
        ok = isinstance(params, BurleyParams) or (isinstance(params, Mapping) and params and all(
            isinstance(v, BurleyParams) for v in params.values()))
        if not ok:
            raise SettingsError(f"params must be BurleyParams or a mapping profile id -> BurleyParams, "
                                f"got {type(params).__name__}")
        return plan, params
    p = settings.pass_  # burley_settings() refused the separable pass
    given = p.params() if isinstance(p, (BurleyPass, AdaptivePass)) else None
    if given is not None:
        return plan, given
    homogeneous(plan.material, "the Burley pass (its profile comes from the coefficients)", SettingsError)
    return plan, per_id(plan, burley_params_for_material)


def render_burley(scene: SceneInput = "slab", settings: RenderSettings | None = None,
                  progress: Progress | None = None, params: BurleyInput | None = None) -> BurleyResult:
    """Render ``scene`` with the Burley pass of ``settings`` (module docstring; default: the Burley pass
    with its defaults); ``params`` (every profile id) instead of the settings' or the material's Burley
    parameters; ``progress`` receives one message per step."""
    settings = RenderSettings(pass_=BurleyPass()) if settings is None else settings
    own = params is not None
    plan, params = plan_burley(scene, settings, params)
    b = settings.burley_settings()
    say = progress or (lambda msg: None)
    # the pass's kernels compile (a fresh machine: seconds, one thread) while Mitsuba renders the G-buffer
    warming = warm_up_in_background(b.backend, ["burley"] + transmission_passes(settings, plan.transmission))
    gb = frame_gbuffer(plan, settings, _on_params(params, lambda p: p.albedo), say, beside=warming)
    say(f"Burley pass: {b.sampler} sampler, {b.spp} spp, {b.backend} backend")
    sss = burley_sss(gb, params, b)
    exact: Callable[[], np.ndarray | None] = lambda: burley_exact(gb, params)  # noqa: E731
    transmitted, info = None, TransmissionInfo(settings.transmission, False)
    if plan.transmission:
        sss, transmitted, info, exact = with_transmission(gb, sss, settings, plan.materials, plan.material,
                                                  exact, say)
    res = BurleyResult(plan.label, settings, b, plan.material, params, gb, sss, gb.composite(sss), source=plan.source,
                       id_materials=plan.id_materials if isinstance(params, Mapping) and not own else {},
                       transmitted=transmitted, transmission=info)
    ground_truths(res, settings, plan, _on_params(params, lambda p: p.profile()), exact, say, progress is not None)
    return res


__all__ = ["BurleyResult", "burley_exact", "burley_reference", "plan_burley", "render_burley"]
