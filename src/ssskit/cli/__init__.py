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
import sys
from collections.abc import Iterator

import click

from ..errors import SimulationInterrupted, SsskitError
from . import backends, export, kernels, materials, profiles, render, report
from .options import examples

EXIT_USAGE = 2


@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
             epilog=examples("ssskit materials", "ssskit profile --material skin1 --model dipole --json",
                             "ssskit render --scene slab --kernel preintegrated --out slab.png",
                             "ssskit demo", "ssskit COMMAND --help"))
@click.version_option(package_name="ssskit")
def cli() -> None:
    """ssskit: diffusion profiles, separable kernels and screen-space subsurface scattering.

    Every command prints only its result on stdout (--json: exactly one JSON object); bad input prints
    one line 'ssskit: error: ...' on stderr and exits with status 2.
    """


for _command in (
    materials.materials,
    backends.backends,
    profiles.profile,
    profiles.simulate,
    profiles.xie_c,
    kernels.kernel,
    kernels.evaluate,
    render.render,
    export.export,
    report.figures,
    report.demo,
):
    cli.add_command(_command)


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
    """Entry point: runs the CLI, turning user errors into one line on stderr and exit status 2."""
    from ..io import heartbeat, reporting
    from .options import progress

    try:
        # progress from deep in the library in every mode; no silence longer than a few seconds in a log
        with reporting(progress), _terminate_as_interrupt(), heartbeat():
            cli.main(args=argv, prog_name="ssskit", standalone_mode=False)
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except SimulationInterrupted as exc:
        click.echo(f"ssskit: {' '.join((exc.cli_message or str(exc)).splitlines())}", err=True)
        return 130
    except click.exceptions.Abort:
        click.echo("ssskit: aborted", err=True)
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


__all__ = ["EXIT_USAGE", "cli", "main"]

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
