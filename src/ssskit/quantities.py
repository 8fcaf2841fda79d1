"""One vocabulary of the quantities ssskit takes: each with its range, unit and the reason for the range, and
one ``check`` whose wording names the actual and the expected value.

Every entry point (settings classes, material and scene readers, engine readers, the profiles' domains, the
backends' frame checks, the CLI) states its inputs in these terms, so a rule is written once and refused in
one wording wherever the value enters (kornia's ``KORNIA_CHECK`` and pydantic/attrs field constraints are the
models). A check raises the caller's area error (``error=``: :class:`~ssskit.errors.MaterialError`,
:class:`~ssskit.errors.SettingsError`, ...), so a caller's ``except`` and tests keep working, under the name the
caller gives (a settings field, ``--spp`` on the command line, ``layer 2: sigma_a`` in a file).

The wordings (the only ones: ``benchmarks/validation_count.py`` counts the phrasings left elsewhere)::

    {name} must be {kind}, got {actual!r}                 a value of the wrong type
    {name} must be finite, got {actual}                   NaN or infinity in an array (an image, a table)
    {name} must lie in {interval}[ unit], got {actual}[ (reason)]   a number out of range (NaN included)
    {name} must be one of {choices}, got {actual!r}       a name that is not among the choices

    >>> BURLEY_ALBEDO.check(0.5, "albedo")
    0.5
    >>> SPP.check(0, "spp")
    Traceback (most recent call last):
    ...
    ssskit.errors.SsskitError: spp must lie in [1, 4096], got 0 (samples per pixel of one G-buffer render; more is a reference's job)
"""

from __future__ import annotations

import functools
import inspect
import math
import numbers
import operator
from collections.abc import Callable, Collection, Iterable
from dataclasses import dataclass, replace
from typing import Any, TypeVar, cast

from .errors import SsskitError

#: the wordings (module docstring); every message below is made from one of them
TYPE = "{name} must be {kind}, got {actual}"
FINITE = "{name} must be finite, got {actual}"
RANGE = "{name} must lie in {interval}{unit}, got {actual}{reason}"
CHOICE = "{name} must be one of {choices}, got {actual}"
#: the wording of an option given but not used by what runs (:func:`refuse_unused`)
UNUSED = "{names} appl{verb} to {category} {values}, not {category} {actual}"

ErrorClass = type[SsskitError]


def fail(error: ErrorClass, template: str, **fields: object) -> SsskitError:
    """The error ``error(template.format(**fields))``: raise what this returns."""
    return error(template.format(**fields))


def _fmt(v: object) -> str:
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, (list, tuple)) or getattr(v, "ndim", 0) == 1:
        return "(" + ", ".join(_fmt(x) for x in v) + ")"  # type: ignore[attr-defined]
    if isinstance(v, numbers.Real) and not isinstance(v, (bool, int)):
        return f"{float(v):g}"
    return repr(v)


def _bound(v: float) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


