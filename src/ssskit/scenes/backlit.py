"""The back-lit built-in scenes at other sizes: the slab of ``backlit.toml`` cut to any thickness, and the camera
of either scene at another angle, as :class:`~ssskit.scenes.scenes.SceneSpec` values that the G-buffer, the
light layers and the path-traced reference take wherever they take a scene name (docs/transmission.md, "The
back-lit slab")."""

from __future__ import annotations

import copy
import math
import tomllib

from ..errors import SceneError
from ..quantities import Choice, Quantity
from .scenefile import BUILTIN_DIR, scene_from_document
from .scenes import SceneSpec

#: the backlit slab's camera angle off the normal, thickness and field of view: the ranges its scene holds
VIEW_DEG = Quantity("view angle", 0.0, 80.0, "degrees", "the slab's face still fills the frame", hi_open=True)
THICKNESS_MM = Quantity("thickness", 0.0, 40.0, "mm", "the slab stays inside the scene's light", lo_open=True)
FOV_DEG = Quantity("fov", 1.0, 30.0, "degrees", "the camera sees the slab alone")


def _document(name: str) -> dict:
    return tomllib.loads((BUILTIN_DIR / f"{name}.toml").read_text(encoding="utf-8"))


def _view(doc: dict, view_deg: float | None) -> str:
    """Put ``doc``'s camera at ``view_deg`` from the +z normal (towards -y), at its distance; the name's suffix."""
    if view_deg is None:
        return ""
    VIEW_DEG.check(view_deg, "the view angle", SceneError)
    cam = doc["camera"]
    dist = math.dist(cam["origin"], cam["target"])
    a = math.radians(view_deg)
    cam["origin"] = [0.0, -dist * math.sin(a), dist * math.cos(a)]
    return f"-view{view_deg:g}"


def backlit_slab(thickness_mm: float, view_deg: float | None = None, fov_deg: float | None = None) -> SceneSpec:
    """The built-in ``backlit`` scene with its slab ``thickness_mm`` thick (its seen face stays at z = 0) and,
    if given, the camera ``view_deg`` off the slab's normal and its horizontal field of view ``fov_deg`` (a
    narrower one sees the slab's middle only, in finer pixels)."""
    THICKNESS_MM.check(thickness_mm, "the slab's thickness", SceneError)
    doc = copy.deepcopy(_document("backlit"))
    slab = doc["shapes"]["slab"]
    slab["translate"] = [0.0, 0.0, -thickness_mm / 2.0]
    slab["scale"] = [slab["scale"][0], slab["scale"][1], thickness_mm / 2.0]
    suffix = ""
    if fov_deg is not None:
        FOV_DEG.check(fov_deg, "the field of view", SceneError)
        doc["camera"]["fov"] = float(fov_deg)
        suffix = f"-fov{fov_deg:g}"
    doc["name"] = f"backlit-{thickness_mm:g}mm" + _view(doc, view_deg) + suffix
    doc["description"] = f"the backlit slab {thickness_mm:g} mm thick"
    return scene_from_document(doc, BUILTIN_DIR, doc["name"]).spec


def backlit_scene(name: str, view_deg: float | None = None) -> SceneSpec:
    """A built-in back-lit scene (``backlit`` or ``leaf``) with the camera ``view_deg`` off the normal."""
    name = Choice("back-lit scene", ("backlit", "leaf")).check(name, error=SceneError)
    doc = copy.deepcopy(_document(name))
    doc["name"] = name + _view(doc, view_deg)
    return scene_from_document(doc, BUILTIN_DIR, doc["name"]).spec


__all__ = ["backlit_scene", "backlit_slab"]
