"""The transmittance model of one profile slot, by name: what the render's transmission pass and the exported
transmittance shader bake in (a module of its own: it joins the Burley pass's parameters and the transmission
models without either importing the other)."""

from __future__ import annotations

from typing import Any


def slot_model(name: str, material: Any) -> Any:
    """The :class:`~ssskit.backends.transmission_plan.SlotModel` of transmission model ``name`` for ``material``
    (mcml: its MCML fit; unreal: UE's defaults for its Burley d; jimenez2010: the skin Gaussians, no material)."""
    from .burley import burley_params_for_material
    from .transmission import jimenez2010_model, mcml_model, unreal_model

    if name == "unreal":  # UE's defaults for the material's Burley d (the Burley pass's own parameters)
        return unreal_model(burley_params_for_material(material).d_mm)
    return mcml_model(material) if name == "mcml" else jimenez2010_model()


__all__ = ["slot_model"]