@dataclass(frozen=True)
class Quantity:
    """A number (or each of three, ``rgb``) with its range ``[lo, hi]`` (``lo_open`` / ``hi_open``: that end
    excluded), ``unit`` (``mm``, ``mm^-1``, ``px``; empty for none), ``reason`` (why the range: the model's
    domain, a paper's value, what the arithmetic holds), ``integer`` (an int; bools are refused everywhere) and
    ``odd`` (an odd integer)."""

    name: str
    lo: float
    hi: float
    unit: str = ""
    reason: str = ""
    integer: bool = False
    lo_open: bool = False
    hi_open: bool = False
    odd: bool = False

    def within(self, lo: float | None = None, hi: float | None = None, reason: str | None = None) -> Quantity:
        """The same quantity on a narrower (or caller-given) range: a model's domain, another's bound; an end
        given here is included (closed)."""
        return replace(self, lo=self.lo if lo is None else lo, hi=self.hi if hi is None else hi,
                       lo_open=self.lo_open and lo is None, hi_open=self.hi_open and hi is None,
                       reason=self.reason if reason is None else reason)

    @property
    def interval(self) -> str:
        return f"{'(' if self.lo_open else '['}{_bound(self.lo)}, {_bound(self.hi)}{')' if self.hi_open else ']'}"

    @property
    def kind(self) -> str:
        return "an odd integer" if self.odd else "an integer" if self.integer else "a number"

    def contains(self, v: float) -> bool:
        lo_ok = v > self.lo if self.lo_open else v >= self.lo
        hi_ok = v < self.hi if self.hi_open else v <= self.hi
        return lo_ok and hi_ok

    def _scalar(self, value: object, name: str, error: ErrorClass, shown: object = None) -> Any:
        try:  # an integer is what operator.index takes (numpy's too, never a float), a number what float() takes
            if isinstance(value, (bool, str, bytes)):
                raise TypeError(value)
            v: int | float = operator.index(value) if self.integer else float(value)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            raise fail(error, TYPE, name=name, kind=self.kind, actual=repr(value)) from None
        if not self.contains(v):  # NaN fails both comparisons; an infinity only where the range holds it
            self.refuse(v if shown is None else shown, name, error)
        if self.odd and int(v) % 2 == 0:
            raise fail(error, TYPE, name=name, kind=self.kind, actual=repr(v))
        return v

    def refuse(self, actual: object, name: str | None = None, error: ErrorClass = SsskitError) -> SsskitError:
        """Raise the range wording for ``actual`` (for callers that test the range themselves, on arrays)."""
        raise self._range(_fmt(actual), name or self.name, error)

    def _range(self, actual: str, name: str, error: ErrorClass) -> SsskitError:
        return fail(error, RANGE, name=name, interval=self.interval, unit=f" {self.unit}" if self.unit else "",
                    actual=actual, reason=f" ({self.reason})" if self.reason else "")

    def check(self, value: object, name: str | None = None, error: ErrorClass = SsskitError) -> Any:
        """``value`` as an int or float in the range, or ``error`` in the module's wording under ``name``."""
        return self._scalar(value, name or self.name, error)

    def check_rgb(self, value: object, name: str | None = None, error: ErrorClass = SsskitError,
                  ) -> tuple[float, float, float]:
        """One number or three (R, G, B), each in the range: three floats."""
        label = name or self.name
        seq = isinstance(value, (list, tuple)) or getattr(value, "ndim", 0) == 1  # a list, tuple or 1D array
        one = value.item() if getattr(value, "ndim", None) == 0 else value  # type: ignore[attr-defined] # a 0-d array
        vals = tuple(value) if seq else (one,)  # type: ignore[arg-type]
        if len(vals) not in (1, 3) or any(isinstance(v, (bool, str, bytes)) or not isinstance(v, numbers.Real)
                                          for v in vals):
            raise fail(error, TYPE, name=label, kind=f"{self.kind} or three [R, G, B]", actual=_fmt(value))
        shown = vals[0] if len(vals) == 1 else vals
        r, g, b = (float(self._scalar(v, label, error, shown)) for v in (vals * 3 if len(vals) == 1 else vals))
        return r, g, b

    def check_array(self, values: Any, name: str | None = None, error: ErrorClass = SsskitError,
                    where: str = "") -> Any:
        """An array of floats, all finite and in the range (``where``: what the elements are, e.g.
        ``"pixels"``); returned as a numpy array."""
        import numpy as np

        label = name or self.name
        a = check_finite(np.asarray(values, dtype=np.float64), label, error, where)
        lo_bad = a <= self.lo if self.lo_open else a < self.lo
        hi_bad = a >= self.hi if self.hi_open else a > self.hi
        out = lo_bad | hi_bad
        if out.any():
            raise self._range(f"{a[out].flat[0]:g} in {int(out.sum())} of {a.size} {where or 'values'}", label, error)
        return a


def _count(bad: Any, a: Any, where: str) -> str:
    import numpy as np

    first = tuple(int(i) for i in np.argwhere(bad)[0]) if a.ndim else ()
    at = f", the first at {first if len(first) > 1 else first[0]}" if first else ""
    return f"NaN or inf in {int(bad.sum())} of {a.size} {where or 'values'}{at}"


