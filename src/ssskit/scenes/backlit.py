"""The back-lit built-in scenes at other sizes: the slab of ``backlit.toml`` cut to any thickness, and the camera
of either scene at another angle, as :class:`~ssskit.scenes.scenes.SceneSpec` values that the G-buffer, the
light layers and the path-traced reference take wherever they take a scene name (docs/transmission.md, "The
back-lit slab")."""

from __future__ import annotations

import copy
import math
import tomllib

from ..errors import SceneError
from .scenefile import BUILTIN_DIR, scene_from_document
from .scenes import SceneSpec


def _document(name: str) -> dict:
    return tomllib.loads((BUILTIN_DIR / f"{name}.toml").read_text(encoding="utf-8"))


def _view(doc: dict, view_deg: float | None) -> str:
    """Put ``doc``'s camera at ``view_deg`` from the +z normal (towards -y), at its distance; the name's suffix."""
    if view_deg is None:
        return ""
    if not (isinstance(view_deg, (int, float)) and 0.0 <= view_deg < 80.0):
        raise SceneError(f"the view angle must lie in [0, 80) degrees, got {view_deg!r}")
    cam = doc["camera"]
    dist = math.dist(cam["origin"], cam["target"])
    a = math.radians(view_deg)
    cam["origin"] = [0.0, -dist * math.sin(a), dist * math.cos(a)]
    return f"-view{view_deg:g}"


def backlit_slab(thickness_mm: float, view_deg: float | None = None, fov_deg: float | None = None) -> SceneSpec:
    """The built-in ``backlit`` scene with its slab ``thickness_mm`` thick (its seen face stays at z = 0) and,
    if given, the camera ``view_deg`` off the slab's normal and its horizontal field of view ``fov_deg`` (a
    narrower one sees the slab's middle only, in finer pixels)."""
    if isinstance(thickness_mm, bool) or not (isinstance(thickness_mm, (int, float)) and 0 < thickness_mm <= 40):
        raise SceneError(f"the slab's thickness must lie in (0, 40] mm, got {thickness_mm!r}")
    doc = copy.deepcopy(_document("backlit"))
    slab = doc["shapes"]["slab"]
    slab["translate"] = [0.0, 0.0, -thickness_mm / 2.0]
    slab["scale"] = [slab["scale"][0], slab["scale"][1], thickness_mm / 2.0]
    suffix = ""
    if fov_deg is not None:
        if not (isinstance(fov_deg, (int, float)) and 1.0 <= fov_deg <= 30.0):
            raise SceneError(f"the field of view must lie in [1, 30] degrees, got {fov_deg!r}")
        doc["camera"]["fov"] = float(fov_deg)
        suffix = f"-fov{fov_deg:g}"
    doc["name"] = f"backlit-{thickness_mm:g}mm" + _view(doc, view_deg) + suffix
    doc["description"] = f"the backlit slab {thickness_mm:g} mm thick"
    return scene_from_document(doc, BUILTIN_DIR, doc["name"]).spec


def backlit_scene(name: str, view_deg: float | None = None) -> SceneSpec:
    """A built-in back-lit scene (``backlit`` or ``leaf``) with the camera ``view_deg`` off the normal."""
    if name not in ("backlit", "leaf"):
        raise SceneError(f"the back-lit scenes are backlit and leaf, got {name!r}")
    doc = copy.deepcopy(_document(name))
    doc["name"] = name + _view(doc, view_deg)
    return scene_from_document(doc, BUILTIN_DIR, doc["name"]).spec


__all__ = ["backlit_scene", "backlit_slab"]
