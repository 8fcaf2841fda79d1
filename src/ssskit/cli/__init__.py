"""The ``ssskit`` command line: a thin click layer over the Python API.

stdout carries only the result (``--json`` prints exactly one JSON object); progress and errors go
to stderr. Every argument is checked while the command line is parsed, before any work starts
(shared option types in :mod:`ssskit.cli.options`, choices from the registries); errors a user can
cause print one line ``ssskit: error: ...`` and exit with status 2.

One module per command or group of commands:

* :mod:`.materials` -- ``materials``; :mod:`.backends` -- ``backends``;
* :mod:`.profiles` -- ``profile``, ``simulate``, ``xie-c``;
* :mod:`.kernels` -- ``kernel``, ``evaluate``;
* :mod:`.render` -- ``render``;
* :mod:`.export` -- ``export``;
* :mod:`.report` -- ``figures``, ``demo``.
"""

from __future__ import annotations

import contextlib
import importlib
import sys
from collections.abc import Iterator, MutableMapping

import click

from ..errors import SimulationInterrupted, SsskitError

EXIT_USAGE = 2

#: every command: name -> (its module in this package, the click command's attribute, the first paragraph of its
#: help, or its short_help prefixed "short:"). The group lists and finds commands by this table and imports a
#: command's module only to run it or show its own help, so ``ssskit --help`` imports neither numpy nor the
#: pipeline; tests/cli/test_cli.py checks the texts against the commands.
COMMANDS: dict[str, tuple[str, str, str]] = {
    "materials": ("materials", "materials", "List the preset materials with their coefficients (mm^-1)."),
    "backends": ("backends", "backends", "List the backends of the screen-space passes: available here or why not."),
    "profile": ("profiles", "profile", "Diffuse reflectance profile R(r) of a material, per RGB channel."),
    "simulate": ("profiles", "simulate", "Monte Carlo (MCML) diffuse reflectance profiles with the supplement's "
                                         "settings."),
    "xie-c": ("profiles", "xie_c", "short:Refit c of Xie 2020 Eq. 21; report the CDF errors."),
    "kernel": ("kernels", "kernel", "A separable kernel approximation of a material's profile."),
    "evaluate": ("kernels", "evaluate", "Each method's error against the exact 2D convolution on a test signal."),
    "render": ("render", "render", "Screen-space SSS (separable, or Burley Monte Carlo) of a scene (built-in, generated, a "
                                   "mesh or a scene file), with errors against the exact 2D convolution; --pass "
                                   "burley-adaptive: a sequence of frames with adaptive sample counts, each against its "
                                   "converged reference."),
    "export": ("export", "export", "Write a kernel or a material's parameters in a format an engine loads."),
    "figures": ("report", "figures", "Regenerate the papers' figures (NAME: any of the figures listed below; all "
                                     "by default). The figures that run a screen-space pass run it on --backend; "
                                     "those that render a scene (xie-fig1) take --scene, --units and --material-map."),
    "view": ("view", "view", "A live WebGL2 viewer of a material on a mesh: the G-buffer pass, the separable and "
                             "Burley passes as the fragment shaders ssskit export writes, composite and tone mapping, "
                             "with per-pass frame times."),
    "demo": ("report", "demo", "The main job: build the report (figures + index.html) on built-in defaults; --scene "
                               "adds your model."),
}


def _shorten(text: str, limit: int) -> str:
    """click's own shortening of a help text to a listed line (what Command.get_short_help_str does)."""
    import click.core

    shorten = getattr(click.core, "_make_default_short_help", None)  # click >= 8.2
    if shorten is None:  # pragma: no cover - click 8.1
        shorten = importlib.import_module("click.utils").make_default_short_help
    return str(shorten(text, limit))


class LazyCommands(MutableMapping[str, click.Command]):
    """The group's commands: those of :data:`COMMANDS`, imported on first access, and any added later."""

    def __init__(self, table: dict[str, tuple[str, str, str]]) -> None:
        self._table = table
        self._loaded: dict[str, click.Command] = {}

    def __getitem__(self, name: str) -> click.Command:
        if name not in self._loaded:
            module, attr, _ = self._table[name]  # (a KeyError for a name in neither)
            self._loaded[name] = getattr(importlib.import_module(f"{__name__}.{module}"), attr)
        return self._loaded[name]

    def __setitem__(self, name: str, command: click.Command) -> None:
        self._loaded[name] = command

    def __delitem__(self, name: str) -> None:
        found = self._loaded.pop(name, None) is not None
        if name in self._table:
            self._table = {k: v for k, v in self._table.items() if k != name}
        elif not found:
            raise KeyError(name)

    def __iter__(self) -> Iterator[str]:
        yield from self._table
        yield from (n for n in self._loaded if n not in self._table)

    def __len__(self) -> int:
        return len(set(self._table) | set(self._loaded))

    def short_help(self, name: str, limit: int) -> str | None:
        """The listed help of a command not imported yet (click's own shortening), else None."""
        if name in self._loaded or name not in self._table:
            return None
        text = self._table[name][2]
        return text[len("short:"):] if text.startswith("short:") else _shorten(text, limit).strip()


