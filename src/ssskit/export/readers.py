"""Engine files read back into a material: the JSON files of ``ssskit export --format unreal|unity|blender``,
a Unity HDRP ``DiffusionProfileSettings`` .asset and a MaterialX .mtlx become Burley's (A, d) the way each
engine reads them (:func:`ssskit.export.reimport`, :func:`~ssskit.export.unity.read_unity_asset`,
:func:`~ssskit.export.materialx.read_materialx`), and from there a physical :class:`~ssskit.materials.Material`
through the Monte Carlo inversion of :mod:`ssskit.profiles.artist` (as a diffuse mean free path,
l_d = d (3.5 + 100 (A - 0.33)^4), Xie 2020 Eq. 5 Theta_3).

Values outside Burley's domain: an Unreal file is read the way UE reads it, its clamps included
(``SubsurfaceProfile.cpp`` ``CreateTexture``: SurfaceAlbedo to [0.009, 1], MeanFreePathColor to >= 0.009;
:mod:`ssskit.export.unreal`), and each clamp that fires is listed in :attr:`EngineSource.clamps` (the CLI
says so on stderr, as the export lists them under ``clamps``). No clamp of the other engines' readers is
cited here (Unity's albedo is the material's base colour, given with ``--albedo``; Blender's and
MaterialX's are node inputs), so there an albedo outside (0, 1] (A = 0 reflects no light beneath the
surface) or a length d that is not a positive finite number is refused, naming the file and the channel.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import SsskitError
from ..materials import Material
from ..quantities import BURLEY_ALBEDO

#: suffixes that hold an engine file (a .json one only when it has an "engine" key)
ENGINE_SUFFIXES = (".json", ".asset", ".mtlx")
ENGINE_NAMES = ("unreal", "unity", "blender")


@dataclass(frozen=True)
class EngineSource:
    """Burley's (A (3,), d (3,) mm) read from an engine file, with the file's engine, name and index."""

    engine: str
    name: str
    albedo: np.ndarray
    d_mm: np.ndarray
    eta: float | None = None
    #: the engine clamps that fired reading the file (Unreal's: module docstring)
    clamps: tuple[str, ...] = ()

    def profile(self) -> Any:
        from ..profiles import BurleyProfile, RGBProfile

        c = [BurleyProfile(float(a), float(d)) for a, d in zip(self.albedo, self.d_mm)]
        return RGBProfile((c[0], c[1], c[2]), "burley", self.name, {"engine": self.engine})

    def material(self, g: float = 0.0) -> Material:
        """The physical material of the Monte Carlo inversion (module docstring)."""
        from ..profiles.artist import ArtistMaterial, material_from_artist

        dmfp = self.d_mm * (3.5 + 100.0 * (self.albedo - 0.33) ** 4)
        eta = self.eta if self.eta is not None and self.eta >= 1.0 else 1.3
        a_r, a_g, a_b = (float(v) for v in self.albedo)
        d_r, d_g, d_b = (float(v) for v in dmfp)
        art = ArtistMaterial(self.name, (a_r, a_g, a_b), (d_r, d_g, d_b), "dmfp", eta, g)
        return material_from_artist(art)


def is_engine_file(path: str | Path) -> bool:
    """Whether ``path`` names an engine file (an .asset or .mtlx, or a .json with an "engine" key)."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix in (".asset", ".mtlx"):
        return True
    if suffix != ".json" or not p.is_file():
        return False
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return False
    return isinstance(data, dict) and "engine" in data


