"""Exceptions raised by ssskit.

Every error a user can cause derives from :class:`SsskitError` (itself a ``ValueError``), so
callers may catch either; the CLI turns them into one line on stderr and exit status 2.
"""

from __future__ import annotations


class SsskitError(ValueError):
    """Base class for errors caused by user input (parameters, names, files).

    ``cli_message``: the same message in the command line's terms (its options instead of the
    Python API's keywords), which the CLI prints instead of ``str(error)`` when given.
    """

    def __init__(self, *args: object, cli_message: str | None = None) -> None:
        super().__init__(*args)
        self.cli_message = cli_message

    def __reduce__(self):  # keep cli_message across processes (sweeps raise in worker processes)
        return (_rebuild, (type(self), self.args, self.cli_message))


def _rebuild(cls: type[SsskitError], args: tuple, cli_message: str | None) -> SsskitError:
    return cls(*args, cli_message=cli_message)


class MaterialError(SsskitError):
    """Invalid material coefficients, an unknown preset name or a malformed material file."""


class ProfileError(SsskitError):
    """Invalid profile parameters or an unknown profile model."""


class SamplingError(SsskitError):
    """Invalid distribution parameters or sample inputs."""


class SimulationInterrupted(ProfileError):
    """A Monte Carlo simulation was stopped (Ctrl-C); its finished batches are kept for resume."""


class KernelError(SsskitError):
    """Invalid kernel parameters, grids or kernel files."""


class SignalError(SsskitError):
    """Invalid test-signal or image parameters (sizes, angles, shapes)."""


class OutputError(SsskitError):
    """An output path that cannot be written (bad extension, missing permissions, same as an input...)."""


class GBufferError(SsskitError):
    """A G-buffer or G-buffer file that cannot be used (the message names the layer)."""


class PassError(SsskitError):
    """Bad settings for a screen-space pass."""


class BackendError(SsskitError):
    """An unknown backend, or one that is not available on this machine (the message says why)."""


class SceneError(SsskitError):
    """Bad scene parameters, or a scene Mitsuba cannot build."""


class SettingsError(SsskitError):
    """Invalid render or pass settings, or a malformed settings file."""


def unknown_names_message(where: str, unknown: list[str], known: list[str], what: str = "setting") -> str:
    """The one wording of "a name that is not known": ``{where}: unknown {what}(s) a, b (known: c, d)`` (the
    settings files' and :meth:`ssskit.settings.Settings.from_dict`'s, reused by functions that take keywords)."""
    return f"{where}: unknown {what}(s) {', '.join(unknown)} (known: {', '.join(known) or 'none'})"


def check_keywords(where: str, given: dict[str, object], known: list[str], error: type[SsskitError]) -> None:
    """Raise ``error`` naming every keyword of ``given`` not in ``known`` (and the known ones), so a misspelt
    keyword argument is the module's SsskitError rather than Python's TypeError."""
    unknown = sorted(k for k in given if k not in known)
    if unknown:
        raise error(unknown_names_message(where, unknown, list(known), "keyword argument"))


__all__ = [
    "BackendError",
    "GBufferError",
    "KernelError",
    "MaterialError",
    "OutputError",
    "PassError",
    "ProfileError",
    "SamplingError",
    "SceneError",
    "SettingsError",
    "SignalError",
    "SimulationInterrupted",
    "SsskitError",
    "check_keywords",
    "unknown_names_message",
]
