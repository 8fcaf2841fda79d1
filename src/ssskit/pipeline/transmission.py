"""The transmittance pass in a rendered frame (docs/transmission.md): whether it runs, its models per profile
id, and its light added to the reflectance SSS before the albedo multiply, for the separable and the
Burley pass alike, and through :func:`transmission_light` for every frame of the adaptive run.

Whether it runs (:func:`transmission_runs`, checked before any work with the scene's plan):

* ``transmission = "off"``: never; the frame is the reflectance pass's alone, bit for bit;
* ``"auto"`` (the default): where the G-buffer has the light layers (``light_depth`` and the header
  ``ssskit_light``, :mod:`ssskit.screenspace.gbuffer`): a G-buffer file or :class:`GBuffer` that carries
  them; a scene's own G-buffer is rendered without them, so a scene renders as before, except a scene lit
  only from behind (:attr:`ssskit.scenes.SceneSpec.lit_from_behind`: the built-in ``backlit`` and ``leaf``),
  whose front is unlit (without the pass its frame is black): as under ``"on"``; where ``"auto"`` leaves a
  frame alone, a ``transmission_model`` or ``transmission_spread`` other than the default is an error (it would
  be dropped without a word), as under ``"off"``;
* ``"on"``: a built-in or mesh scene's G-buffer is rendered with them (the first light's ray-cast
  translucency shadow map, :func:`ssskit.scenes.lightspace.light_layers`); a G-buffer without them, or a
  scene without a light, is an error; a ``transmission_model = "mcml"`` needs homogeneous materials (their
  MCML slab tables).

The light added (:func:`add_transmission`). The pass gives per pixel out = T(t) E, the exitance of the light
that crossed the medium from the back (E the back surface's irradiance,
:mod:`ssskit.backends.transmission_plan` step 5); with ``transmission_spread = "mcml"`` (not the default: its
cost, docs/transmission.md) the spread step (:mod:`ssskit.backends.spread_plan`) spreads it as wide as MCML's
Tt(r) at each pixel's thickness (homogeneous materials; for any other the frame keeps the unspread light and says ``spread: off``). The G-buffer's ``diffuse`` layer is the radiance of a
white Lambertian surface, and the composite multiplies the reflectance SSS by ``albedo`` (the profile's
total diffuse reflectance Rd). Taking the transmitted light's exit as Lambertian (radiance = exitance / pi;
MCML's Tt [WJZ95] is tallied over the whole exit hemisphere), it enters the reflectance SSS demodulated by
the albedo:

    sss' = sss + T(t) E / (pi albedo),   so   albedo sss' = albedo sss + T(t) E / pi

(T(t) is already the material's whole transmittance; multiplying it by Rd would take the material's colour
twice). Pixels whose albedo is 0 get no transmitted light (nothing there to add to).

The ``unreal`` model is Unreal Engine 5's own (:mod:`ssskit.screenspace.transmission`): its light carries UE's
phase factor per pixel and its exit is UE's, the pass's out times the base colour (UE adds the transmission
to the diffuse lighting its recombine pass multiplies by the base colour): radiance = albedo out, sss' =
sss + out.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..backends import get_backend
from ..backends.transmission_plan import SlotModel
from ..errors import PassError, SettingsError
from ..materials import Material, homogeneous
from ..quantities import refuse_unused
from ..screenspace import GBuffer
from ..screenspace.transmission_slot import slot_model
from .settings import RenderSettings


@dataclass(frozen=True)
class TransmissionInfo:
    """What a frame's transmission did: the setting, whether the pass ran, its model, the share of SSS
    pixels it lit (out > 0 in some channel), and its lateral spread (``mcml`` or ``off``)."""

    setting: str
    ran: bool
    model: str | None = None
    lit_pixels: int = 0
    spread: str = "off"

    def to_dict(self) -> dict[str, Any]:
        return {"setting": self.setting, "ran": self.ran, "model": self.model, "lit_pixels": int(self.lit_pixels),
                "spread": self.spread}

    def line(self) -> str:
        """One line for the human-readable summary."""
        if not self.ran:
            return f"# transmission: off (setting {self.setting})"
        return (f"# transmission: {self.model} model, {self.lit_pixels} SSS pixels lit from behind, lateral spread "
                f"{self.spread}; transmission setting {self.setting}")


def transmission_runs(settings: RenderSettings, gbuffer: GBuffer | None, label: str, has_scene: bool,
                      scene_lights: int, materials: tuple[Any, ...], lit_from_behind: bool = False) -> bool:
    """Whether the frame runs the transmittance pass (module docstring), or a SettingsError naming why it
    cannot: ``gbuffer`` the given or loaded G-buffer (None: a scene renders it), ``label`` its name,
    ``has_scene`` whether a scene renders it with ``scene_lights`` lights, ``materials`` those of the
    profile ids (or the one material), ``lit_from_behind`` whether that scene's only light is behind its
    object (``auto`` then runs the pass)."""
    if settings.transmission == "off":
        return False
    if gbuffer is not None:
        if not gbuffer.has_light:
            if settings.transmission == "on":
                raise SettingsError(f"transmission on (--transmission on) needs the G-buffer's light layers ('light_depth' "
                                    f"and header 'ssskit_light'); {label} has none (render a scene with transmission "
                                    "on and save its G-buffer, or use transmission auto)")
            return _not_run(settings, f"the G-buffer {label} has no light layers")
    elif not has_scene or not (settings.transmission == "on" or lit_from_behind):
        return _not_run(settings, f"the scene {label} is not lit from behind alone (transmission on runs it)")
    elif scene_lights < 1:
        raise SettingsError(f"transmission on needs a light behind the object; the scene {label} has no light")
    if settings.transmission_model in ("mcml", "unreal"):
        what = "MCML slab transmittance" if settings.transmission_model == "mcml" else "Burley d"
        for m in materials:
            homogeneous(m, f"the {settings.transmission_model} transmission model (its {what})", SettingsError)
    _models_before_the_frame(settings, materials)
    return True


def _not_run(settings: RenderSettings, why: str) -> bool:
    """False (transmission auto does not run the pass, ``why``), or a SettingsError where the settings ask for a
    transmission model or spread other than the defaults: they would be dropped without a word."""
    given = [n for n, default in (("transmission_model", "mcml"), ("transmission_spread", "off"))
             if getattr(settings, n) != default]
    refuse_unused(given, "transmission", ("on",), f"{settings.transmission} ({why})", SettingsError)
    return False


def _models_before_the_frame(settings: RenderSettings, materials: tuple[Any, ...]) -> None:
    """Build every material's transmission model (and its lateral spread) now, before the G-buffer renders:
    a material outside the model's domain (a ProfileError: e.g. a table that cannot reach its floor) fails
    before any frame work; the pass later takes them from memory (:func:`slot_model`'s caches)."""
    from ..screenspace.transmission import mcml_spread

    done: set[int] = set()
    for m in materials:
        if id(m) in done:
            continue
        done.add(id(m))
        if settings.transmission_spread == "mcml" and isinstance(m, Material):
            mcml_spread(m)  # first: the MCML table (its domain is checked from sigma_t before any simulation)
        slot_model(settings.transmission_model, m)  # unreal: the Burley d, from the reflectance profile


def transmission_passes(settings: RenderSettings, transmission: bool) -> list[str]:
    """The backend passes (:data:`ssskit.backends.base.WARM_UP` names) the transmitted light of a frame runs under
    ``settings``: none without the transmittance pass (``transmission`` False: the plan's decision), else
    ``transmission``, and ``spread`` where the lateral spread is asked for (``transmission_spread = "mcml"``; off
    by default). What a first frame's warm-up compiles: the spread's kernels alone take ~6.5 s of one core."""
    if not transmission:
        return []
    return ["transmission"] + (["spread"] if settings.transmission_spread == "mcml" else [])


def _unreal_light(gb: GBuffer, light_rgb: np.ndarray, ue_phase: tuple[float, float] | None = None) -> np.ndarray:
    """The light of the ``unreal`` model: the irradiance times UE's phase factor per pixel
    (:func:`ssskit.screenspace.transmission.unreal_phase` with ``ue_phase`` = (ScatteringDistribution, IOR), UE's
    defaults if None; V towards the camera, L towards the light)."""
    from ..screenspace.transmission import UE_TRANSMISSION_DEFAULTS, LightView, unreal_phase

    assert gb.light is not None and gb.normal is not None
    pos = gb.positions()
    eye = np.linalg.inv(gb.camera.world_to_camera)[:3, 3]
    v = eye - pos
    v /= np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)
    n = gb.normal.astype(np.float64)
    n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-300)
    to_light = -np.asarray(LightView.from_dict(gb.light).direction, float)
    g, ior = ((float(UE_TRANSMISSION_DEFAULTS["ScatteringDistribution"]), float(UE_TRANSMISSION_DEFAULTS["IOR"]))
              if ue_phase is None else (float(ue_phase[0]), float(ue_phase[1])))
    phase = unreal_phase(n, v, np.broadcast_to(to_light, n.shape), g, ior)
    return np.asarray(light_rgb * phase[..., None], light_rgb.dtype)