class LazyGroup(click.Group):
    """A click group whose commands come from :class:`LazyCommands`: listing them imports nothing."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self.commands = LazyCommands(COMMANDS)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        names = self.list_commands(ctx)
        if not names:
            return
        limit = formatter.width - 6 - max(len(n) for n in names)
        rows = []
        for name in names:
            text = self.commands.short_help(name, limit) if isinstance(self.commands, LazyCommands) else None
            if text is None:
                cmd = self.get_command(ctx, name)
                if cmd is None or cmd.hidden:
                    continue
                text = cmd.get_short_help_str(limit)
            rows.append((name, text))
        with formatter.section("Commands"):
            formatter.write_dl(rows)


def _examples(*lines: str) -> str:
    return "\b\nExamples:\n" + "\n".join(f"  {line}" for line in lines)  # as cli.options.examples


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
             epilog=_examples("ssskit materials", "ssskit profile --material skin1 --model dipole --json",
                              "ssskit render --scene slab --kernel preintegrated --out slab.png",
                              "ssskit demo", "ssskit COMMAND --help"))
@click.version_option(package_name="ssskit")
def cli() -> None:
    """ssskit: diffusion profiles, separable kernels and screen-space subsurface scattering.

    Every command prints only its result on stdout (--json: exactly one JSON object); bad input prints
    one line 'ssskit: error: ...' on stderr and exits with status 2.
    """


@contextlib.contextmanager
def _terminate_as_interrupt() -> Iterator[None]:
    """SIGTERM (``kill``, a CI timeout) handled as Ctrl-C while a command runs: its clean-up runs (a demo's
    staging folder is removed, a simulation keeps its finished batches) instead of the process vanishing."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def main(argv: list[str] | None = None) -> int:
    """Entry point: runs the CLI, turning user errors into one line on stderr and exit status 2. Before any
    command imports numpy, BLAS and OpenMP are set to one thread unless the user chose a count
    (:func:`ssskit.compute.workers.one_library_thread`). Without ``argv`` (the process's own command line: the
    ``ssskit`` script, ``python -m ssskit``) the process exits next, so its objects are left to the exit
    instead of the garbage collector's last pass (:func:`_leave_objects_to_exit`)."""
    try:
        return _main(argv)
    finally:
        if argv is None:
            _leave_objects_to_exit()


def _leave_objects_to_exit() -> None:
    """``gc.freeze()``: every object alive now moves to the collector's permanent generation, so the
    interpreter's shutdown does not walk them (after a command that compiled numba kernels that walk took
    0.35-0.45 s of a process's exit: numba's and LLVM's objects). Reference counting still frees what it
    frees and every ``atexit`` handler runs; only the last search for unreachable cycles skips them (ssskit
    closes its files with ``with``; standard streams are flushed at exit). Only for a process about to exit:
    frozen objects are never collected."""
    import gc

    gc.freeze()


def _main(argv: list[str] | None) -> int:
    import os

    from ..compute.workers import ignored_sigint_blocked, one_library_thread
    from ..progress import heartbeat, reporting
    from .options import progress

    os.environ.update(one_library_thread())

    try:
        # progress from deep in the library in every mode; no silence longer than a few seconds in a log. SIGINT
        # inherited as ignored (a script's background job) is ignored by every thread, Mitsuba's renders included,
        # and the command completes; otherwise it is Ctrl-C: exit status 130 with nothing written
        with ignored_sigint_blocked(), reporting(progress), _terminate_as_interrupt(), heartbeat():
            cli.main(args=argv, prog_name="ssskit", standalone_mode=False)
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except SimulationInterrupted as exc:
        click.echo(f"ssskit: {' '.join((exc.cli_message or str(exc)).splitlines())}", err=True)
        return 130
    except click.exceptions.Abort as exc:  # click's form of a KeyboardInterrupt in a command: one word for both
        interrupted = isinstance(exc.__cause__, KeyboardInterrupt)
        click.echo(f"ssskit: {'interrupted' if interrupted else 'aborted'}", err=True)
        return 130
    except click.ClickException as exc:
        message = " ".join(exc.format_message().split("\n"))
        click.echo(f"ssskit: error: {message}", err=True)
        return EXIT_USAGE
    except SsskitError as exc:
        click.echo(f"ssskit: error: {' '.join((exc.cli_message or str(exc)).splitlines())}", err=True)
        return EXIT_USAGE
    except OSError as exc:  # a file system refusal the upfront checks could not foresee (disk full...)
        where = f" {exc.filename!r}" if getattr(exc, "filename", None) else ""
        click.echo(f"ssskit: error: cannot access{where}: {exc.strerror or exc}", err=True)
        return EXIT_USAGE
    except KeyboardInterrupt:
        click.echo("ssskit: interrupted", err=True)
        return 130
    return 0


__all__ = ["COMMANDS", "EXIT_USAGE", "LazyCommands", "LazyGroup", "cli", "main"]

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