def check_finite(values: Any, name: str, error: ErrorClass = SsskitError, where: str = "") -> Any:
    """An array (an image, a table) with no NaN or infinity, or ``error`` in the finiteness wording: the count
    and the first index. Returns it as given."""
    import numpy as np

    a = np.asarray(values)
    if a.dtype.kind in "fc":
        bad = ~np.isfinite(a)
        if bad.any():
            raise fail(error, FINITE, name=name, actual=_count(bad, a, where))
    return values


@dataclass(frozen=True)
class Choice:
    """A name among ``choices`` (a collection, or a function returning one: a registry's names, read when
    checked), case-insensitive, returned in its canonical spelling; ``optional``: None passes."""

    name: str
    choices: Collection[str] | Callable[[], Collection[str]]
    reason: str = ""

    def names(self) -> Collection[str]:
        return self.choices() if callable(self.choices) else self.choices

    def check(self, value: object, name: str | None = None, error: ErrorClass = SsskitError) -> str:
        names = self.names()
        if isinstance(value, str):
            for c in names:
                if c.lower() == value.strip().lower():
                    return c
        raise fail(error, CHOICE, name=name or self.name, choices=", ".join(names), actual=repr(value))


@dataclass(frozen=True)
class Flag:
    """true or false (a bool, nothing else)."""

    name: str
    reason: str = ""

    def check(self, value: object, name: str | None = None, error: ErrorClass = SsskitError) -> bool:
        if not isinstance(value, bool):
            raise fail(error, TYPE, name=name or self.name, kind="true or false", actual=repr(value))
        return value


def check_choice(name: str, value: object, choices: Collection[str], error: ErrorClass = SsskitError) -> str:
    """``value`` (case-insensitive) among ``choices``, in its canonical spelling: :class:`Choice`'s check."""
    return Choice(name, choices).check(value, name, error)


def refuse_unused(names: Iterable[str], category: str, values: Iterable[str], actual: object,
                  error: ErrorClass = SsskitError) -> None:
    """Refuse options given but not used by what runs, in the one wording (Mitsuba's unqueried-property check):
    ``{names} applies to {category} {values}, not {category} {actual}``, e.g. ``c applies to sampler xie, not
    sampler exact`` or, in the CLI's terms, ``--c applies to --sampler xie, not --sampler exact``. Nothing when
    ``names`` is empty."""
    given = list(names)
    if given:
        raise fail(error, UNUSED, names=", ".join(given), verb="ies" if len(given) == 1 else "y", category=category,
                   values=" or ".join(values), actual=actual)


# --- the vocabulary -------------------------------------------------------------------------------------------
# lengths are millimetres (materials.py); counts are integers; every bound says why it is where it is

#: transport mean free paths 1/sigma_t' (and any mean free path an artist gives) every model takes
MFP_MM = Quantity("mean free path", 1e-6, 1e6, "mm", "1 nm to 1 km: beyond it a profile's grid overflows or "
                  "underflows, docs/models.md")
#: Burley's surface albedo A (Xie 2020 Eq. 5, Burley 2015): the total diffuse reflectance of a scattering medium
BURLEY_ALBEDO = Quantity("Burley albedo A", 0.0, 1.0, "",
                         "a reflectance; A = 0 reflects no light beneath the surface: R(r) = 0 and a kernel "
                         "normalised by it is 0/0", lo_open=True)
#: a reflectance that may be 0 (a surround, a diffuse colour): [0, 1]
REFLECTANCE = Quantity("albedo", 0.0, 1.0, "", "a reflectance")
#: absorption and scattering coefficients (mm^-1): >= 0, finite
COEFFICIENT = Quantity("coefficient", 0.0, math.inf, "mm^-1", "an attenuation per mm", hi_open=True)
#: the extinction sigma_t = sigma_a + sigma_s (mm^-1): > 0
EXTINCTION = Quantity("sigma_t", 0.0, math.inf, "mm^-1", "a medium that neither absorbs nor scatters holds no "
                      "light beneath its surface", lo_open=True, hi_open=True)
