"""The transmittance pass in a rendered frame (docs/transmission.md): whether it runs, its models per profile
id, and its light added to the reflectance SSS before the albedo multiply, for the separable and the
Burley pass alike.

Whether it runs (:func:`transmission_runs`, checked before any work with the scene's plan):

* ``transmission = "off"``: never; the frame is the reflectance pass's alone, bit for bit;
* ``"auto"`` (the default): where the G-buffer has the light layers (``light_depth`` and the header
  ``ssskit_light``, :mod:`ssskit.screenspace.gbuffer`): a G-buffer file or :class:`GBuffer` that carries
  them; a scene's own G-buffer is rendered without them, so a scene renders as before;
* ``"on"``: a built-in or mesh scene's G-buffer is rendered with them (the first light's ray-cast
  translucency shadow map, :func:`ssskit.scenes.lightspace.light_layers`); a G-buffer without them, or a
  scene without a light, is an error; a ``transmission_model = "mcml"`` needs homogeneous materials (their
  MCML slab tables).

The light added (:func:`add_transmission`). The pass gives per pixel out = T(t) E, the exitance of the light
that crossed the medium from the back (E the back surface's irradiance,
:mod:`ssskit.backends.transmission_plan` step 5); with ``transmission_spread = "mcml"`` (the default) the
spread step (:mod:`ssskit.backends.spread_plan`) spreads it as wide as MCML's Tt(r) at each pixel's thickness
(homogeneous materials; for any other the frame keeps the unspread light and says ``spread: off``). The G-buffer's ``diffuse`` layer is the radiance of a
white Lambertian surface, and the composite multiplies the reflectance SSS by ``albedo`` (the profile's
total diffuse reflectance Rd). Taking the transmitted light's exit as Lambertian (radiance = exitance / pi;
MCML's Tt [WJZ95] is tallied over the whole exit hemisphere), it enters the reflectance SSS demodulated by
the albedo:

    sss' = sss + T(t) E / (pi albedo),   so   albedo sss' = albedo sss + T(t) E / pi

(T(t) is already the material's whole transmittance; multiplying it by Rd would take the material's colour
twice). Pixels whose albedo is 0 get no transmitted light (nothing there to add to).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..backends import get_backend
from ..backends.transmission_plan import SlotModel
from ..errors import SettingsError
from ..materials import Material
from ..screenspace import GBuffer
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
                f"{self.spread} (setting {self.setting})")


def transmission_runs(settings: RenderSettings, gbuffer: GBuffer | None, label: str, has_scene: bool,
                      scene_lights: int, materials: tuple[Any, ...]) -> bool:
    """Whether the frame runs the transmittance pass (module docstring), or a SettingsError naming why it
    cannot: ``gbuffer`` the given or loaded G-buffer (None: a scene renders it), ``label`` its name,
    ``has_scene`` whether a scene renders it with ``scene_lights`` lights, ``materials`` those of the
    profile ids (or the one material)."""
    if settings.transmission == "off" or settings.pass_name == "burley-adaptive":
        return False
    if gbuffer is not None:
        if not gbuffer.has_light:
            if settings.transmission == "on":
                raise SettingsError(f"transmission on (--transmission on) needs the G-buffer's light layers ('light_depth' "
                                    f"and header 'ssskit_light'); {label} has none (render a scene with transmission "
                                    "on and save its G-buffer, or use transmission auto)")
            return False
    elif not has_scene or settings.transmission != "on":
        return False
    elif scene_lights < 1:
        raise SettingsError(f"transmission on needs a light behind the object; the scene {label} has no light")
    if settings.transmission_model == "mcml":
        for m in materials:
            if not isinstance(m, Material):
                raise SettingsError(f"the mcml transmission model needs homogeneous materials (their MCML slab "
                                    f"transmittance); {getattr(m, 'name', m)!r} is a {type(m).__name__}")
    return True


def _model(name: str, material: Any) -> Any:
    from ..screenspace.transmission import jimenez2010_model, mcml_model

    return mcml_model(material) if name == "mcml" else jimenez2010_model()


def add_transmission(gb: GBuffer, sss: np.ndarray, settings: RenderSettings, material_of: dict[int, Any],
                     say: Callable[[str], None], models: Mapping[int, SlotModel] | None = None,
                     ) -> tuple[np.ndarray, np.ndarray, TransmissionInfo]:
    """(sss', transmitted radiance T E / pi (H, W, 3) float32, info): the transmittance pass on the settings'
    backend with the settings' model for every profile id of the mask (``material_of`` id -> material), or
    ``models`` (profile id -> :class:`~ssskit.backends.transmission_plan.SlotModel`, e.g. an engine's exported
    parameters), spread (``settings.transmission_spread``), demodulated and added to ``sss`` (module docstring)."""
    from ..screenspace.transmission import transmission_plan

    ids = sorted(int(i) for i in np.unique(gb.profile_id[gb.mask]))
    name = settings.transmission_model if models is None else "given"
    say(f"transmittance pass: {name} model, {settings.backend} backend")
    plan = transmission_plan({pid: _model(settings.transmission_model, material_of[pid]) if models is None
                              else models[pid] for pid in ids})
    lut = np.zeros(int(gb.profile_id.max(initial=0)) + 1, np.int32)
    lut[ids] = np.arange(1, len(ids) + 1, dtype=np.int32)
    slots = lut[gb.profile_id]
    backend = get_backend(settings.backend)
    uvz, shadow, ndl, light = gb.transmission_inputs()
    # >= 0: a model whose terms subtract (the scattered part) may round a hair below 0 in float32
    out = np.maximum(np.asarray(backend.transmission(plan, slots, uvz, shadow, ndl, light), np.float64), 0.0)
    spread = settings.transmission_spread == "mcml" and all(isinstance(material_of[pid], Material) for pid in ids)
    if spread:
        from ..backends.spread_plan import build_spread_plan
        from ..screenspace.transmission import mcml_spread

        say(f"lateral spread of the transmitted light (MCML's Tt(r)), {settings.backend} backend")
        splan = build_spread_plan({pid: mcml_spread(material_of[pid]) for pid in ids}, gb.camera.fx, gb.camera.fy,
                                  plan.bias_mm)
        out = np.asarray(backend.transmission_spread(splan, out, gb.depth_mm, slots, uvz, shadow), np.float64)
    radiance = out / math.pi
    albedo = gb.albedo.astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        demod = np.where(albedo > 0, radiance / albedo, 0.0)
    lit = int(np.count_nonzero(np.any(out > 0, axis=-1)))
    total = (np.asarray(sss, np.float64) + demod).astype(np.asarray(sss).dtype)
    return total, np.where(albedo > 0, radiance, 0.0).astype(np.float32), TransmissionInfo(
        settings.transmission, True, name, lit, "mcml" if spread else "off")


def with_transmission(gb: GBuffer, sss: np.ndarray, settings: RenderSettings, materials: tuple[Any, ...], material: Any,
                      exact: Callable[[], np.ndarray | None], say: Callable[[str], None]
                      ) -> tuple[np.ndarray, np.ndarray, TransmissionInfo, Callable[[], np.ndarray | None]]:
    """A frame's pass result with the transmitted light (:func:`add_transmission`; ``materials`` the scene's
    per profile id, else ``material`` for every id), and its exact limit ``exact`` with the same light added,
    so that the metrics against it measure the reflectance pass as before."""
    ids = [int(i) for i in np.unique(gb.profile_id[gb.mask])]
    material_of = {pid: materials[min(pid, len(materials)) - 1] if materials else material for pid in ids}
    total, radiance, info = add_transmission(gb, sss, settings, material_of, say)
    added = total.astype(np.float64) - np.asarray(sss, np.float64)

    def exact_with() -> np.ndarray | None:
        e = exact()
        return None if e is None else (np.asarray(e, np.float64) + added).astype(np.asarray(e).dtype)

    return total, radiance, info, exact_with


__all__ = ["TransmissionInfo", "add_transmission", "transmission_runs", "with_transmission"]
