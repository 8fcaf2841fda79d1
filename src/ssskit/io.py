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
import time
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, Protocol

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
        fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=f".tmp{target.suffix}", dir=parent)
    except OSError as exc:
        why = exc.strerror
        existing = next((a for a in (parent, *parent.parents) if a.exists()), None)
        if existing is not None and not existing.is_dir():
            why = f"{str(existing)!r} is not a directory"
        raise OutputError(f"cannot write {str(target)!r}: {why}") from None
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        try:
            os.chmod(tmp, 0o666 & ~_umask())
            os.replace(tmp, target)
        except OSError as exc:
            raise OutputError(f"cannot write {str(target)!r}: {exc.strerror}") from None
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def write_text(path: str | Path, text: str) -> None:
    with atomic_output(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def check_suffix(path: str | Path, allowed: tuple[str, ...], what: str) -> str:
    """The lower-case suffix of ``path`` if it is one of ``allowed``; else a precise error."""
    suffix = Path(path).suffix.lower()
    if suffix not in allowed:
        raise OutputError(f"{what} {str(path)!r} must end in {' or '.join(allowed)}")
    return suffix


def check_distinct(output: str | Path | None, *inputs: Any, what: str = "output") -> None:
    """An :class:`OutputError` if ``output`` is the same file as one of ``inputs``.

    Paths are compared after resolving symlinks and ``..`` (and by device/inode when both exist, so
    hard links count too). ``None`` and inputs that are not paths (a scene name given as a string
    that names no file, a G-buffer in memory) are skipped, so callers may pass their inputs as given.
    """
    if output is None:
        return
    out = Path(output)
    for inp in inputs:
        if inp is None or not isinstance(inp, (str, os.PathLike)):
            continue
        p = Path(inp)
        same = False
        with contextlib.suppress(OSError):
            same = p.resolve() == out.resolve() or (out.exists() and p.exists() and os.path.samefile(out, p))
        if same:
            raise OutputError(f"{what} {str(output)!r} would overwrite the input {str(inp)!r}; choose another path")


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
    from matplotlib.image import imsave

    finite = img[np.isfinite(img)]
    peak = float(np.percentile(finite, 99.5)) if finite.size else 1.0
    ldr = np.round(255.0 * tonemap(np.nan_to_num(img), peak if peak > 0 else 1.0)).astype(np.uint8)
    with atomic_output(path) as tmp:
        imsave(tmp, ldr, format="png")


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


def _check_readable(path: Path, what: str) -> int:
    """The version field of an OpenEXR file, after checking that ``path`` is a readable OpenEXR file."""
    if not path.exists():
        raise GBufferError(f"{what} {str(path)!r} does not exist")
    if path.is_dir():
        raise GBufferError(f"{what} {str(path)!r} is a directory, not a file")
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except OSError as exc:
        raise GBufferError(f"cannot read {what} {str(path)!r}: {exc.strerror}") from None
    if len(head) < 8 or head[:4] != EXR_MAGIC:
        raise GBufferError(f"{what} {str(path)!r} is not an OpenEXR file")
    return int.from_bytes(head[4:8], "little")


def read_exr(path: str | Path, what: str = "EXR file", required: Iterable[str] = ()) -> tuple[dict, dict]:
    """Read an OpenEXR file: (header, channels), channels a dict name -> array ((H, W) or (H, W, 3)
    for ``name.R/G/B`` groups).

    A multi-part file is read from the one part that holds every ``required`` channel (its header is
    returned); if no part, or more than one, holds them all, it is refused, naming the parts. Deep
    files are refused. Missing files, directories, other formats and truncated or corrupt files are
    one :class:`GBufferError` line naming ``what`` and the path; nothing reaches stdout or stderr.
    """
    p = Path(path)
    version = _check_readable(p, what)
    if version & _EXR_DEEP:
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
    need = f"no single part holds the layers {', '.join(required)}" if required else "ssskit reads single-part files"
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


class ProgressBar(Protocol):
    """What :func:`progress_bar` returns (a tqdm bar, or plain lines for a log): the calls ssskit makes."""

    def update(self, n: int = 1, /) -> object: ...

    def set_postfix_str(self, s: str, /) -> None: ...

    def close(self) -> None: ...


class _LineProgress:
    """A tqdm-like progress report for a stderr that is no terminal (a log file, CI): one plain line
    at each tenth of the total and at the end, instead of carriage-return redraws."""

    def __init__(self, total: int, desc: str, unit: str, initial: int = 0) -> None:
        self.total, self.desc, self.unit, self.n = max(int(total), 1), desc, unit, int(initial)
        self.postfix, self._next = "", self._step(self.n)
        self._t0 = time.perf_counter()

    def _step(self, n: int) -> int:
        tenth = max(self.total // 10, 1)
        return (n // tenth + 1) * tenth

    def update(self, k: int = 1) -> None:
        self.n += int(k)
        if self.n >= self._next or self.n >= self.total:
            self._next = self._step(self.n)
            self._say()

    def set_postfix_str(self, text: str) -> None:
        self.postfix = text

    def _say(self) -> None:
        extra = f", {self.postfix}" if self.postfix else ""
        print(f"  {self.desc}: {self.n:,}/{self.total:,} {self.unit}{extra} ({time.perf_counter() - self._t0:.0f} s)",
              file=sys.stderr, flush=True)

    def close(self) -> None:
        pass


def progress_bar(total: int, desc: str, unit: str = "it", enabled: bool = True, initial: int = 0,
                 **tqdm_kw: Any) -> ProgressBar:
    """A progress bar on stderr: tqdm when stderr is a terminal, plain lines at each tenth otherwise
    (readable in logs), nothing when not ``enabled``. Supports update, set_postfix_str and close."""
    if not enabled:
        from tqdm import tqdm

        return tqdm(total=total, disable=True)
    if not sys.stderr.isatty():
        return _LineProgress(total, desc, unit, initial)
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, initial=initial, **tqdm_kw)