#: the Henyey-Greenstein anisotropy g (mean cosine of the scattering angle)
ANISOTROPY = Quantity("g", -1.0, 1.0, "", "the mean cosine of the scattering angle; |g| = 1 is a delta phase "
                      "function that never turns", lo_open=True, hi_open=True)
#: refractive index (absolute or relative to the outside); each model bounds it further (profiles.domain)
ETA = Quantity("eta", 1.0, math.inf, "", "a refractive index; vacuum is 1", hi_open=True)
#: a layer's thickness (mm); inf: semi-infinite
THICKNESS_MM = Quantity("thickness_mm", 0.0, math.inf, "mm", "a slab's depth; inf for a semi-infinite medium",
                        lo_open=True)
#: a distance or size in mm that must be positive (pixel size, texel size, kernel cell, Burley's d)
LENGTH_MM = Quantity("length", 0.0, math.inf, "mm", "a length", lo_open=True, hi_open=True)
#: photons per channel of a Monte Carlo profile (one range for every command)
PHOTONS = Quantity("photons", 1_000, 10_000_000_000, "", "below 10^3 the tallies are noise; 10^10 is hours per "
                   "channel", integer=True)
#: samples per pixel of one G-buffer or Burley pass
SPP = Quantity("spp", 1, 4096, "", "samples per pixel of one G-buffer render; more is a reference's job",
               integer=True)
#: samples per pixel of a path-traced reference
REFERENCE_SPP = Quantity("reference_spp", 1, 1 << 20, "", "samples per pixel of a path-traced reference",
                         integer=True)
#: frames of one adaptive run or sequence
FRAMES = Quantity("frames", 1, 100_000, "", "frames of one run; a sequence's G-buffers are kept", integer=True)
#: taps of one 1D pass (odd: a centre tap)
TAPS = Quantity("taps", 1, 255, "", "taps of one 1D pass, odd for a centre tap", integer=True, odd=True)
#: image sides of the built-in scenes (pixels)
SIZE_PX = Quantity("size", 8, 8192, "px", "image sides of a rendered G-buffer", integer=True)
#: a seed or a frame index: the counter-based hashes take 31 bits
SEED = Quantity("seed", 0, 2**31 - 1, "", "the per-pixel hashes take 31 bits", integer=True)
FRAME = Quantity("frame", 0, 2**31 - 1, "", "the per-pixel hashes take 31 bits", integer=True)
#: a fraction in [0, 1] (jitter as a fraction of the kernel, bleed, kappa)
FRACTION = Quantity("fraction", 0.0, 1.0)
#: a relative standard error a reference is run to
REL_SE = Quantity("reference_rel_se", 0.0, 1.0, "", "a relative standard error", lo_open=True, hi_open=True)
#: a scale factor that must be positive and finite
SCALE = Quantity("scale", 1e-6, 1e6, "", "a positive factor")

__all__ = ["ANISOTROPY", "BURLEY_ALBEDO", "CHOICE", "COEFFICIENT", "Choice", "ETA", "EXTINCTION", "FINITE", "FRACTION", "FRAME",
           "FRAMES", "Flag", "LENGTH_MM", "MFP_MM", "PHOTONS", "Quantity", "RANGE", "REFERENCE_SPP", "REFLECTANCE",
           "REL_SE", "SCALE", "SEED", "SIZE_PX", "SPP", "TAPS", "THICKNESS_MM", "TYPE", "UNUSED", "check_choice",
           "check_finite", "fail", "refuse_unused"]


# --- vocab-b: arrays, tables and their keys, in the wordings above ------------------------------------------------

from collections.abc import Mapping  # noqa: E402
from typing import TYPE_CHECKING  # noqa: E402

if TYPE_CHECKING:
    import numpy as np

_KINDS = {"iuf": "a real", "iu": "an integer", "f": "a float", "b": "a boolean", "iufb": "a real or boolean"}


