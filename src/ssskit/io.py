"""File input and output in one place: atomic writes, profile tables, images and OpenEXR files.

Every writer goes through :func:`atomic_output`: data lands in a temporary file beside the target
and is renamed over it only when complete, so an interrupted or failed run never leaves a
half-written file; the file gets the mode ``0o666 & ~umask``, as ``open`` would give it.

OpenEXR files are read and written with the official OpenEXR Python bindings (imageio writes TIFF
bytes into ``.exr`` files). Their C library reports some errors on stderr by itself and the
bindings print warnings on stdout; :func:`read_exr` and :func:`write_exr` capture both and turn
every failure into one :class:`~ssskit.errors.GBufferError` / :class:`~ssskit.errors.OutputError`
line naming the file.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import sys
import tempfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import GBufferError, OutputError

#: the first four bytes of every OpenEXR file
EXR_MAGIC = b"\x76\x2f\x31\x01"
_EXR_MULTIPART = 0x1000  # version-field flag: a multi-part file
_EXR_DEEP = 0x800  # version-field flag: deep (non-image) data


# ---- atomic writes ---------------------------------------------------------------------------------

def _umask() -> int:
    """The process umask (from /proc where it can be read without changing it)."""
    with contextlib.suppress(OSError, ValueError):
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def _failing(doing: str, error: type[Exception] = OutputError) -> Iterator[None]:
    """An OSError inside (a full disk, a file size limit, a rename, a folder that cannot be made, a read that
    fails) as one ``error``: ``{doing}: {why}``, ``doing`` naming the file, e.g. ``cannot write 'out.exr'``."""
    try:
        yield
    except OSError as exc:
        raise error(f"{doing}: {exc.strerror or exc}") from None


def _writing(path: str | Path) -> contextlib.AbstractContextManager[None]:
    """:func:`_failing` for the file or folder ``path`` being written."""
    return _failing(f"cannot write {str(path)!r}")


@contextlib.contextmanager
def atomic_output(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path with the same suffix beside ``path``; rename it over ``path`` on success.

    The file is made readable as the user's umask says (``mkstemp`` alone would leave it 0600).
    """
    target = Path(path)
    parent = target.parent if str(target.parent) else Path(".")
    if target.is_dir():
        raise OutputError(f"cannot write {str(target)!r}: it is a directory")
    try:
        parent.mkdir(parents=True, exist_ok=True)
        # the temporary name begins with the target's, cut to 100 bytes: a target name near the file system's
        # 255 bytes is still written
        head = target.name.encode()[:100].decode("utf-8", "ignore")
        fd, tmp_name = tempfile.mkstemp(prefix=f".{head}.", suffix=f".tmp{target.suffix[:20]}", dir=parent)
    except OSError as exc:
        why = exc.strerror
        existing = next((a for a in (parent, *parent.parents) if a.exists()), None)
        if existing is not None and not existing.is_dir():
            why = f"{str(existing)!r} is not a directory"
        raise OutputError(f"cannot write {str(target)!r}: {why}") from None
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        with _writing(target):  # the write itself (a full disk, a file size limit) or the rename: name the target
            yield tmp
            os.chmod(tmp, 0o666 & ~_umask())
            os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


