"""ssskit: real-time subsurface scattering -- profiles, separable kernels, screen-space passes.

Importing ssskit is cheap: submodules (and scipy / matplotlib / numba behind them) load on first
use, e.g. ``ssskit.materials`` or ``from ssskit.profiles import profile_for_material``.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

_SUBMODULES = ("materials", "profiles", "kernels", "sampling", "screenspace", "scenes", "truth", "metrics", "evaluate", "figures", "errors",
               "registry", "io", "report", "cli")


def __getattr__(name: str):
    if name in _SUBMODULES:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module 'ssskit' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(list(globals()) + list(_SUBMODULES))
