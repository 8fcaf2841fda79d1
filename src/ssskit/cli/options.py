"""Shared option decorators and parameter types of the ``ssskit`` commands.

Choices come from the registries (profile models, kernel methods, tap methods, depth modes,
backends, figures, signals, scenes), looked up when a value is converted or help is shown, so a
newly registered entry is accepted without editing the CLI. Ranges come from :mod:`ssskit.settings`
(``PHOTONS_RANGE``, ``SIZE_RANGE``, ``TAP_RANGE``) or from the settings classes themselves, which
validate when they are made. Every check here runs while the command line is parsed, before any
work starts; a failure is one ``ssskit: error: ...`` line (see :func:`ssskit.cli.main`).
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import stat
import tempfile
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
from click.core import ParameterSource

if TYPE_CHECKING:
    from ..kernels import KernelMethod
    from click.shell_completion import CompletionItem

from ..errors import OutputError, SettingsError, SsskitError
from ..settings import DEFAULT_PHOTONS, HEAD_ATTRIBUTION, PHOTONS_RANGE, SIZE_RANGE, TAP_RANGE

#: the profile model every command defaults to: the supplement's Monte Carlo profiles (shipped for the
#: 11 measured materials at 10^7 photons, so a preset costs nothing; another material is simulated once
#: and cached), so that ``profile``, ``kernel``, ``evaluate``, ``figures`` and ``export`` of one material
#: approximate one profile
DEFAULT_MODEL = "montecarlo"

__all__ = [
    "DEFAULT_MODEL",
    "DEFAULT_PHOTONS",
    "PHOTONS_RANGE",
    "SIZE_RANGE",
    "TAP_RANGE",
    "IntPair",
    "KernelSpec",
    "MaterialRef",
    "OutputDir",
    "OutputFile",
    "RegistryName",
    "SceneRef",
    "Size",
    "backend_option",
    "check_writable",
    "echo_json",
    "examples",
    "given",
    "named",
    "json_option",
    "kernel_spec_option",
    "material_option",
    "model_option",
    "out_dir_option",
    "out_option",
    "photons_option",
    "progress",
    "scene_option",
    "signal_option",
]


# ---------------------------------------------------------------------------------------------- helpers


def strict_json(data: Any) -> Any:
    """``data`` with every non-finite number (NaN, +-inf: a standard error of one batch, a PSNR of
    identical images) as ``null``, which strict JSON parsers accept (RFC 8259 has no NaN)."""
    import math

    if isinstance(data, float):
        return data if math.isfinite(data) else None
    if isinstance(data, dict):
        return {k: strict_json(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [strict_json(v) for v in data]
    if hasattr(data, "item") and hasattr(data, "dtype") and getattr(data, "ndim", 1) == 0:  # a numpy scalar
        return strict_json(data.item())
    return data


def echo_json(data: Any) -> None:
    """Print exactly one JSON object on stdout, strict JSON (non-finite numbers as null)."""
    click.echo(json.dumps(strict_json(data), allow_nan=False))


def progress(msg: str) -> None:
    """A progress line on stderr (stdout carries only the result)."""
    from ..progress import noted

    click.echo(f"  {msg}", err=True)
    noted(msg)


def examples(*lines: str) -> str:
    """A command's epilog: example command lines, printed verbatim under 'Examples:'."""
    return "\b\nExamples:\n" + "\n".join(f"  {line}" for line in lines)


@contextlib.contextmanager
def named(flag: str, error: type[SsskitError] = SettingsError) -> Iterator[None]:
    """An error of what option ``flag`` gave, named by it (``--c: c must lie in ...``): every option's one wording."""
    try:
        yield
    except SsskitError as exc:
        raise error(f"{flag}: {exc}") from None


def given(ctx: click.Context, name: str) -> bool:
    """Whether the user gave parameter ``name`` (on the command line or in the environment)."""
    return ctx.get_parameter_source(name) not in (None, ParameterSource.DEFAULT, ParameterSource.DEFAULT_MAP)