@contextlib.contextmanager
def staged_folder(out: str | Path) -> Iterator[Path]:
    """Build a folder of outputs in a hidden staging folder beside ``out`` and move its files into
    ``out`` only when all are written: an interrupted or failed run (Ctrl-C, a full disk) leaves no
    partial folder and no new file in ``out``, only what was there before. Errors naming the staging
    folder are reworded to name ``out``."""
    import shutil

    final = Path(out)
    parent = final.resolve().parent
    with _writing(final):
        parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{final.resolve().name}.partial-", dir=parent))
    try:
        yield staging
        for src in sorted(p for p in staging.rglob("*") if p.is_file()):
            dst = final / src.relative_to(staging)
            with _writing(dst):
                dst.parent.mkdir(parents=True, exist_ok=True)
                os.replace(src, dst)
    except OutputError as exc:
        raise OutputError(str(exc).replace(str(staging), str(final))) from None
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def write_text(path: str | Path, text: str) -> None:
    with atomic_output(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def check_suffix(path: str | Path, allowed: tuple[str, ...], what: str, error: type[Exception] = OutputError) -> str:
    """The lower-case suffix of ``path`` if it is one of ``allowed``; else a precise ``error``."""
    suffix = Path(path).suffix.lower()
    if suffix not in allowed:
        raise error(f"{what} {str(path)!r} must end in {' or '.join(allowed)}")
    return suffix


def check_distinct(output: str | Path | None | dict[str, Any], *inputs: Any, what: str = "output") -> None:
    """An :class:`OutputError` if ``output`` is the same file as one of ``inputs``; several outputs given as
    ``{option: path}`` (None skipped) may be neither an input nor one another.

    Paths are compared after resolving symlinks and ``..`` (and by device/inode when both exist, so
    hard links count too). ``None`` and inputs that are not paths (a scene name given as a string
    that names no file, a G-buffer in memory) are skipped, so callers may pass their inputs as given.
    """
    outputs = list((output if isinstance(output, dict) else {what: output}).items())
    for i, (opt, path) in enumerate(outputs):
        same = next((inp for inp in inputs if path is not None and same_file(path, inp)), None)
        if same is not None:
            raise OutputError(f"{opt} {str(path)!r} would overwrite the input {str(same)!r}; choose another path")
        other = next((o for o, earlier in outputs[:i] if path is not None and same_file(path, earlier)), None)
        if other is not None:
            raise OutputError(f"{opt} {str(path)!r} is also the {other} file; choose another path")


def same_file(a: Any, b: Any) -> bool:
    """Whether paths ``a`` and ``b`` name one file: equal after resolving symlinks and ``..``, or (both existing)
    one device and inode, so hard links count too; anything that is not a path is no file."""
    if not (isinstance(a, (str, os.PathLike)) and isinstance(b, (str, os.PathLike))):
        return False
    p, q = Path(a), Path(b)
    with contextlib.suppress(OSError):
        return p.resolve() == q.resolve() or (p.exists() and q.exists() and os.path.samefile(p, q))
    return False


# ---- arrays and profile tables ---------------------------------------------------------------------

def save_arrays(path: str | Path, **arrays: ArrayLike) -> None:
    """Write an ``.npz`` of named arrays atomically."""
    with atomic_output(path) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, allow_pickle=True, **arrays)  # the default, named so no array can take its place


def save_profile_table(path: str | Path, r_mm: np.ndarray, rd: np.ndarray, meta: dict[str, Any]) -> None:
    """Write R(r) per channel: ``.csv`` (r_mm, Rd_R, Rd_G, Rd_B; mm and mm^-2) or ``.npz``.

    ``meta`` (model, material, totals...) becomes '#' header lines in CSV and a JSON string
    entry ``meta`` in NPZ.
    """
    suffix = check_suffix(path, (".csv", ".npz"), "profile output")
    r_mm = np.asarray(r_mm, dtype=float)
    rd = np.asarray(rd, dtype=float)
    if suffix == ".csv":
        with atomic_output(path) as tmp:
            header = "\n".join(f"{k}: {json.dumps(v)}" for k, v in meta.items())
            header += "\nr_mm,Rd_R,Rd_G,Rd_B  (Rd in mm^-2)"
            np.savetxt(tmp, np.column_stack([r_mm, rd]), delimiter=",", header=header, fmt="%.10e")
    if suffix == ".npz":
        save_arrays(path, r_mm=r_mm, Rd=rd, meta=np.array(json.dumps(meta)))


# ---- images ----------------------------------------------------------------------------------------

