"""Engine files read back into a material: the JSON files of ``ssskit export --format unreal|unity|blender``,
the Blender and Unreal editor scripts (``.py``: their parameter literal, read with Python's ``ast``, never run),
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
Every number a reader takes must be finite and fit the float32 the engines store it in: NaN, an infinity or
an overflow is refused in one line naming the file and the field (never replaced, never a warning).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import SsskitError
from ..io import parse_document, read_input
from ..materials import Material, homogeneous
from ..quantities import BURLEY_ALBEDO, ENGINE_NUMBER, LENGTH_MM, Choice, check_keys, refuse_twice, refuse_unused
from .registry import FORMATS

#: suffixes that hold an engine file (a .json one only when it has an "engine" key, a .py one only when it is an
#: editor script ssskit wrote)
ENGINE_SUFFIXES = (".json", ".asset", ".mtlx", ".py")
#: the parameter literal of each editor script ssskit writes (ssskit.export.blender / .unreal)
SCRIPT_LITERALS = {"blender": "PARAMS", "unreal": "SETTINGS"}
ENGINE_NAMES = ("unreal", "unity", "blender")
#: the "engine" of a JSON export, checked once (case-insensitive): ssskit's own that write JSON, or a format registered
#: beside them with its own reader (ssskit's MaterialX is read from its .mtlx only: read_engine_file reads those itself)
JSON_ENGINE = Choice("engine", lambda: [*ENGINE_NAMES, *(n for n, f in FORMATS.items() if f.read is not None
                                                        and n not in (*ENGINE_NAMES, "materialx"))])
#: the models an engine file's or artists' terms' Burley parameters go through (module docstring)
INVERSIONS = Choice("--model of an engine file or artists' terms", ("burley", "montecarlo", "dipole"))


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
    #: the volume mean free path 1 / sigma_t (3,) mm where the file states it (MaterialX's OpenPBR radius)
    mfp_mm: np.ndarray | None = None
    g: float = 0.0

    def profile(self) -> Any:
        from ..profiles import BurleyProfile, RGBProfile

        c = [BurleyProfile(float(a), float(d)) for a, d in zip(self.albedo, self.d_mm)]
        return RGBProfile((c[0], c[1], c[2]), "burley", self.name, {"engine": self.engine})

    def material(self) -> Material:
        """The physical material of the Monte Carlo inversion (module docstring): from the file's mean free path
        1 / sigma_t where it states one (MaterialX), else from its diffuse mean free path; the file's index where
        it holds one of at least 1 (else the artists' default 1.3)."""
        from ..profiles.artist import ArtistMaterial, material_from_artist

        kind, dist = (("mfp", self.mfp_mm) if self.mfp_mm is not None
                      else ("dmfp", self.d_mm * (3.5 + 100.0 * (self.albedo - 0.33) ** 4)))
        eta = self.eta if self.eta is not None and self.eta >= 1.0 else 1.3
        a_r, a_g, a_b = (float(v) for v in self.albedo)
        d_r, d_g, d_b = (float(v) for v in dist)
        art = ArtistMaterial(self.name, (a_r, a_g, a_b), (d_r, d_g, d_b), kind, eta, self.g)
        return material_from_artist(art)


def is_engine_file(path: str | Path) -> bool:
    """Whether ``path`` names an engine file (an .asset or .mtlx, a .json with an "engine" key, or a .py editor
    script ssskit wrote)."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix in (".asset", ".mtlx") or _format_reader(suffix) is not None:
        return True
    if suffix not in (".json", ".py") or not p.is_file():
        return False
    try:
        text = p.read_text(encoding="utf-8")
        if suffix == ".py":
            return _script_engine(text) is not None
        data = parse_document(text, ".json")
    except (OSError, UnicodeDecodeError, ValueError):
        return False
    return isinstance(data, dict) and "engine" in data


def _format_reader(suffix: str) -> Any:
    """The reader of a format registered beside ssskit's own whose file has this (own) suffix, else None."""
    if suffix in ENGINE_SUFFIXES:
        return None
    return next((f.read for _, f in FORMATS.items() if f.read is not None and suffix in f.suffixes), None)


def _script_engine(text: str) -> str | None:
    """The engine of an editor script ssskit wrote (its docstring's first line), else None."""
    for engine, head in (("blender", '"""ssskit export for Blender'), ("unreal", '"""ssskit export for Unreal Engine')):
        if text.startswith(head):
            return engine
    return None


def _script_literal(p: Path, text: str, engine: str) -> dict[str, Any]:
    """The parameter literal of an editor script (``PARAMS`` / ``SETTINGS``), read with ``ast`` (never run)."""
    import ast

    name = SCRIPT_LITERALS[engine]
    try:
        tree = ast.parse(text)
    except (SyntaxError, ValueError) as exc:
        raise SsskitError(f"{str(p)!r} is not a readable {engine} script (truncated?): {exc}") from None
    values: dict[str, Any] = {}
    for node in tree.body:
        if isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name):
            try:
                values[node.targets[0].id] = ast.literal_eval(node.value)
            except ValueError:
                continue
    out = dict(check_keys(values.get(name), f"{str(p)!r}: the {name} literal of the {engine} parameters (truncated?)"))
    if engine == "unreal":  # the script holds the mfp block and its asset name
        return {"engine": "unreal", "mfp": out, "base_color": out.get("SurfaceAlbedo"), "IOR": out.get("IOR"),
                "source_profile": {"name": str(values.get("NAME", p.stem))}}
    return {"engine": "blender", **out, "source_profile": {"name": str(out.get("name", p.stem))}}