def check_writable(target: str | Path, opt: str, folder: bool = False) -> None:
    """Refuse an output ``target`` (a file, or a folder with ``folder=True``) that cannot be written:
    a write test in its folder or, if that does not exist yet, in the nearest existing ancestor.

    Nothing is left behind: no folder is created and the test file is removed. An empty path (which
    would mean the current folder) is refused.
    """
    if not str(target).strip():
        raise OutputError(f"{opt} is empty; give a {'folder path (. for the current folder)' if folder else 'file path'}")
    t = Path(target)
    if folder and t.exists() and not t.is_dir():
        raise OutputError(f"{opt} {str(t)!r} is a file, not a folder")
    if not folder and t.is_dir():
        raise OutputError(f"{opt} {str(t)!r} is a directory")
    probe = t if folder else t.parent
    probe = probe if str(probe) else Path(".")
    while not probe.exists() and probe.parent != probe:
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"cannot write {opt} {str(t)!r}: {str(probe)!r} is not a folder")
    try:
        fd, name = tempfile.mkstemp(prefix=".ssskit-write-test-", dir=probe)
    except OSError as exc:  # ENOENT in a folder that exists (/proc, a vanished mount) would read "no such file"
        why = "" if exc.errno == errno.ENOENT else f" ({exc.strerror or exc})"
        raise OutputError(f"cannot write {opt} {str(t)!r}: the folder {str(probe)!r} cannot be written{why}") from None
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(name)
    if not folder and t.is_file() and _immutable(t):  # the atomic write's os.replace would fail on it
        raise OutputError(f"cannot write {opt} {str(t)!r}: the existing file cannot be replaced (it is immutable: "
                          "chattr -i removes that)")


def _immutable(path: Path) -> bool:
    """Whether the file ``path`` cannot be replaced although its folder takes files: its mode lets its owner write
    (who we are, or root), yet the kernel refuses writing (Linux's immutable flag, ``chattr +i``, which root too
    obeys). A read-only mode is no reason: the atomic write (:func:`ssskit.io.atomic_output`) replaces the file by
    a rename, which a writable folder allows."""
    st = path.stat()
    mine = os.geteuid() in (0, st.st_uid) if hasattr(os, "geteuid") else False
    return bool(mine and st.st_mode & stat.S_IWUSR and not os.access(path, os.W_OK))


# ---------------------------------------------------------------------------------------------- types


class RegistryName(click.ParamType):
    """A name from a registry (or a sequence of names), matched like the registry matches it and
    returned in its canonical spelling; the choices are listed in the help."""

    name = "name"

    def __init__(self, source: Callable[[], Any]) -> None:
        self._source = source

    def names(self) -> list[str]:
        src = self._source()
        return list(src.names()) if hasattr(src, "names") else [str(n) for n in src]

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:  # click >= 8.2 passes ctx
        return "[" + "|".join(self.names()) + "]"

    def shell_complete(self, ctx: click.Context, param: click.Parameter, incomplete: str) -> list[CompletionItem]:
        from click.shell_completion import CompletionItem

        return [CompletionItem(n) for n in self.names() if n.lower().startswith(incomplete.lower())]

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        src = self._source()
        text = str(value)
        if hasattr(src, "get"):
            try:
                entry = src.get(text)
            except SsskitError as exc:
                self.fail(str(exc), param, ctx)
            return next((n for n in src.names() if src.get(n) is entry), text)
        for n in src:
            if n.lower() == text.strip().lower():
                return n
        self.fail(f"{text!r} is not one of {', '.join(map(str, src))}", param, ctx)


class MaterialRef(click.ParamType):
    """A preset material name, a .toml/.json material file or an engine file ssskit wrote (read by
    :func:`ssskit.materials.get_material`, the one material entry point), checked (loaded) while parsing.

    Returns the text as given (stripped); with ``split=True`` a comma-separated list of them.
    """

    name = "material"

    def __init__(self, split: bool = False) -> None:
        self.split = split

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return "NAME|FILE" + (",..." if self.split else "")

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        from ..export import readers  # noqa: F401  (registers the engine files as material files)
        from ..materials import get_material

        if self.split and isinstance(value, list):
            return value
        text = str(value)
        names = [n.strip() for n in text.split(",")] if self.split else [text.strip()]
        if self.split:
            names = [n for n in names if n]
            if not names:
                self.fail(f"no material given ({text!r} names none); give preset names or material files, "
                          "comma-separated", param, ctx)
        for n in names:
            try:
                get_material(n)
            except SsskitError as exc:
                self.fail(str(exc), param, ctx)
        return names if self.split else names[0]