def tonemap(image: ArrayLike, peak: float) -> NDArray[np.float64]:
    """Linear -> display: divide by ``peak``, clip to [0, 1], sRGB transfer function (IEC 61966-2-1)."""
    x = np.clip(np.asarray(image, dtype=np.float64) / peak, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def save_image(path: str | Path, image: np.ndarray, layers: dict[str, np.ndarray] | None = None,
               what: str = "image") -> None:
    """Write a linear RGB image (H, W, 3).

    ``.exr``: float32 RGB plus the extra named RGB ``layers`` (``sss.R``, ``exact.G``...), ZIP, via
    OpenEXR; ``.png``: 8-bit sRGB tone-mapped to the image's 99.5th percentile (``layers`` are not
    written). Atomic; errors are :class:`OutputError` naming ``what`` and the path.
    """
    suffix = check_suffix(path, (".exr", ".png"), what)
    img = np.asarray(image)
    if img.ndim != 3 or img.shape[2] != 3:
        raise OutputError(f"{what} {str(path)!r}: the image must have shape (H, W, 3), got {img.shape}")
    img = np.ascontiguousarray(img, dtype=np.float32)
    if suffix == ".exr":
        channels = {"RGB": img}
        for name, arr in (layers or {}).items():
            channels[name] = np.ascontiguousarray(arr, dtype=np.float32)
        write_exr(path, channels, what=what)
        return
    finite = img[np.isfinite(img)]
    peak = float(np.percentile(finite, 99.5)) if finite.size else 1.0
    write_png(path, np.round(255.0 * tonemap(np.nan_to_num(img), peak if peak > 0 else 1.0)).astype(np.uint8))


def write_png(path: str | Path, rgb8: np.ndarray) -> None:
    """Write an 8-bit RGB image (H, W, 3) uint8 as PNG, atomically, with Pillow (which matplotlib's image
    writer uses too: importing matplotlib for it costs a first render a second or more)."""
    from PIL import Image

    arr = np.ascontiguousarray(rgb8, dtype=np.uint8)
    with atomic_output(path) as tmp:
        Image.fromarray(arr, "RGB").save(tmp, format="PNG")


# ---- OpenEXR ----------------------------------------------------------------------------------------

@contextlib.contextmanager
def _captured_output() -> Iterator[io.StringIO]:
    """Capture what a C library writes on file descriptors 1 and 2 and what Python code writes on
    sys.stdout / sys.stderr; the text is in the yielded buffer after the block."""
    buf = io.StringIO()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    saved = []
    with tempfile.TemporaryFile(mode="w+b") as sink:
        try:
            for fd in (1, 2):
                try:
                    saved.append((fd, os.dup(fd)))
                except OSError:  # no such descriptor (a daemon without stdio): nothing to silence
                    continue
                os.dup2(sink.fileno(), fd)
            with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
                yield buf
        finally:
            for fd, copy in saved:
                os.dup2(copy, fd)
                os.close(copy)
            sink.seek(0)
            buf.write(sink.read().decode("utf-8", "replace"))


def _library_message(text: str, path: Path) -> str:
    """The most specific line the OpenEXR library printed, without the file name it starts with."""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    errors = [ln for ln in lines if "EXR_ERR" in ln] or lines
    if not errors:
        return ""
    line = errors[-1]
    for prefix in (f"{path}: ", f"{path.name}: "):
        if line.startswith(prefix):
            line = line[len(prefix):]
    return re.sub(r"^\((EXR_ERR_\w+)\)\s*", r"\1: ", line)


def parse_document(text: str, suffix: str) -> Any:
    """The data of a TOML (``suffix`` ".toml") or JSON document; a ValueError for a malformed one, one nested too
    deeply for the parsers (both recurse per level: a 100,000-deep JSON raised RecursionError) included, so every
    reader of a user's file reports it as the malformed file it is."""
    import tomllib

    try:
        return tomllib.loads(text) if suffix.lower() == ".toml" else json.loads(text)
    except RecursionError:
        raise ValueError("nested too deeply (more levels of arrays or tables than the parser can follow)") from None


def read_document(path: str | Path, what: str, error: type[Exception] = OutputError, suffixes: Iterable[str] = (),
                  build: Callable[[Any], Any] | None = None) -> Any:
    """The data of an input file of TOML (or JSON: a ``.json`` file) after :func:`read_input`'s rules, or what
    ``build`` makes of it: the one reader of the settings, material and scene files. A malformed document is one
    ``error``, ``malformed {what} {path}: {why}``; an ``error`` of ``build`` (a value the file holds) names the
    file, ``{path}: {why}``."""
    p = Path(path)
    text = read_input(p, what, error, suffixes, text=True)
    try:
        data = parse_document(text, ".json" if p.suffix.lower() == ".json" else ".toml")
    except ValueError as exc:
        raise error(f"malformed {what} {str(p)!r}: {exc}") from None
    try:
        return data if build is None else build(data)
    except error as exc:
        raise error(f"{str(p)!r}: {exc}") from None


def read_input(path: str | Path, what: str, error: type[Exception] = OutputError, suffixes: Iterable[str] = (),
               size: int = -1, text: bool = False) -> Any:
    """The contents of an input file (``text``: decoded as UTF-8; ``size``: at most that many bytes), after the
    rules of every input file, stated once: a regular file that exists (a folder, a FIFO, a socket or a device
    is refused: reading a FIFO would wait for a writer forever), its suffix one of ``suffixes`` (when given), that
    reads; else one ``error`` naming ``what``."""
    import stat

    p = Path(path)
    if not p.exists() or p.is_dir():
        raise error(f"{what} {str(p)!r} {'is a directory, not a file' if p.is_dir() else 'does not exist'}")
    mode = p.stat().st_mode
    if not stat.S_ISREG(mode):
        kind = "a FIFO (named pipe)" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode) else "a device"
        raise error(f"{what} {str(p)!r} is {kind}, not a regular file")
    if suffixes:
        check_suffix(p, tuple(suffixes), what, error)
    try:
        with _failing(f"cannot read {what} {str(p)!r}", error), open(p, "rb") as fh:
            raw = fh.read(size)
        return raw.decode("utf-8") if text else raw
    except UnicodeDecodeError:
        raise error(f"{what} {str(p)!r} is not a UTF-8 text file") from None


