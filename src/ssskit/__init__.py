"""ssskit: real-time subsurface scattering -- profiles, separable kernels, screen-space passes.

Importing ssskit is cheap: submodules (and scipy / matplotlib / numba behind them) load on first
use, e.g. ``ssskit.materials`` or ``from ssskit.profiles import profile_for_material``. The
pipeline's entry points are reachable from the top, also lazily::

    >>> import ssskit
    >>> r = ssskit.render("slab", ssskit.RenderSettings(kernel="svd:2"))   # doctest: +SKIP
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

#: every module and subpackage of ssskit, roughly bottom layer first (the layers: docs/architecture.md)
_SUBMODULES = ("errors", "progress", "registry", "cache", "io", "compute", "quantities", "settings", "metrics", "materials", "profiles",
               "kernels", "sampling", "backends", "screenspace", "scenes", "truth", "pipeline", "export", "figures", "view",
               "report", "cli")
#: names re-exported from a submodule: name -> submodule
_API = {"render": "pipeline", "RenderSettings": "pipeline", "RenderResult": "pipeline"}
#: what ``from ssskit import *`` gives: the pipeline's entry points (loading the pipeline), not this module's
#: helpers; the submodules stay attributes (``ssskit.materials``), loaded on first use
__all__ = sorted(_API)


def __getattr__(name: str) -> Any:
    if name in _SUBMODULES:
        return importlib.import_module(f"{__name__}.{name}")
    if name in _API:
        return getattr(importlib.import_module(f"{__name__}.{_API[name]}"), name)
    raise AttributeError(f"module 'ssskit' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(list(globals()) + list(_SUBMODULES) + list(_API))
