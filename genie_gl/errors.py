"""The exceptions genie-gl raises.

Every message names what was wrong (file, key or field, value) and, where there is one,
the fix. Catch :class:`GenieError` to catch them all.
"""

from __future__ import annotations

import difflib
import errno
from collections.abc import Iterable


class GenieError(Exception):
    """Base class of every error genie-gl raises on purpose."""


class ConfigError(GenieError, ValueError):
    """Bad input: a strategy, profile, calibration, scene file or argument."""


class BackendUnavailableError(GenieError, RuntimeError):
    """No OpenGL backend could start; the message lists what was tried and how to fix it."""


class ShaderError(GenieError):
    """A shader failed to compile or link; carries the shader path and the driver's log."""

    def __init__(self, path: str, log: str) -> None:
        super().__init__(f"shader {path} failed to build:\n{log}")
        self.path = path
        self.log = log


class RenderError(GenieError, RuntimeError):
    """Rendering failed (GL error, bad geometry that cannot be skipped, ...)."""


def did_you_mean(value: str, choices: Iterable[str]) -> str:
    """Return ``"; did you mean 'x'?"`` for the closest choice, or ``""`` when none is close."""
    close = difflib.get_close_matches(str(value), list(choices), n=1)
    return f"; did you mean '{close[0]}'?" if close else ""


def json_path(loc: Iterable[object]) -> str:
    """A validation error's location as a JSON path: ``("levels", 0, "args")`` ->
    ``$.levels[0].args``."""
    out = "$"
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else f".{part}"
    return out


class ExportError(GenieError, ValueError):
    """Data that a format cannot hold (an id beyond its range, ...); the message names the limit."""


class LimitError(ConfigError):
    """A run estimated to need more memory, disk or work than allowed; the message gives the
    estimate and the option that raises the limit."""


def os_error_message(exc: OSError) -> str:
    """One line for a file-system error: the file, what happened, what to do."""
    where = exc.filename or "a file"
    if exc.filename2:
        where = f"{exc.filename} -> {exc.filename2}"
    fix = {
        errno.ENOSPC: "free space and run again; nothing half-written is left",
        errno.EDQUOT: "free space and run again; nothing half-written is left",
        errno.EFBIG: "beyond the file-size limit of this file system or process; nothing "
        "half-written is left",
        errno.EROFS: "write somewhere else",
        errno.EACCES: "write somewhere else, or give permission",
        errno.ENAMETOOLONG: "use a shorter name",
    }.get(exc.errno or -1)
    return f"{where}: {exc.strerror or exc}" + (f" ({fix})" if fix else "")