def _numbers(value: Any, field: str = "") -> Any:
    """(field, number) for every number under ``value`` (nested dicts and lists), the field as ``a.b[2]``."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield from _numbers(v, f"{field}.{k}" if field else str(k))
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            yield from _numbers(v, f"{field}[{i}]")
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        yield field, value


def check_numbers(path: str | Path, value: Any, field: str) -> None:
    """Every number under ``value`` (nested lists and dicts) a finite float32 (:data:`ENGINE_NUMBER`), else one
    :class:`SsskitError` naming the file and the field (module docstring)."""
    for name, v in _numbers(value, field):
        ENGINE_NUMBER.check(v, f"{str(path)!r}: {name}")


def read_engine_file(path: str | Path, albedo: Any = None) -> EngineSource:
    """An :class:`EngineSource` from an engine file. ``albedo`` (3,): the surface albedo for a Unity .asset,
    whose profile holds none (HDRP takes it from the material)."""
    from .engines import reimport

    p = Path(path)
    read_input(p, "engine file", SsskitError, size=0)  # a regular file that exists and reads
    suffix = p.suffix.lower()
    reader = _format_reader(suffix)
    if reader is not None:
        return reader(p)
    if suffix == ".asset":
        engine = "unity"
    elif suffix == ".mtlx":
        engine = "materialx"
    elif suffix == ".py":
        text = read_input(p, "engine file (a Python script)", SsskitError, text=True)
        script = _script_engine(text)
        if script is None:
            raise SsskitError(f"{str(p)!r} is not an editor script ssskit wrote (a Blender or Unreal export)")
        engine = script
        data = _script_literal(p, text, engine)
    else:
        text = read_input(p, "engine file", SsskitError, text=True)
        try:
            data = parse_document(text, ".json")
        except ValueError as exc:
            raise SsskitError(f"malformed engine file {str(p)!r}: {exc}") from None
        engine = JSON_ENGINE.check(data.get("engine") if isinstance(data, dict) else None,
                                   f"{str(p)!r}: the engine of an export")
        other = FORMATS.get(engine).read if engine not in ENGINE_NAMES else None
        if other is not None:
            return other(p)  # a format registered beside ssskit's own reads its JSON export
    if engine == "unity" and suffix == ".asset":
        from .unity import read_unity_asset

        u = read_unity_asset(read_input(p, "engine file (a YAML .asset)", SsskitError, text=True), repr(str(p)))
        check_numbers(p, {k: u[k] for k in ("scatteringDistance", "scatteringDistanceMultiplier", "worldScale", "ior")}, "")
        if u["worldScale"] != 1.0:
            raise SsskitError(f"{str(p)!r}: worldScale {u['worldScale']}: ssskit reads profiles at HDRP's worldScale 1 "
                              "(scattering distances in mm) only")
        d = np.array(u["scatteringDistance"]) * u["scatteringDistanceMultiplier"]
        if albedo is None:  # (so an .asset is no material by itself: every command but export refuses it here)
            raise SsskitError(f"{str(p)!r}: a DiffusionProfileSettings asset holds no albedo (HDRP takes it from the "
                              "material's base colour): read ssskit's JSON export of the profile (--format unity --out "
                              f"X.json), or give the albedo: ssskit export --material {p} --albedo R,G,B ...")
        # Burley's domain (module docstring: HDRP's reader has no cited clamp ssskit could apply): A in (0, 1], d > 0
        BURLEY_ALBEDO.check_array(np.asarray(albedo, dtype=float).reshape(-1)[:3], f"{str(p)!r}: the unity albedo",
                                  SsskitError, "channels")
        LENGTH_MM.check_array(d, f"{str(p)!r}: Burley's d", SsskitError, "channels")
        return EngineSource("unity", u["name"], np.asarray(albedo, dtype=float), d, u["ior"])
    if engine == "materialx":
        from .materialx import read_materialx

        m = read_materialx(p)
        return EngineSource("materialx", str(m["name"]), m["albedo"], m["d_mm"], m["eta"], mfp_mm=m["mfp_mm"],
                            g=m["g"])
    check_numbers(p, {k: v for k, v in data.items() if k not in ("sources", "lost")}, "")
    clamps: tuple[str, ...] = ()
    try:
        if engine == "unreal":
            clamps = _unreal_clamps(data["mfp"])
        prof = reimport({**data, "engine": engine}, "burley")  # (its BurleyProfiles refuse an A or d outside
        # Burley's domain; the engine in its canonical spelling)
    except SsskitError as exc:  # (a ValueError too): a value the file has is out of its domain, not missing
        if str(p) in str(exc):
            raise
        raise SsskitError(f"{str(p)!r}: {exc}") from None
    except (KeyError, TypeError, ValueError) as exc:
        raise SsskitError(f"{str(p)!r} lacks the {engine} parameters ssskit writes ({exc})") from None
    from ..profiles.burley import BurleyProfile

    chans = [ch for ch in prof.channels if isinstance(ch, BurleyProfile)]  # reimport gives Burley channels, each
    a = np.array([ch.albedo for ch in chans])  # in Burley's domain (BurleyProfile checks A and d when made)
    d = np.array([ch.d for ch in chans])
    eta = data.get("IOR", data.get("ior"))
    name = str(data.get("source_profile", {}).get("name", p.stem)) if isinstance(data.get("source_profile"), dict) \
        else p.stem
    return EngineSource(engine, name, a, d, float(eta) if isinstance(eta, (int, float)) else None, clamps)


def _unreal_clamps(block: dict[str, Any]) -> tuple[str, ...]:
    """The clamps UE applies reading a Burley block (module docstring), as the export words them."""
    from .unreal import COLOR_BIAS

    out = []
    for field, hi in (("SurfaceAlbedo", 1.0), ("MeanFreePathColor", None)):
        v = np.array(ENGINE_NUMBER.check_rgb(block[field], field), dtype=np.float32).astype(float)
        for c in range(3):
            eng = min(max(v[c], COLOR_BIAS), hi) if hi is not None else max(v[c], COLOR_BIAS)
            if eng != v[c]:
                rng = f"[{COLOR_BIAS:g}, {hi:g}]" if hi is not None else f">= {COLOR_BIAS:g}"
                out.append(f"{field}[{'RGB'[c]}] {v[c]:.4g} -> {eng:.4g} (UE clamps to {rng})")
    return tuple(out)


# ------------------------------------------------------------------------------------- the one entry point


@dataclass
class Source:
    """The material of an export request, checked: ``profile()`` computes its profile (None: a kernel that reads
    none), ``material`` the physical material where there is one, ``name``, the ``model`` used, the ``eta`` to
    write where no material gives it, and ``notes`` (the engine clamps that fired reading an engine file)."""

    profile: Any
    material: Any
    name: str | None
    model: str | None
    eta: float | None = None
    notes: list[str] = dataclasses.field(default_factory=list)
    kernel: Any = None  # (method, params, tap count) of a kernel format
    #: the physical material of the Monte Carlo inversion, for a Burley-only source (None: ``material`` is it)
    physical: Any = None


def engine_material(path: str | Path) -> Material:
    """The physical material of an engine file ssskit wrote (the Monte Carlo inversion,
    :meth:`EngineSource.material`): the reader :func:`ssskit.materials.get_material` uses for engine files (it is
    registered in :data:`ssskit.materials.MATERIAL_READERS` when this module is imported)."""
    return read_engine_file(path).material()  # (an .asset alone is refused there: it holds no albedo)


def _register() -> None:
    from ..materials import MATERIAL_READERS

    if "engine files" not in MATERIAL_READERS:
        MATERIAL_READERS.register("engine files", (is_engine_file, engine_material))


_register()


def model_parameters(model: str) -> set[str]:
    """The named keyword parameters of a profile model's factory (from the MODELS registry): the options it takes
    (here and in the CLI's :func:`ssskit.cli.profiles.resolve_profile`)."""
    import inspect

    from ..profiles import MODELS

    sig = inspect.signature(MODELS.get(model))
    return {n for n, p in list(sig.parameters.items())[1:] if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}


def _physical(req: Any, mat: Any, model: str) -> Any:
    """The profile factory of a physical material under ``model``, passing the options it takes (refusing the
    others) after its domain check."""
    from ..profiles import MATERIAL_FREE_MODELS, check_model_domain, profile_for_material

    takes = model_parameters(model)
    refuse_given(req, tuple(n for n in ("photons", "grid_fraction") if n not in takes), f"--model {model}")
    kwargs = {n: getattr(req, n) for n in ("photons", "grid_fraction") if getattr(req, n) is not None}
    free = model.lower() in MATERIAL_FREE_MODELS
    if not free:
        check_model_domain(mat, model)
    return lambda: profile_for_material(None if free else mat, model, **kwargs)


def refuse_given(req: Any, names: tuple[str, ...], what: str) -> None:
    """The unused-option rule of an export request, stated once: the first of ``names`` the user gave (its
    option ``--name``) does not apply to ``what``."""
    given = [n for n in names if req.given(n)]
    if given:
        raise SsskitError(f"--{given[0].replace('_', '-')} does not apply to {what}")


def _need(have: bool, what: str, option: str) -> None:
    """What a request's ``what`` needs (``option``: the material, the kernel), in one wording for every format."""
    if not have:
        raise SsskitError(f"{what} needs {option}")


def _need_material(req: Any, artist: bool, what: str) -> None:
    """The material a request's ``what`` needs: --material or artists' terms."""
    _need(req.material is not None or artist, what, "--material (or artists' terms: --albedo with --mfp or --dmfp)")


def _artist(req: Any) -> Any:
    """The request's artists' terms (--albedo with one of --mfp or --dmfp; --eta 1.3 and --g 0 by default) as an
    :class:`~ssskit.profiles.artist.ArtistMaterial`, which checks their domain."""
    from ..profiles.artist import ArtistMaterial

    if req.albedo is None or (req.mfp is None) == (req.dmfp is None):
        raise SsskitError("artists' terms need --albedo and one of --mfp (volume mean free path, mm) or --dmfp "
                          "(diffuse mean free path, mm)")
    kind, dist = ("mfp", req.mfp) if req.mfp is not None else ("dmfp", req.dmfp)
    return ArtistMaterial("artist", req.albedo, dist, kind, 1.3 if req.eta is None else req.eta,
                          0.0 if req.g is None else req.g)


def material_source(req: Any, needs: str) -> Source:
    """Every material check of an export request (:class:`ssskit.export.ExportSettings`), before any work.

    An engine file or artists' terms default to the Burley-fit inversion (``model`` burley, no coefficients);
    montecarlo / dipole invert them to a physical material first (:mod:`ssskit.profiles.artist`). A kernel
    format (``needs`` "kernel" or "shader") checks its kernel here too (:func:`_kernel_checks`)."""
    from ..profiles.artist import burley_from_artist, check_artist, material_from_artist

    material, albedo = req.material, req.albedo
    artist = albedo is not None or req.mfp is not None or req.dmfp is not None
    engine_file = material is not None and is_engine_file(material)
    if not artist:
        refuse_given(req, ("eta", "g"), "a material without artists' terms (--albedo with --mfp or --dmfp)")
    if artist and material is not None and not (engine_file and str(material).lower().endswith(".asset")):
        raise SsskitError("give the material once: --material or artists' terms (--albedo with --mfp or --dmfp)")
    if engine_file:  # an HDRP .asset takes --albedo only: the file holds the distances and the index
        refuse_given(req, ("mfp", "dmfp", "eta", "g"), f"an engine file ({material}), which holds its own parameters "
                     "(an HDRP .asset takes only --albedo)")
    if req.shader_pass in ("burley", "transmission"):
        return _pass_source(req, engine_file, artist)
    kernel = _kernel_checks(req, material is not None or artist) if needs != "engine" else None
    if needs == "engine":
        _need_material(req, artist, f"--format {req.format}")
    model = req.model
    if engine_file or artist:  # burley: the Burley-fit inversion; montecarlo / dipole: the Monte Carlo inversion
        used = INVERSIONS.check("burley" if model is None else model)
        if used == "burley":
            refuse_given(req, ("photons", "grid_fraction"), "--model burley (the Burley fit simulates nothing)")
    if engine_file:
        src = read_engine_file(material, albedo=albedo)
        if albedo is not None:
            check_artist(albedo, src.d_mm, "dmfp", 1.0, 0.0)
        notes = [f"{material}: read as {src.engine} reads it: {c}" for c in src.clamps]
        if used == "burley":
            return Source(src.profile, None, src.name, used, src.eta, notes, kernel, src.material)
        mat = src.material()
        return Source(_physical(req, mat, used), mat, src.name, used, None, notes, kernel)
    if artist:
        art = _artist(req)  # checks the domain
        kind, eta = art.kind, art.eta
        if used == "burley":
            from ..profiles import BurleyProfile, RGBProfile

            a, d = burley_from_artist(art)
            chans = [BurleyProfile(float(x), float(y)) for x, y in zip(a, d)]
            prof = RGBProfile((chans[0], chans[1], chans[2]), "burley", "artist", {"inversion": f"Burley fit ({kind})"})
            return Source(lambda: prof, None, "artist", used, eta, [], kernel, lambda: material_from_artist(art))
        mat = material_from_artist(art)
        return Source(_physical(req, mat, used), mat, "artist", used, None, [], kernel)
    return _named_source(req, kernel)


def _named_source(req: Any, kernel: Any) -> Source:
    """A preset or material file (or none, for a kernel that reads no profile)."""
    from ..materials import get_material
    from ..profiles import MATERIAL_FREE_MODELS, refuse_material

    from ..kernels import refuse_profile_options

    model = req.model or "montecarlo"
    m = kernel[0] if kernel is not None else None
    if m is not None:  # as `ssskit kernel` refuses them (the header named an unused material)
        refuse_profile_options(m, [f"--{n.replace('_', '-')}" for n in ("material", "albedo", "model", "photons",
                                                                       "grid_fraction") if req.given(n)],
                               req.material is not None, "--kernel")
        if req.material is None and not m.needs_profile:
            return Source(None, None, None, None, None, [], kernel)
    if model.lower() in MATERIAL_FREE_MODELS:
        refuse_material(model, req.material, f"--model {model}", "--material", SsskitError)
        return Source(_physical(req, None, model), None, None, model, None, [], kernel)
    _need_material(req, False, f"--format {req.format}" if m is None else f"--kernel {m.name}")
    mat = get_material(req.material)
    return Source(_physical(req, mat, model), mat, None, model, None, [], kernel)


def _kernel_checks(req: Any, have_material: bool) -> tuple[Any, dict[str, Any], int | None]:
    """A kernel format's checks: (method, params, tap count for make_taps)."""
    from ..kernels import parse_method_spec

    fmt = req.format
    _need(req.kernel is not None, f"--format {fmt}", "--kernel")
    m, params, _ = parse_method_spec(req.kernel)
    tap_kernel = m.primary == "taps"  # an engine tap kernel (jimenez2012): built with its taps
    tap_count = None
    taps = req.taps
    if taps is not None:
        if tap_kernel:
            if params.get("taps", taps) != taps:
                refuse_twice(f"--kernel {req.kernel}", f"--taps {taps}", "the number of taps")
            params["taps"] = taps
        else:
            tap_count = taps
    if fmt in ("bn", "json") and not tap_kernel:
        refuse_given(req, ("taps",), f"--format {fmt} (it writes the tabulated kernel itself)")
    if tap_kernel:  # (bn and json take no --tap-method: their Format.options)
        refuse_given(req, ("tap_method",), f"the {m.name} kernel, which ships its own taps")
    if fmt == "bn":
        from .bn import refuse_unfit

        refuse_unfit(f"--kernel {req.kernel}", tap_kernel, int(params.get("rank", 1)))
    return m, params, tap_count


def _pass_source(req: Any, engine_file: bool, artist: bool) -> Source:
    """``shader_pass`` burley or transmission: the one homogeneous medium whose numbers the pass's shader bakes in
    (the Burley parameters, :func:`ssskit.screenspace.burley.burley_params_for_material`; the transmittance model),
    from a preset, a material file, or artists' terms (inverted by Monte Carlo: always for the Burley pass, with
    ``--model montecarlo`` for the transmittance pass, which so also reads an engine file) -- except transmission's
    jimenez2010, which takes no material. (Options a pass does not take: ExportSettings.unused, PASS_OPTIONS.)"""
    burley = req.shader_pass == "burley"
    what = "--pass burley" if burley else f"--transmission-model {req.transmission_model or 'mcml'}"
    if req.model is not None and req.model.lower() != "montecarlo":  # the shader bakes the material's transmittance
        # model from its MCML transport (artists' terms: --model montecarlo, the Monte Carlo inversion)
        refuse_unused([f"--model {req.model}"], "--pass", ("separable",), "transmission, which takes --model "
                      "montecarlo only (the Monte Carlo inversion of artists' terms)")
    if what == "--transmission-model jimenez2010":  # (it takes no material: ExportSettings.unused, PASS_OPTIONS)
        return Source(None, None, None, None)
    _need_material(req, artist, what)
    mat: Any = None
    if artist and (burley or req.model is not None):
        from ..profiles.artist import material_from_artist

        mat = material_from_artist(_artist(req))
    elif engine_file:  # (the Burley pass takes no --model: an engine file gives it no medium)
        mat = read_engine_file(req.material).material() if req.model is not None else None
    elif not artist:
        from ..materials import get_material

        mat = get_material(req.material)
    mat = homogeneous(mat, f"{what} (a preset, a material file, or artists' terms"
                      f"{')' if burley else ' with --model montecarlo)'}")
    return Source(None, mat, mat.name, None)


__all__ = ["ENGINE_NAMES", "ENGINE_SUFFIXES", "EngineSource", "Source", "check_numbers", "is_engine_file",
           "engine_material", "material_source", "model_parameters", "read_engine_file"]