def transmission_light(gb: GBuffer, settings: RenderSettings, material_of: dict[int, Any],
                       say: Callable[[str], None], models: Mapping[int, SlotModel] | None = None,
                       ue_phase: tuple[float, float] | None = None) -> tuple[np.ndarray, np.ndarray, TransmissionInfo]:
    """(added, radiance, info): the transmittance pass on the settings' backend with the settings' model for
    every profile id of the mask (``material_of`` id -> material), or ``models`` (profile id ->
    :class:`~ssskit.backends.transmission_plan.SlotModel`, e.g. an engine's exported parameters: models of kind
    ``unreal`` for every id take UE's light and recombine, with ``ue_phase`` = (ScatteringDistribution, IOR) of
    the exported profile, UE's defaults if None), then its
    lateral spread (``settings.transmission_spread``); ``radiance`` (H, W, 3) float32, the transmitted radiance
    in the image (T E / pi; ``unreal``: albedo times UE's light) and ``added`` = radiance / albedo in the
    backend's float type, the light to add to the reflectance SSS (module docstring), both 0 where the albedo
    is 0."""
    from ..screenspace.transmission import transmission_plan

    ids = _mask_ids(gb)
    name = settings.transmission_model if models is None else "given"
    say(f"transmittance pass: {name} model, {settings.backend} backend")
    plan = transmission_plan({pid: slot_model(settings.transmission_model, material_of[pid]) if models is None
                              else models[pid] for pid in ids}, allow_empty=True)  # (no SSS pixel: 0)
    lut = np.zeros(int(gb.profile_id.max(initial=0)) + 1, np.int32)
    lut[ids] = np.arange(1, len(ids) + 1, dtype=np.int32)
    slots = lut[gb.profile_id]
    backend = get_backend(settings.backend)
    uvz, shadow, ndl, light_rgb = gb.transmission_inputs(backend.dtype)
    if models is None:
        unreal = settings.transmission_model == "unreal"
    else:
        kinds = {models[pid].model == "unreal" for pid in ids}
        if len(kinds) > 1:
            raise PassError("given transmission models mix unreal and other kinds in one frame: their light and "
                            "recombine differ (UE's phase and base colour against T E / pi)")
        unreal = kinds == {True}
    if unreal:
        light_rgb = _unreal_light(gb, light_rgb, ue_phase)
    out = np.asarray(backend.transmission(plan, slots, uvz, shadow, ndl, light_rgb))
    # >= 0: a model whose terms subtract (the scattered part) may round a hair below 0 in float32
    out = np.maximum(out, 0.0, dtype=out.dtype)
    spread = settings.transmission_spread == "mcml" and all(isinstance(material_of[pid], Material) for pid in ids)
    if spread:
        from ..backends.spread_plan import build_spread_plan
        from ..screenspace.transmission import mcml_spread

        say(f"lateral spread of the transmitted light (MCML's Tt(r)), {settings.backend} backend")
        splan = build_spread_plan({pid: mcml_spread(material_of[pid]) for pid in ids}, gb.camera.fx, gb.camera.fy,
                                  plan.bias_mm)
        out = np.asarray(backend.transmission_spread(splan, out, gb.depth_mm, slots, uvz, shadow), out.dtype)
    flat = out.reshape(-1, 3)
    lit = int(np.count_nonzero((flat[:, 0] > 0) | (flat[:, 1] > 0) | (flat[:, 2] > 0)))
    lit_albedo = gb.albedo > 0
    if unreal:  # UE's recombine multiplies the transmitted light by the base colour: radiance = albedo out
        added = np.where(lit_albedo, out, 0.0).astype(out.dtype)
        radiance = np.multiply(added, gb.albedo, dtype=out.dtype)
    else:
        radiance = np.multiply(out, 1.0 / math.pi, dtype=out.dtype)
        np.copyto(radiance, 0.0, where=~lit_albedo)
        added = np.divide(radiance, gb.albedo, out=np.zeros_like(radiance), where=lit_albedo)
    return added, radiance.astype(np.float32, copy=False), TransmissionInfo(
        settings.transmission, True, name, lit, "mcml" if spread else "off")


