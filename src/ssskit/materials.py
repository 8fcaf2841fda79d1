"""Materials: per-RGB-channel scattering coefficients and the papers' presets.

Lengths are in millimetres and coefficients in mm^-1 throughout ssskit.

Sources
-------
* The 11 measured materials: separable-SSS supplement, section G (Tables G.1-G.11), whose
  coefficients the supplement takes from Jensen et al. 2001 [JMLH01]. All have g = 0 and a
  semi-infinite thickness (10^7 cm); eta = 1.3 except Marble (1.5).
* The artist-friendly two-Gaussian presets: separable-SSS paper, Table 2 (model of Eq. 6).
"""

from __future__ import annotations

import functools
import math
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .errors import MaterialError, SsskitError
from .quantities import (ANISOTROPY, COEFFICIENT, ETA, EXTINCTION, FRACTION, LENGTH_MM, THICKNESS_MM, TYPE, Choice,
                         check_instance, check_keys, fail)
from .registry import Registry

CHANNELS: tuple[str, str, str] = ("R", "G", "B")

Triple = tuple[float, float, float]

#: mm per cm, for converting coefficients given in cm^-1 (as MCML expects) to mm^-1.
MM_PER_CM = 10.0


def _is_number(value: Any) -> bool:
    """A real number (Python or numpy), not a boolean and not a string."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _describe(value: Any) -> str:
    """How a refused value reads in a message (in the terms of a TOML/JSON file)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, str):
        try:
            float(value)
        except ValueError:
            return f"the string {value!r}"
        return f"the string {value!r} (write numbers without quotes)"
    if isinstance(value, Mapping):
        return "a table/object"
    return repr(value)


def _number(name: str, value: Any) -> float:
    """A real number as float; strings, booleans, tables and lists are refused, naming ``name`` (the quantities'
    type wording, the value described in a file's terms)."""
    if not _is_number(value):
        raise fail(MaterialError, TYPE, name=name, kind="a number", actual=_describe(value))
    return float(value)


def _triple(name: str, value: Any) -> Triple:
    """A number (the same for R, G, B) or 3 numbers (a list, tuple or numpy array) as three floats. Strings (even
    "0.1" or "123"), booleans and tables are refused, alone or inside the list; the finiteness and range are the
    field's quantity's (:meth:`Material.__post_init__`)."""
    listed = (hasattr(value, "__iter__") and not isinstance(value, (str, bytes, Mapping))
              and getattr(value, "ndim", 1) != 0)  # (a 0-d numpy array is one number)
    values = list(value) if listed else [value] * 3
    wrong = [v for v in values if not _is_number(v)]
    if len(values) != 3 or wrong:
        raise fail(MaterialError, TYPE, name=name, kind="a number or a list of 3 numbers (R, G, B)",
                   actual=_describe(wrong[0]) if wrong else f"{len(values)} values")
    return (float(values[0]), float(values[1]), float(values[2]))


#: the quantity of each field of a :class:`Material` (one number or R, G, B; one number)
_RGB_FIELDS = {"sigma_a": COEFFICIENT, "sigma_s": COEFFICIENT, "g": ANISOTROPY}
_FIELDS = {"eta": ETA, "eta_ambient": ETA, "thickness_mm": THICKNESS_MM}