class KernelSpec(click.ParamType):
    """A kernel method spec ``name[:value]`` (``svd:3``, ``guided:0``, ``artist:production``), parsed and
    range-checked by :func:`ssskit.kernels.parse_method_spec`; returns its canonical label.
    With ``many=True`` a comma-separated list of specs."""

    name = "method"

    def __init__(self, many: bool = False) -> None:
        self.many = many

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        from ..kernels import METHODS

        return "[" + "|".join(METHODS.names()) + "][:VALUE]" + (",..." if self.many else "")

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        from ..kernels import parse_method_spec

        if self.many and isinstance(value, list):
            return value
        specs = [s.strip() for s in str(value).split(",")] if self.many else [str(value)]
        specs = [s for s in specs if s] if self.many else specs
        if not specs:
            self.fail(f"no kernel method given ({str(value)!r})", param, ctx)
        labels = []
        seen: dict[tuple[str, str], str] = {}
        for s in specs:
            try:
                method, params, label = parse_method_spec(s)
            except SsskitError as exc:
                self.fail(str(exc), param, ctx)
            same = _canonical_spec(method, params)
            if self.many and same in seen:
                self.fail(f"{label!r} names the same kernel as {seen[same]!r}; give each method once", param, ctx)
            seen[same] = label
            labels.append(label)
        return labels if self.many else labels[0]


def _canonical_spec(method: KernelMethod, params: dict[str, Any]) -> tuple[str, str]:
    """(method, its primary parameter with the builder's default filled in): ``svd`` and ``svd:1`` are
    one kernel."""
    import inspect

    if method.primary is None:
        return method.name, ""
    value = params.get(method.primary, inspect.signature(method.builder).parameters[method.primary].default)
    return method.name, str(value).strip().lower()


class IntPair(click.ParamType):
    """Two integers written with a separator (``name`` is the metavar, ``hint`` the message's example); the
    settings fields they set check their range."""

    name = "A:B"
    sep = ":"
    hint = "8:64 (two integers)"

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return self.name

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, tuple):
            return value
        try:
            a, b = (int(v) for v in str(value).lower().split(self.sep))
        except ValueError:
            self.fail(f"must look like {self.hint}, got {value!r}", param, ctx)
        return a, b


class Size(IntPair):
    """``WxH`` in pixels (the settings' width and height check each side's range)."""

    name = "WxH"
    sep = "x"
    hint = "256x192"


class SceneRef(click.ParamType):
    """A built-in scene name (the scenes registry), a generated mesh (``bust``, ``icosphere``, ``torus``), a
    mesh file (.obj, .ply, .glb, .gltf), a scene .toml file, or a G-buffer ``.exr`` file that exists.

    Returns the canonical scene name (str) or the file as a :class:`~pathlib.Path`; a mesh or scene file
    is checked by :func:`ssskit.scenes.resolve_scene` (one error line naming what is wrong)."""

    name = "scene"

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        from ..scenes import GENERATED_SCENES

        return "[" + "|".join([*_scenes().names(), *GENERATED_SCENES]) + "|MESH|SCENE.toml|GBUFFER.exr]"

    def _regular(self, path: Path, what: str, param: click.Parameter | None, ctx: click.Context | None) -> None:
        """Fail unless ``path`` is a regular file that exists and reads (a FIFO as an input would hang:
        :func:`ssskit.io.read_input`)."""
        from ..io import read_input

        try:
            read_input(path, what, size=0)
        except SsskitError as exc:
            self.fail(str(exc), param, ctx)

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        from ..scenes import GENERATED_SCENES
        from ..scenes.meshes import FORMATS
        from ..scenes.scenefile import unknown_scene_message

        if isinstance(value, Path):
            return value
        text = str(value)
        scenes = _scenes()
        if text in scenes:
            return RegistryName(_scenes).convert(text, param, ctx)
        if text.strip().lower() in GENERATED_SCENES:
            return text.strip().lower()
        p = Path(text)
        if p.suffix.lower() in FORMATS or p.suffix.lower() == ".toml":
            if p.exists():  # a FIFO or device would hang the reader: refused here (what is missing: later)
                self._regular(p, "scene file", param, ctx)
            return p
        if p.suffix or p.exists() or len(p.parts) > 1:
            if p.suffix.lower() != ".exr" and not p.is_dir():
                return p  # a format --scene does not take: resolve_scene's rule (scenes.SCENE_FORMAT), before any work
            self._regular(p, "G-buffer file", param, ctx)
            return p
        try:
            return scenes.get(text).name  # the registry's matching (case, '-' for '_')
        except SsskitError:
            self.fail(unknown_scene_message(text), param, ctx)