def check_shape(values: Any, name: str, shape: tuple[int | str, ...], error: ErrorClass = SsskitError,
                kinds: str = "iuf", dtype: Any = None, finite: bool = False, where: str = "values") -> np.ndarray:
    """``values`` as a numpy array (``dtype``: converted to it) of ``shape`` (an int per axis, or a letter such as
    ``"H"`` for any length) whose dtype kind is one of ``kinds`` (numpy's letters: ``"iuf"`` real, ``"iu"``
    integer, ``"b"`` boolean; an empty array passes), with ``finite`` no NaN or infinity; else ``error`` in the
    type (or finiteness) wording: ``diffuse must be a real array of shape (4, 4, 3), got shape (4, 4) float64``."""
    import numpy as np

    expected = "(" + ", ".join(map(str, shape)) + ("," if len(shape) == 1 else "") + ")"
    kind = f"{_KINDS.get(kinds, 'a')} array of shape {expected}"
    try:
        a = np.asarray(values)
    except (TypeError, ValueError) as e:
        raise fail(error, TYPE, name=name, kind=kind, actual=f"{type(values).__name__} ({e})") from None
    if a.ndim != len(shape) or any(isinstance(n, int) and n != m for n, m in zip(shape, a.shape)) or (
            a.dtype.kind not in kinds and a.size):
        raise fail(error, TYPE, name=name, kind=kind, actual=f"shape {a.shape} {a.dtype}")
    if finite:
        check_finite(a, name, error, where)
    return a if dtype is None else a.astype(dtype, copy=False)


def check_keys(table: object, where: str, allowed: Collection[str] | None = None, required: Collection[str] = (),
               error: ErrorClass = SsskitError) -> Any:
    """``table`` (a mapping: a TOML or JSON table) with no key outside ``allowed`` (None: any key) and every one of
    ``required``; else ``error``: ``{where}: unknown key(s) a, b (known: ...)``, ``{where}: missing a, b`` or
    ``{where} must be a table``."""
    if not isinstance(table, Mapping):
        raise fail(error, TYPE, name=where, kind="a table", actual=_fmt(table))
    unknown = [] if allowed is None else sorted(str(k) for k in table if k not in allowed)
    if unknown:
        raise error(f"{where}: unknown key(s) {', '.join(unknown)} (known: {', '.join(sorted(allowed or ()))})")
    missing = [k for k in required if k not in table]
    if missing:
        raise error(f"{where}: missing {', '.join(missing)}")
    return table


def check_fields(table: Any, fields: Mapping[str, Quantity | Choice | Flag | Rule], where: str = "",
                 error: ErrorClass = SsskitError, rgb: Collection[str] = ()) -> dict[str, Any]:
    """Each key of ``fields`` that ``table`` holds, checked by its quantity (``rgb``: the keys that take one
    number or three) under the name ``{where}: {key}`` (``where`` empty: the key alone): a dict of the checked
    values. The table-driven reader of a file's section: each field's quantity is declared once."""
    out: dict[str, Any] = {}
    for key, q in fields.items():
        if key in table:
            label = f"{where}: {key}" if where else key
            out[key] = q.check_rgb(table[key], label, error) if key in rgb and isinstance(q, Quantity) else \
                q.check(table[key], label, error)
    return out


__all__ += ["check_shape", "check_fields", "check_keys"]


def check_instance(value: Any, kind: type | tuple[type, ...], name: str, error: ErrorClass = SsskitError,
                   optional: bool = False) -> Any:
    """``value`` if it is a ``kind`` (``optional``: or None), else ``error`` in the type wording: ``burley must be
    BurleySettings, got dict``."""
    if (optional and value is None) or isinstance(value, kind):
        return value
    names = " or ".join(k.__name__ for k in (kind if isinstance(kind, tuple) else (kind,)))
    raise fail(error, TYPE, name=name, kind=names, actual=type(value).__name__)


__all__ += ["check_instance"]


# --- vocab-a: the quantities of the engine files, the kernels and the exports ----------------------------------