@dataclass(frozen=True)
class Material:
    """A homogeneous scattering medium with per-channel (R, G, B) coefficients.

    Attributes
    ----------
    name: display name.
    sigma_a, sigma_s: absorption and scattering coefficients in mm^-1, one per channel.
    g: Henyey-Greenstein anisotropy, one per channel (|g| < 1).
    eta: refractive index of the medium (>= 1), relative to ``eta_ambient``.
    thickness_mm: slab thickness; ``math.inf`` for a semi-infinite medium.
    eta_ambient: refractive index above the surface (1 for air).
    """

    name: str
    sigma_a: Triple
    sigma_s: Triple
    g: Triple = (0.0, 0.0, 0.0)
    eta: float = 1.3
    thickness_mm: float = math.inf
    eta_ambient: float = 1.0
    source: str = field(default="user", compare=False)

    def __post_init__(self) -> None:
        for name, q in _RGB_FIELDS.items():  # each field's quantity, declared once (_RGB_FIELDS, _FIELDS)
            object.__setattr__(self, name, _triple(name, getattr(self, name)))
            q.check_array(getattr(self, name), name, MaterialError, "channels")
        EXTINCTION.check_array(self.sigma_t, "sigma_a + sigma_s", MaterialError, "channels")
        for name, q in _FIELDS.items():
            object.__setattr__(self, name, q.check(_number(name, getattr(self, name)), name, MaterialError))
        if not isinstance(self.name, str) or not self.name.strip():
            raise MaterialError("a material needs a non-empty name")

    # ---- derived quantities (per channel) -------------------------------------------------
    @property
    def sigma_t(self) -> Triple:
        """Extinction coefficient sigma_t = sigma_a + sigma_s (mm^-1)."""
        return _map2(lambda a, s: a + s, self.sigma_a, self.sigma_s)

    @property
    def albedo(self) -> Triple:
        """Single-scattering albedo alpha = sigma_s / sigma_t."""
        return _map2(lambda s, t: s / t, self.sigma_s, self.sigma_t)

    @property
    def mfp_mm(self) -> Triple:
        """Volume mean free path 1 / sigma_t (mm); supplement F's MFP for g = 0."""
        return _map1(lambda t: 1.0 / t, self.sigma_t)

    @property
    def sigma_s_reduced(self) -> Triple:
        """Reduced scattering coefficient sigma_s' = sigma_s (1 - g) (mm^-1) [JMLH01]."""
        return _map2(lambda s, g: s * (1.0 - g), self.sigma_s, self.g)

    @property
    def sigma_t_reduced(self) -> Triple:
        """Reduced extinction sigma_t' = sigma_a + sigma_s' (mm^-1) [JMLH01]."""
        return _map2(lambda a, s: a + s, self.sigma_a, self.sigma_s_reduced)

    @property
    def albedo_reduced(self) -> Triple:
        """Reduced albedo alpha' = sigma_s' / sigma_t' [JMLH01]."""
        return _map2(lambda s, t: s / t, self.sigma_s_reduced, self.sigma_t_reduced)

    @property
    def mfp_reduced_mm(self) -> Triple:
        """Transport mean free path 1 / sigma_t' (mm); supplement F's MFP definition."""
        return _map1(lambda t: 1.0 / t, self.sigma_t_reduced)

    @property
    def sigma_tr(self) -> Triple:
        """Effective transport coefficient sigma_tr = sqrt(3 sigma_a sigma_t') (mm^-1) [JMLH01]."""
        return _map2(lambda a, t: math.sqrt(3.0 * a * t), self.sigma_a, self.sigma_t_reduced)

    @property
    def is_semi_infinite(self) -> bool:
        return math.isinf(self.thickness_mm)

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form (mm^-1), loadable again by :func:`material_from_dict`."""
        return {
            "name": self.name,
            "sigma_a": list(self.sigma_a),
            "sigma_s": list(self.sigma_s),
            "g": list(self.g),
            "eta": self.eta,
            "thickness_mm": None if self.is_semi_infinite else self.thickness_mm,
            "eta_ambient": self.eta_ambient,
        }

    def summary(self) -> dict[str, Any]:
        """Coefficients plus derived quantities, for reports and ``ssskit materials --json``."""
        d = self.to_dict()
        d.update(
            source=self.source,
            sigma_t=list(self.sigma_t),
            albedo=list(self.albedo),
            mfp_mm=list(self.mfp_mm),
            sigma_s_reduced=list(self.sigma_s_reduced),
            albedo_reduced=list(self.albedo_reduced),
            sigma_tr=list(self.sigma_tr),
        )
        return d


def _map1(fn: Callable[[float], float], a: Triple) -> Triple:
    return (fn(a[0]), fn(a[1]), fn(a[2]))


def _map2(fn: Callable[[float, float], float], a: Triple, b: Triple) -> Triple:
    return (fn(a[0], b[0]), fn(a[1], b[1]), fn(a[2], b[2]))


# ---- presets ---------------------------------------------------------------------------------

MATERIALS: Registry[Material] = Registry("material", MaterialError)

_SUPPLEMENT_G = "separable-SSS supplement, section G (from [JMLH01])"

# name: (sigma_a [RGB] mm^-1, sigma_s [RGB] mm^-1, eta) -- supplement G.1-G.11, g = 0, 10^7 cm thick.
_MEASURED: dict[str, tuple[Triple, Triple, float]] = {
    "Apple": ((0.0030, 0.0034, 0.0460), (2.2900, 2.3900, 1.9700), 1.3),
    "Chicken1": ((0.0150, 0.0770, 0.1900), (0.1500, 0.2100, 0.3800), 1.3),
    "Chicken2": ((0.0180, 0.0880, 0.2000), (0.1900, 0.2500, 0.3200), 1.3),
    "Cream": ((0.0002, 0.0028, 0.0163), (7.3800, 5.4700, 3.1500), 1.3),
    "Ketchup": ((0.0610, 0.9700, 1.4500), (0.1800, 0.0700, 0.0300), 1.3),
    "Marble": ((0.0021, 0.0041, 0.0071), (2.1900, 2.6200, 3.0000), 1.5),
    "Potato": ((0.0024, 0.0090, 0.1200), (0.6800, 0.7000, 0.5500), 1.3),
    "Skimmilk": ((0.0014, 0.0025, 0.0142), (0.7000, 1.2200, 1.9000), 1.3),
    "Skin1": ((0.0320, 0.1700, 0.4800), (0.7400, 0.8800, 1.0100), 1.3),
    "Skin2": ((0.0130, 0.0700, 0.1450), (1.0900, 1.5900, 1.7900), 1.3),
    "Wholemilk": ((0.0011, 0.0024, 0.0140), (2.5500, 3.2100, 3.7700), 1.3),
}

for _preset, (_sa, _ss, _eta) in _MEASURED.items():
    MATERIALS.register(
        _preset,
        Material(_preset, _sa, _ss, (0.0, 0.0, 0.0), _eta, math.inf, 1.0, source=_SUPPLEMENT_G),
    )


@dataclass(frozen=True)
class ArtistPreset:
    """Parameters of the artist-friendly two-Gaussian separable model (paper Eq. 6).

    a_m(x) = w G(x, sigma_n) + (1 - w) G(x, sigma_f), per channel. The paper does not state the
    unit of the standard deviations; ssskit treats them as mm, like every other length.
    """

    name: str
    sigma_near: Triple
    sigma_far: Triple
    weight: float
    source: str = "separable-SSS paper, Table 2"

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma_near", _triple("sigma_near", self.sigma_near))
        object.__setattr__(self, "sigma_far", _triple("sigma_far", self.sigma_far))
        LENGTH_MM.check_array(self.sigma_near + self.sigma_far, "two-Gaussian standard deviations", MaterialError)
        FRACTION.check(self.weight, "two-Gaussian weight w", MaterialError)


ARTIST_PRESETS: Registry[ArtistPreset] = Registry("artist preset", MaterialError)
ARTIST_PRESETS.register(
    "close fit", ArtistPreset("close fit", (0.034, 0.029, 0.016), (1.0, 0.48, 0.2), 0.37)
)
ARTIST_PRESETS.register(
    "production", ArtistPreset("production", (0.25, 0.08, 0.02), (1.0, 0.3, 0.05), 0.6)
)


def homogeneous(material: Any, what: str, error: type[SsskitError] = MaterialError) -> Material:
    """``material`` if it is one homogeneous medium (a :class:`Material`), else ``error`` in one wording for every
    user of a single medium (``what``: who needs it, and where to get one, or why)."""
    if not isinstance(material, Material):
        raise error(f"{what} needs one homogeneous medium, not {_describe_material(material)}")
    return material


def _describe_material(material: Any) -> str:
    return (f"the layered material {material.name!r}" if isinstance(material, LayeredMaterial)
            else "Burley parameters without coefficients")


# ---- loading ---------------------------------------------------------------------------------

_FILE_KEYS = {"name", "sigma_a", "sigma_s", "g", "eta", "thickness_mm", "eta_ambient", "unit", "units"}
_LAYERED_KEYS = {"name", "layers", "eta_above", "eta_below", "unit", "units"}
#: the unit of a file's coefficients (mm^-1 or cm^-1, as MCML's input files) and thickness
UNIT = Choice("unit", ("mm", "cm"))


@dataclass(frozen=True)
class LayeredMaterial:
    """A stack of layers (top first) for the Monte Carlo engine; each layer is a :class:`Material`
    with its ``thickness_mm`` (only the last may be semi-infinite). Ambient indices above / below."""

    name: str
    layers: tuple[Material, ...]
    eta_above: float = 1.0
    eta_below: float = 1.0

    def __post_init__(self) -> None:
        if not self.layers:
            raise MaterialError("a layered material needs at least one layer")
        for i, layer in enumerate(self.layers[:-1]):
            LENGTH_MM.within(reason="only the last layer may be semi-infinite (omit its thickness_mm)").check(
                layer.thickness_mm, f"layer {i + 1}: thickness_mm", MaterialError)
        for attr in ("eta_above", "eta_below"):
            object.__setattr__(self, attr, ETA.check(_number(attr, getattr(self, attr)), attr, MaterialError))

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "layers": [layer.to_dict() for layer in self.layers],
                "eta_above": self.eta_above, "eta_below": self.eta_below}


def _layered_from_dict(data: Mapping[str, Any], default_name: str) -> LayeredMaterial:
    raw = check_instance(data["layers"], (list, tuple), "layers", MaterialError)  # (none: LayeredMaterial refuses it)
    unit = data.get("unit", data.get("units"))
    layers = []
    for i, entry in enumerate(raw):
        entry = dict(check_keys(entry, f"layer {i + 1}", _FILE_KEYS, error=MaterialError))  # (no layers of its own)
        if unit is not None:
            entry.setdefault("unit", unit)
        try:
            layer = material_from_dict(entry, default_name=f"layer {i + 1}")
        except MaterialError as exc:
            raise MaterialError(f"layer {i + 1}: {exc}") from None
        assert isinstance(layer, Material)
        layers.append(layer)
    return LayeredMaterial(_name(data, default_name), tuple(layers),
                           data.get("eta_above", 1.0), data.get("eta_below", 1.0))


def _name(data: Mapping[str, Any], default_name: str) -> str:
    return check_instance(data.get("name", default_name), str, "name", MaterialError)


def material_from_dict(data: Mapping[str, Any], *, default_name: str = "user material") -> Material | LayeredMaterial:
    """Build a :class:`Material` (or a :class:`LayeredMaterial`) from plain data (a parsed TOML/JSON file).

    Keys: ``sigma_a`` and ``sigma_s`` (required; a number or [R, G, B]), ``g`` (default 0),
    ``eta`` (default 1.3), ``thickness_mm`` (default semi-infinite), ``eta_ambient`` (default 1),
    ``name``, and ``unit`` = ``"mm"`` (default) or ``"cm"`` for coefficients in cm^-1 and a
    thickness in cm, as MCML input files use. A ``layers`` list of such tables (top first, each
    with ``thickness_mm``; the last may omit it for a semi-infinite layer) plus optional
    ``eta_above`` / ``eta_below`` gives a :class:`LayeredMaterial` (for the Monte Carlo engine).
    Every value must be a number (or a list of numbers): strings, booleans and tables are refused
    with a :class:`MaterialError` naming the key.
    """
    layered = isinstance(data, Mapping) and "layers" in data
    check_keys(data, "layered material" if layered else "material", _LAYERED_KEYS if layered else _FILE_KEYS,
               () if layered else ("sigma_a", "sigma_s"), MaterialError)
    if layered:
        return _layered_from_dict(data, default_name)
    unit = UNIT.check(str(data.get("unit", data.get("units", "mm"))), "unit", MaterialError)
    scale = 1.0 / MM_PER_CM if unit == "cm" else 1.0
    sigma_a = _map1(lambda v: v * scale, _triple("sigma_a", data["sigma_a"]))
    sigma_s = _map1(lambda v: v * scale, _triple("sigma_s", data["sigma_s"]))
    thickness = data.get("thickness_mm")
    if thickness is None:
        thickness = math.inf
    elif unit == "cm":
        thickness = _number("thickness_mm", thickness) * MM_PER_CM
    return Material(
        name=_name(data, default_name),
        sigma_a=sigma_a,
        sigma_s=sigma_s,
        g=data.get("g", 0.0),
        eta=data.get("eta", 1.3),
        thickness_mm=thickness,
        eta_ambient=data.get("eta_ambient", 1.0),
        source="user",
    )


def load_material(path: str | Path) -> Material | LayeredMaterial:
    """Load a material from a ``.toml`` or ``.json`` file (see :func:`material_from_dict`); a file
    with a ``layers`` list gives a :class:`LayeredMaterial`."""
    from .io import read_document

    return read_document(path, "material file", MaterialError, (".toml", ".json"),  # (io: every input file's rules)
                         functools.partial(material_from_dict, default_name=Path(path).stem))


#: readers of the material files this layer does not know, registered by the layer that does: name -> (accepts(path)
#: -> bool, read(path) -> Material). ``ssskit.export`` registers the engine files it writes (its import does it; the
#: command line imports it before reading any --material), so every command and :func:`get_material` take them.
MATERIAL_READERS: Registry[tuple[Callable[[str], bool], Callable[[str], Material]]] = Registry(
    "material file reader", MaterialError)


def get_material(name_or_path: str | Path | Material | LayeredMaterial) -> Material | LayeredMaterial:
    """A preset by (case-insensitive) name, a material file path (.toml / .json; a file with a ``layers`` list
    gives a :class:`LayeredMaterial`), or a file a registered reader accepts (:data:`MATERIAL_READERS`: the
    engine files of ``ssskit export`` once ``ssskit.export`` is imported). A material passed in is returned as is:
    the one material-loading entry point of every command."""
    if isinstance(name_or_path, (Material, LayeredMaterial)):
        return name_or_path
    text = str(name_or_path)
    if not text.strip():
        raise MaterialError(f"the material name is empty; give a preset name ({', '.join(MATERIALS.names())}) "
                            "or a .toml/.json material file")
    if text in MATERIALS:
        return MATERIALS.get(text)
    for _, (accepts, read) in MATERIAL_READERS.items():
        if accepts(text):
            return read(text)
    if text.lower().endswith((".toml", ".json")) or Path(text).exists():
        return load_material(text)
    return MATERIALS.get(text)  # raises with the list of known names


__all__ = [
    "ARTIST_PRESETS",
    "ArtistPreset",
    "CHANNELS",
    "LayeredMaterial",
    "MATERIALS",
    "MATERIAL_READERS",
    "MM_PER_CM",
    "Material",
    "Triple",
    "get_material",
    "homogeneous",
    "load_material",
    "material_from_dict",
]