def add_transmission(gb: GBuffer, sss: np.ndarray, settings: RenderSettings, material_of: dict[int, Any],
                     say: Callable[[str], None], models: Mapping[int, SlotModel] | None = None,
                     ue_phase: tuple[float, float] | None = None) -> tuple[np.ndarray, np.ndarray, TransmissionInfo]:
    """(sss', the transmitted radiance (H, W, 3) float32, info): :func:`transmission_light` (with ``models`` and
    ``ue_phase`` if given) added to ``sss`` (in its float type)."""
    added, radiance, info = transmission_light(gb, settings, material_of, say, models, ue_phase)
    dt = np.asarray(sss).dtype
    return np.add(sss, added, dtype=dt), radiance, info


def _mask_ids(gb: GBuffer) -> list[int]:
    """The profile ids (>= 1) present in the G-buffer, ascending."""
    return [int(i) for i in np.flatnonzero(np.bincount(gb.profile_id.reshape(-1))[1:]) + 1]


def material_of_ids(gb: GBuffer, materials: tuple[Any, ...], material: Any) -> dict[int, Any]:
    """Profile id -> material for the ids of ``gb``'s mask: the scene's per id (``materials``), else
    ``material`` for every id."""
    ids = _mask_ids(gb)
    return {pid: materials[min(pid, len(materials)) - 1] if materials else material for pid in ids}


def with_transmission(gb: GBuffer, sss: np.ndarray, settings: RenderSettings, materials: tuple[Any, ...], material: Any,
                      exact: Callable[[], np.ndarray | None], say: Callable[[str], None]
                      ) -> tuple[np.ndarray, np.ndarray, TransmissionInfo, Callable[[], np.ndarray | None]]:
    """A frame's pass result with the transmitted light (:func:`add_transmission`; ``materials`` the scene's
    per profile id, else ``material`` for every id), and its exact limit ``exact`` with the same light added,
    so that the metrics against it measure the reflectance pass as before."""
    total, radiance, info = add_transmission(gb, sss, settings, material_of_ids(gb, materials, material), say)

    def exact_with() -> np.ndarray | None:
        e = exact()
        if e is None:
            return None
        added = total.astype(np.float64) - np.asarray(sss, np.float64)  # what the frame got, to the last bit
        return (np.asarray(e, np.float64) + added).astype(np.asarray(e).dtype)

    return total, radiance, info, exact_with


__all__ = ["TransmissionInfo", "add_transmission", "material_of_ids", "slot_model", "transmission_light",
           "transmission_passes", "transmission_runs", "with_transmission"]