#: the largest finite float32 (the engines store their parameters as float32)
FLOAT32_MAX = float.fromhex("0x1.fffffep+127")
#: any number an engine file holds (NaN, an infinity or an overflow of the float32 the engines store is refused)
ENGINE_NUMBER = Quantity("number", -FLOAT32_MAX, FLOAT32_MAX, "", "a finite float32, as the engine stores it")
#: a positive finite number without a unit (a scale factor, a weight's suppression): (0, inf)
POSITIVE = Quantity("value", 0.0, math.inf, "", "a positive finite number", lo_open=True, hi_open=True)
#: a length in metres (a scene's unit): (0, inf) m
LENGTH_M = Quantity("length", 0.0, math.inf, "m", "a length", lo_open=True, hi_open=True)
#: cells per side of a tabulated kernel's grid: odd (the origin at a cell centre), at least 3
KERNEL_CELLS = Quantity("kernel grid size", 3, 100_001, "", "odd, so the origin lies at a cell centre; an n x n "
                        "grid of floats bounds n", integer=True, odd=True)

# --- vocab-c: a value's rule that no range or list of names states ------------------------------------------------


@dataclass(frozen=True)
class Rule:
    """A value's rule that no :class:`Quantity` or :class:`Choice` states (a name that must resolve to a preset or a
    file, a spec that must parse, a type): ``test(value, name, error)`` returns the value or raises ``error`` in
    this module's wordings. Declared on a settings field like a quantity (:func:`ssskit.settings.setting`), so
    the field's rule is stated once, where the settings are made."""

    name: str
    test: Callable[[Any, str, ErrorClass], Any]

    def check(self, value: object, name: str | None = None, error: ErrorClass = SsskitError) -> Any:
        return self.test(value, name or self.name, error)


__all__ += ["Rule"]


# --- vc-d: a function's argument rules declared once, at its signature ---------------------------------------------

_F = TypeVar("_F", bound=Callable[..., Any])


def checks(error: ErrorClass = SsskitError, **rules: Quantity | Choice | Flag | Rule | tuple[Any, str],
           ) -> Callable[[_F], _F]:
    """A decorator declaring a function's argument rules once, at its signature (pydantic's ``validate_call``):
    before the body runs, each argument named in ``rules`` is checked by its rule under the argument's name (a
    tuple: the rule and the name), in ``error`` and the rule's wording, and the body gets the checked value (a
    choice's canonical spelling, an int or a float). An argument whose default is None passes when None."""
    def decorate(fn: _F) -> _F:
        signature = inspect.signature(fn)

        @functools.wraps(fn)
        def checked(*args: Any, **kwargs: Any) -> Any:
            bound = signature.bind(*args, **kwargs)
            bound.apply_defaults()
            for arg, (rule, name) in ((a, r if isinstance(r, tuple) else (r, a)) for a, r in rules.items()):
                if bound.arguments[arg] is not None or signature.parameters[arg].default is not None:
                    bound.arguments[arg] = rule.check(bound.arguments[arg], name, error)
            return fn(*bound.args, **bound.kwargs)
        return cast(_F, checked)
    return decorate


def rgb(quantity: Quantity) -> Rule:
    """``quantity``'s rule for one number or three (R, G, B): :meth:`Quantity.check_rgb`, as a :func:`checks` rule."""
    return Rule(quantity.name, quantity.check_rgb)


__all__ += ["checks", "rgb"]


# --- vc-a: one value given twice, in two places that disagree ------------------------------------------------

#: the wording of one value given twice that disagrees (a kernel spec's inline tap count and --taps)
TWICE = "{first} and {second} disagree; give {what} once"


def refuse_twice(first: str, second: str, what: str, error: ErrorClass = SsskitError) -> None:
    """Raise, in the one wording, a value given twice that disagrees: ``--kernel jimenez2012:11 and --taps 7
    disagree; give the number of taps once``."""
    raise fail(error, TWICE, first=first, second=second, what=what)


__all__ += ["TWICE", "refuse_twice"]