def read_engine_file(path: str | Path, expect: str | None = None, albedo: Any = None) -> EngineSource:
    """An :class:`EngineSource` from an engine file. ``expect``: the engine the caller asked for (an
    Unreal file given where a Unity one is expected is refused, naming both). ``albedo`` (3,): the
    surface albedo for a Unity .asset, whose profile holds none (HDRP takes it from the material)."""
    from .engines import reimport

    p = Path(path)
    if not p.is_file():
        raise SsskitError(f"cannot read engine file {str(p)!r}: no such file")
    suffix = p.suffix.lower()
    if suffix == ".asset":
        engine = "unity"
    elif suffix == ".mtlx":
        engine = "materialx"
    else:
        try:
            data = json.loads(p.read_text(encoding="utf-8"))
        except (UnicodeDecodeError, ValueError) as exc:
            raise SsskitError(f"malformed engine file {str(p)!r}: {exc}") from None
        engine = str(data.get("engine", "")) if isinstance(data, dict) else ""
        if engine not in ENGINE_NAMES:
            raise SsskitError(f"{str(p)!r} is an export of engine {engine!r}; ssskit reads {', '.join(ENGINE_NAMES)}")
    if expect is not None and engine != expect:
        raise SsskitError(f"{str(p)!r} is a {engine} file, not a {expect} one")
    if engine == "unity" and suffix == ".asset":
        from .unity import read_unity_asset

        try:
            text = p.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            raise SsskitError(f"{str(p)!r} is not a text (YAML) .asset file") from None
        u = read_unity_asset(text, repr(str(p)))
        if u["worldScale"] != 1.0:
            raise SsskitError(f"{str(p)!r}: worldScale {u['worldScale']}: ssskit reads profiles at HDRP's worldScale 1 "
                              "(scattering distances in mm) only")
        d = np.array(u["scatteringDistance"]) * u["scatteringDistanceMultiplier"]
        if albedo is None:
            raise SsskitError(f"{str(p)!r}: a DiffusionProfileSettings asset holds no albedo (HDRP takes it from "
                              "the material's base colour): give --albedo R,G,B, or read ssskit's JSON export")
        _check_burley_inputs(p, engine, np.asarray(albedo, dtype=float), d)
        return EngineSource("unity", u["name"], np.asarray(albedo, dtype=float), d, u["ior"])
    if engine == "materialx":
        from .materialx import read_materialx

        m = read_materialx(p)
        return EngineSource("materialx", str(m["name"]), m["albedo"], m["d_mm"])
    clamps: tuple[str, ...] = ()
    try:
        if engine == "unreal":
            clamps = _unreal_clamps(data["mfp"])
        else:
            _check_burley_inputs(p, engine, np.asarray(data["base_color"], dtype=float))
        prof = reimport(data, "burley")
    except SsskitError as exc:  # (a ValueError too): a value the file has is out of its domain, not missing
        if str(p) in str(exc):
            raise
        raise SsskitError(f"{str(p)!r}: {exc}") from None
    except (KeyError, TypeError, ValueError) as exc:
        raise SsskitError(f"{str(p)!r} lacks the {engine} parameters ssskit writes ({exc})") from None
    from ..profiles.burley import BurleyProfile

    chans = [ch for ch in prof.channels if isinstance(ch, BurleyProfile)]  # reimport gives Burley channels
    a = np.array([ch.albedo for ch in chans])
    d = np.array([ch.d for ch in chans])
    _check_burley_inputs(p, engine, a, d)
    eta = data.get("IOR", data.get("ior"))
    name = str(data.get("source_profile", {}).get("name", p.stem)) if isinstance(data.get("source_profile"), dict) \
        else p.stem
    return EngineSource(engine, name, a, d, float(eta) if isinstance(eta, (int, float)) else None, clamps)


def _unreal_clamps(block: dict[str, Any]) -> tuple[str, ...]:
    """The clamps UE applies reading a Burley block (module docstring), as the export words them."""
    from .unreal import COLOR_BIAS

    out = []
    for field, hi in (("SurfaceAlbedo", 1.0), ("MeanFreePathColor", None)):
        v = np.asarray(block[field], dtype=np.float32).astype(float)
        if v.shape != (3,) or not np.all(np.isfinite(v)):
            raise ValueError(f"{field} must be 3 finite numbers, got {block[field]!r}")
        for c in range(3):
            eng = min(max(v[c], COLOR_BIAS), hi) if hi is not None else max(v[c], COLOR_BIAS)
            if eng != v[c]:
                rng = f"[{COLOR_BIAS:g}, {hi:g}]" if hi is not None else f">= {COLOR_BIAS:g}"
                out.append(f"{field}[{'RGB'[c]}] {v[c]:.4g} -> {eng:.4g} (UE clamps to {rng})")
    return tuple(out)


def _check_burley_inputs(path: Path, engine: str, albedo: np.ndarray, d_mm: np.ndarray | None = None) -> None:
    """Burley's domain for an engine without a cited clamp (module docstring): A in (0, 1], d > 0 finite."""
    BURLEY_ALBEDO.check_array(np.asarray(albedo, dtype=float).reshape(-1)[:3],  # no clamp ssskit could apply
                              f"{str(path)!r}: the {engine} albedo", SsskitError, "channels")
    if d_mm is not None:
        for c, v in enumerate(d_mm):
            if not (np.isfinite(v) and v > 0.0):
                raise SsskitError(f"{str(path)!r}: Burley's d must be a positive number of mm, got {v:g} in channel "
                                  f"{'RGB'[c]}")


__all__ = ["ENGINE_NAMES", "ENGINE_SUFFIXES", "EngineSource", "is_engine_file", "read_engine_file"]