def scene_mesh_options(view: bool = True) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``--units``, ``--material-map`` and (``view``) ``--view``: how a mesh or scene file is read and seen
    (:func:`ssskit.scenes.resolve_scene`)."""
    from ..scenes.meshes import UNITS_MM

    def deco(fn: Callable[..., Any]) -> Callable[..., Any]:
        if view:
            fn = click.option("--view", default=None, metavar="front|profile|ear|close|AZ,EL[,DIST]",
                              help="Mesh scenes: a view preset, or azimuth,elevation (degrees) and the distance as a "
                                   "multiple of the automatic framing's [default: the scene's, else front].")(fn)
        fn = click.option("--material-map", "material_map", default=None, metavar="NAME=MATERIAL,...",
                          help="Mesh scenes: a material per object (OBJ/PLY: the file's stem; glTF: its material "
                               "names); the others take --material.")(fn)
        return click.option("--units", type=click.Choice(list(UNITS_MM), case_sensitive=False), multiple=True,
                            help="Mesh scenes: the length unit of the mesh files [default: mm for OBJ and PLY, m "
                                 "for glTF; said on stderr with the model's size].")(fn)

    return deco


def resolve_scene_value(scene: Any, units: Sequence[str] = (), material_map: str | None = None,
                        view: str | None = None, width: int = 256, height: int = 192, say: bool = True) -> Any:
    """The ``--scene`` value resolved (:func:`ssskit.scenes.resolve_scene`) and checked before any work; with
    ``say``, what it assumed (units, the model's size) goes to stderr (:func:`say_notes`)."""
    from ..scenes import resolve_scene

    resolved = resolve_scene(scene, units=list(units) or None, material_map=material_map, view=view, width=width,
                             height=height)
    if say:
        say_notes(resolved.notes)
    return resolved


def say_notes(notes: Iterable[str]) -> None:
    """What resolving a scene assumed, one ``ssskit: ...`` line each on stderr."""
    for note in notes:
        click.echo(f"ssskit: {note}", err=True)


def _opt(param: click.Parameter | None, fallback: str) -> str:
    return param.opts[0] if param is not None and getattr(param, "opts", None) else fallback


class OutputFile(click.ParamType):
    """An output file path: its suffix one of ``suffixes``, not a directory, its folder writable
    (tested without leaving anything behind). Errors are OutputErrors naming the option."""

    name = "file"

    def __init__(self, suffixes: Sequence[str]) -> None:
        self.suffixes = tuple(s.lower() for s in suffixes)

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return "FILE" + "|".join(self.suffixes)

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        from ..io import check_suffix

        opt = _opt(param, "output")
        check_suffix(value, self.suffixes, opt)
        check_writable(value, opt)
        return str(value)


class OutputDir(click.ParamType):
    """An output folder: not a file, and writable (tested without creating anything)."""

    name = "dir"

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return "DIR"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        check_writable(value, _opt(param, "output folder"), folder=True)
        return str(value)


class SettingOption(click.Option):
    """A click option generated from declared settings fields (:func:`ssskit.settings.setting`), not declared a
    second time: its name (``--field`` with ``-`` for ``_``, unless given), type (an integer, a number, one
    number or three for an RGB field, a choice among the quantity's names, a flag), default (the field's) and
    the range in its help (the quantity's interval and unit), after ``help`` (default: the quantity's reason).
    The value is checked once, by the settings class when it is made (the option named in the error:
    :mod:`ssskit.cli.render_options`); :meth:`changes` gives the fields it sets.

    ``setting=(cls, field)``, or ``(cls, (field, ...))`` for one option setting several fields (with an explicit
    ``type`` whose value is a tuple); ``invert=True``: a ``--no-x`` flag that sets the boolean field to False;
    ``convert``: the fields' values from the option's (e.g. sigma0 -> sigma0^2)."""

    def __init__(self, param_decls: Sequence[str], *, setting: tuple[type, Any], invert: bool = False,
                 convert: Callable[[Any], tuple[Any, ...]] | None = None, **attrs: Any) -> None:
        import dataclasses

        from ..quantities import Choice, Flag, Quantity

        cls, names = setting
        self.settings_class: type = cls
        self.fields: tuple[str, ...] = (names,) if isinstance(names, str) else tuple(names)
        self.invert, self.convert = invert, convert
        declared = {f.name: f for f in dataclasses.fields(cls)}
        f = declared[self.fields[0]]
        q = f.metadata.get("quantity")
        default: Any = tuple(getattr(cls(), n) for n in self.fields) if len(self.fields) > 1 else \
            (f.default_factory() if f.default_factory is not dataclasses.MISSING else f.default)
        help_ = attrs.pop("help", None) or getattr(q, "reason", "")
        if invert or isinstance(q, Flag):
            attrs.setdefault("is_flag", True)
            attrs.setdefault("default", False if invert else default)
        else:
            if isinstance(q, Choice):
                choices = q.choices
                attrs.setdefault("type", RegistryName(choices) if callable(choices) else
                                 click.Choice(list(choices), case_sensitive=False))
            elif isinstance(q, Quantity):
                if f.metadata.get("rgb"):
                    attrs.setdefault("type", RGBFloats())
                attrs.setdefault("type", click.INT if q.integer else click.FLOAT)
                if len(self.fields) == 1 and convert is None:  # the range, stated once: the quantity's
                    help_ = f"{help_} ({'odd, ' if q.odd else ''}in {q.interval}{' ' + q.unit if q.unit else ''})."
            if len(self.fields) > 1:  # written as the option's type writes it (8:64, 256x192)
                default = getattr(attrs.get("type"), "sep", ",").join(str(v) for v in default)
            attrs.setdefault("default", default)
            attrs.setdefault("show_default", default is not None)
        decls = list(param_decls) or [f"--{self.fields[0].replace('_', '-')}"]
        super().__init__(decls, help=help_, **attrs)

    def changes(self, value: Any) -> dict[str, Any]:
        """The settings fields this option sets from its ``value`` (``{field: value}``)."""
        if self.invert:
            return {self.fields[0]: not value}
        values = self.convert(value) if self.convert is not None else (
            tuple(value) if len(self.fields) > 1 else (value,))
        return dict(zip(self.fields, values))


def setting_option(cls: type, field: Any, *decls: str, **attrs: Any) -> Callable[[Callable[..., Any]], Any]:
    """The :class:`SettingOption` of ``cls``'s declared ``field`` (or fields), as a decorator."""
    return click.option(*decls, cls=SettingOption, setting=(cls, field), **attrs)


class RGBFloats(click.ParamType):
    """One number or three comma-separated numbers (R,G,B)."""

    name = "V[,V,V]"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, tuple):
            return value
        try:
            vals = tuple(float(v) for v in str(value).split(","))
        except ValueError:
            self.fail(f"{value!r} is not a number or three comma-separated numbers", param, ctx)
        if len(vals) not in (1, 3):
            self.fail(f"{value!r}: give one number or three (R,G,B)", param, ctx)
        return vals if len(vals) == 3 else vals * 3


