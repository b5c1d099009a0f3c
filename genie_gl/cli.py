"""The ``genie`` command.

Each subcommand is a module of :mod:`genie_gl.commands` with ``add_arguments(parser)`` and
``run(args) -> int``, listed in :data:`COMMANDS` one line each. Only the module of the command
given is imported, and a command module imports the pipeline only when it runs, so
``genie --help`` and ``genie COMMAND --help`` answer at once. This file wires them up, reads
the environment (the one place that does) and turns :class:`~genie_gl.errors.GenieError` into
one clear line and exit code 2.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import signal
import sys
import threading
from typing import Any

from . import __version__
from .errors import GenieError, os_error_message

# subcommand -> (module with add_arguments/run, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "layout": ("genie_gl.commands.layout", "generate a region layout tree from a JSON strategy"),
    "scene": ("genie_gl.commands.scene", "build a 3D scene (USD) from a layout JSON"),
    "capture": (
        "genie_gl.commands.capture",
        "render a scene from K placed cameras and export clouds",
    ),
    "scan": (
        "genie_gl.commands.scan",
        "scan a strategy's scene with a LiDAR scanner or rig along a trajectory",
    ),
    "plan": ("genie_gl.commands.plan", "print which effects run where, and why, before rendering"),
    "dataset": ("genie_gl.commands.dataset", "run the whole pipeline for N scenes"),
    "bench": (
        "genie_gl.commands.bench",
        "benchmarks: render | layout | accuracy | pipeline | stability | planning | sequence | "
        "odometry | cli",
    ),
    "report-card": (
        "genie_gl.commands.report_card",
        "a sensor profile against published measurements of the real device",
    ),
    "eval": (
        "genie_gl.commands.eval",
        "train and test segmentation models on datasets; protocols and studies",
    ),
    "view": (
        "genie_gl.commands.view",
        "a Rerun recording (.rrd) of a dataset, recording, capture or scene; --serve: web viewer",
    ),
}


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (the option and what was expected), exit status 2."""

    def error(self, message: str):  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``genie`` parser; the options of ``command`` (its module imported) when given, every
    other subcommand by name and help line only."""
    parser = _Parser(
        prog="genie", description="genie-gl: labelled synthetic point clouds of industrial scenes"
    )
    parser.add_argument("--version", action="version", version=f"genie-gl {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more logging")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name, (module, help_text) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        p.set_defaults(_module=module)
        if name == command:
            importlib.import_module(module).add_arguments(p)
    return parser


def command_of(argv: list[str]) -> str | None:
    """The subcommand ``argv`` names: its first word that is not an option."""
    return next((a for a in argv if not a.startswith("-")), None)


# the optional packages a command may need, by import name: (PyPI name, genie-gl extra)
OPTIONAL = {
    "kiss_icp": ("kiss-icp", "bench"),
    "evo": ("evo", "bench"),
    "open3d": ("open3d", "bench"),
    "pye57": ("pye57", "sequences"),
    "laspy": ("laspy", "sequences"),
    "rosbags": ("rosbags", "sequences"),
    "fast_simplification": ("fast-simplification", "lod"),
    "ray": ("ray", "ray"),
    "torch": ("torch", "neural"),
    "rerun": ("rerun-sdk", "view"),
    "rerun_cli": ("rerun-sdk", "view"),
}


def missing_package(name: str) -> str:
    """One line: which optional package is not installed, and how to install it."""
    top = name.split(".")[0]
    pypi, extra = OPTIONAL.get(top, (top, None))
    how = (
        f"pip install 'genie-gl[{extra}]' (or pip install {pypi})"
        if extra
        else f"pip install {pypi}"
    )
    return f"needs the Python package {top!r}, which is not installed here; {how}"


# what a command stopped half-way leaves: the workers some commands start, and which resume
WORKERS = ("capture", "dataset", "eval", "bench")


def stopped_message(command: str, by_sigterm: bool) -> str:
    """The line a command stopped by SIGINT or SIGTERM prints: what it stopped, what it kept
    and (``genie dataset`` alone) that running it again resumes."""
    how = "stopped by SIGTERM" if by_sigterm else "interrupted"
    workers = "its workers are stopped and " if command in WORKERS else ""
    resume = "; the same command run again resumes the dataset" if command == "dataset" else ""
    return f"{how}; {workers}what was written whole is kept, nothing half-written{resume}"


def interrupted(exc: BaseException) -> bool:
    """True when a KeyboardInterrupt lies behind ``exc`` (a library that turned the interrupt
    into an error of its own: numba interrupted while it compiles a kernel)."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(command_of(argv))
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse's one-line error (or --help, --version)
        return int(exc.code or 0)
    logging.basicConfig(
        level=logging.WARNING - 10 * min(args.verbose, 2),
        format="%(levelname)s %(name)s: %(message)s",
    )
    if args.command is None:
        parser.print_help()
        return 2
    stopped: list[int] = []

    def stop(
        signum: int, frame: object
    ) -> None:  # SIGTERM as SIGINT: unwind, so pools stop their workers
        stopped.append(signum)
        raise KeyboardInterrupt

    def unraisable(
        info: Any,
    ) -> None:  # an interrupt inside a C callback (numba compiling) is no error
        if not isinstance(info.exc_value, KeyboardInterrupt):
            sys.__unraisablehook__(info)

    main_thread = threading.current_thread() is threading.main_thread()
    previous = (
        {s: signal.signal(s, stop) for s in (signal.SIGTERM, signal.SIGINT)} if main_thread else {}
    )
    sys.unraisablehook = unraisable
    try:
        backend = os.environ.get("GENIE_GL_BACKEND")
        if backend:
            from .render.gl.context import set_default_backend

            set_default_backend(backend)
        return int(importlib.import_module(args._module).run(args) or 0)
    except GenieError as exc:
        print(f"genie {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except ModuleNotFoundError as exc:
        if not exc.name or exc.name.split(".")[0] == "genie_gl":
            raise  # a module of ours missing is a bug, not an input
        print(f"genie {args.command}: error: {missing_package(exc.name)}", file=sys.stderr)
        return 2
    except (
        OSError
    ) as exc:  # the file system said no (full, read-only, name too long, ...): one line
        print(f"genie {args.command}: error: {os_error_message(exc)}", file=sys.stderr)
        return 2
    except MemoryError:
        print(
            f"genie {args.command}: error: out of memory; use smaller inputs (fewer cameras, "
            "scenes or workers, "
            "a smaller sensor) or lower the limits (--max-memory-gb where the command has it)",
            file=sys.stderr,
        )
        return 2
    except KeyboardInterrupt:
        by = stopped[0] if stopped else signal.SIGINT
        print(
            f"genie {args.command}: {stopped_message(args.command, by == signal.SIGTERM)}",
            file=sys.stderr,
        )
        return 128 + by
    except Exception as exc:  # noqa: BLE001  (re-raised unless a signal caused it)
        if not (
            stopped or interrupted(exc)
        ):  # a library may turn the interrupt into an error of its own
            raise
        by = stopped[0] if stopped else signal.SIGINT
        print(
            f"genie {args.command}: {stopped_message(args.command, by == signal.SIGTERM)}",
            file=sys.stderr,
        )
        return 128 + by
    finally:
        sys.unraisablehook = sys.__unraisablehook__
        for sig, handler in previous.items():
            signal.signal(sig, handler)


if __name__ == "__main__":
    sys.exit(main())