def read_exr(path: str | Path, what: str = "EXR file", required: Iterable[str] = ()) -> tuple[dict, dict]:
    """Read an OpenEXR file: (header, channels), channels a dict name -> array ((H, W) or (H, W, 3)
    for ``name.R/G/B`` groups).

    A multi-part file is read from the one part that holds every ``required`` channel (its header is
    returned); if no part, or more than one, holds them all, it is refused, naming the parts. Deep
    files are refused. Missing files, directories, other formats and truncated or corrupt files are
    one :class:`GBufferError` line naming ``what`` and the path; nothing reaches stdout or stderr.
    """
    p = Path(path)
    head = read_input(p, what, GBufferError, size=8)
    if len(head) < 8 or head[:4] != EXR_MAGIC:
        raise GBufferError(f"{what} {str(p)!r} is not an OpenEXR file")
    if int.from_bytes(head[4:8], "little") & _EXR_DEEP:  # (the version field's flags)
        raise GBufferError(f"{what} {str(p)!r} holds deep data; ssskit reads flat (scanline or tiled) images")
    import OpenEXR

    required = tuple(required)
    parts = []
    with _captured_output() as out:
        try:
            with OpenEXR.File(str(p)) as f:
                for i in range(len(f.parts)):
                    parts.append((dict(f.header(i)), {name: ch.pixels for name, ch in f.channels(i).items()}))
        except Exception:  # noqa: BLE001 - the bindings raise RuntimeError / ValueError with C++ text
            parts = []
    if not parts:
        detail = _library_message(out.getvalue(), p)
        raise GBufferError(f"cannot read {what} {str(p)!r}: the file is truncated or corrupt"
                           + (f" ({detail})" if detail else ""))
    if len(parts) == 1:
        return parts[0]
    holding = [i for i, (_, ch) in enumerate(parts) if all(name in ch for name in required)]
    if required and len(holding) == 1:
        return parts[holding[0]]
    listing = "; ".join(f"part {i} {h.get('name', '')!r}: {', '.join(sorted(ch)) or 'no channels'}"
                        for i, (h, ch) in enumerate(parts))
    if not required:
        need = "ssskit reads single-part files"
    elif holding:
        need = (f"parts {', '.join(map(str, holding))} each hold every layer {', '.join(required)}, so which one to "
                "read is ambiguous; keep one of them")
    else:
        need = f"no single part holds the layers {', '.join(required)}"
    raise GBufferError(f"{what} {str(p)!r} is a multi-part EXR and {need} ({listing})")


def write_exr(path: str | Path, channels: dict[str, np.ndarray], attributes: dict[str, str] | None = None,
              what: str = "EXR file") -> None:
    """Write a single-part scanline OpenEXR file (ZIP) atomically: ``channels`` name -> (H, W) or
    (H, W, 3) array (float16/float32/uint32), ``attributes`` extra string header attributes."""
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **(attributes or {})}
    with atomic_output(path) as tmp:
        with _captured_output() as out:
            try:
                with OpenEXR.File(header, channels) as f:
                    f.write(str(tmp))
                error = None
            except Exception as exc:  # noqa: BLE001 - the bindings raise RuntimeError with C++ text
                error = exc
        if error is not None:
            detail = _library_message(out.getvalue(), tmp) or str(error).replace(str(tmp), str(path))
            raise OutputError(f"cannot write {what} {str(path)!r}: {detail}")


# progress lives in ssskit.progress (no numpy: the CLI's entry point imports it); re-exported here
from .progress import (LINE_INTERVAL_S, ProgressBar, Ticker, heartbeat, noted, plain_progress,  # noqa: E402,F401
                       progress_bar, report, reporting, reporting_active, say)