# ------------------------------------------------------------------------------------------ registries


def _models():
    from ..profiles import MODELS

    return MODELS


def _scenes():
    from ..scenes import SCENES

    return SCENES


def _signals():
    from ..scenes import SIGNALS

    return SIGNALS


def _backends():
    from ..backends import BACKENDS

    return BACKENDS


def _depth_modes():
    from ..backends import DEPTH_MODES

    return DEPTH_MODES


def _tap_methods():
    from ..sampling.taps import TAP_METHODS

    return TAP_METHODS


def _figures():
    from ..figures import FIGURES

    return FIGURES


#: the help of every --depth-mode (render's and export's, generated from their settings)
DEPTH_MODE_HELP = "Depth test [default: gaussian for artist kernels, follow otherwise]."
MODEL = RegistryName(_models)
SIGNAL = RegistryName(_signals)
BACKEND = RegistryName(_backends)
DEPTH_MODE = RegistryName(_depth_modes)
TAP_METHOD = RegistryName(_tap_methods)
FIGURE = RegistryName(_figures)


# ------------------------------------------------------------------------------------------ decorators


def json_option(help: str = "Print one JSON object.") -> Callable:
    return click.option("--json", "as_json", is_flag=True, help=help)


def material_option(*, required: bool = False, default: str | None = None, split: bool = False,
                    help: str = "Preset name or .toml/.json material file.") -> Callable:
    return click.option("--material", type=MaterialRef(split=split), required=required, default=default,
                        show_default=default is not None, multiple=split, help=help)


def model_option(default: str | None, help: str = "Profile model.") -> Callable:
    return click.option("--model", type=MODEL, default=default, show_default=True, help=help)


def photons_option(default: int | None, help: str = "Monte Carlo photons per channel (cached).") -> Callable:
    return click.option("--photons", type=click.IntRange(*PHOTONS_RANGE), default=default,
                        show_default=default is not None, help=help)


def out_option(suffixes: Iterable[str], help: str, name: str = "--out", dest: str | None = None) -> Callable:
    decls = [name] if dest is None else [name, dest]
    return click.option(*decls, type=OutputFile(tuple(suffixes)), default=None, help=help)


def out_dir_option(default: str, help: str = "Output folder.") -> Callable:
    return click.option("--out", type=OutputDir(), default=default, show_default=True, help=help)


def kernel_spec_option(name: str = "--kernel", dest: str = "kernel_spec", default: str | None = None,
                       many: bool = False, required: bool = False,
                       help: str = "Kernel method spec name[:value].") -> Callable:
    # no default given: none passed, so that click (>= 8.3, whose sentinel for "not given" is not None) still
    # reports a required option as missing
    if default is None:
        return click.option(name, dest, type=KernelSpec(many=many), required=required, help=help)
    return click.option(name, dest, type=KernelSpec(many=many), default=default, show_default=True,
                        required=required, help=help)


def signal_option(default: str = "edge") -> Callable:
    return click.option("--signal", type=SIGNAL, default=default, show_default=True, help="Test signal.")


def scene_option() -> Callable:
    return click.option("--scene", type=SceneRef(), required=True,
                        help="Built-in scene, generated mesh (bust, icosphere, torus), mesh file (.obj, .ply, .glb, "
                             ".gltf), scene .toml, or a G-buffer EXR (its layers: docs/commands.md, 'A G-buffer EXR'). "
                             "The built-in head (--view front, ear or close; 259 mm per unit, docs/head.md): "
                             f"{HEAD_ATTRIBUTION}.")


def backend_option(default: str | None) -> Callable:
    return click.option("--backend", type=BACKEND, default=default, show_default=default is not None,
                        help="Who runs the screen-space pass ('ssskit backends' lists them and whether they run here).")


def option_name(ctx: click.Context, name: str) -> str:
    """How the user spells the option of click parameter ``name`` (``n_gaussians`` -> ``--gaussians``)."""
    return next((p.opts[0] for p in ctx.command.params if p.name == name and p.opts), name)
