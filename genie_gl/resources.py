"""Where the shipped data lives: ``shaders/``, ``layouts/``, ``sensors/`` and ``rigs/``.

In a wheel they are packaged as ``genie_gl/_data/<kind>``; in a source checkout (editable
install) they are the top-level folders of the repository. :func:`data_dir` finds either.
"""

from __future__ import annotations

import json
import os
from importlib import resources
from pathlib import Path
from typing import Any

from .errors import ConfigError, did_you_mean

KINDS = ("shaders", "layouts", "sensors", "rigs")


def data_dir(kind: str) -> Path:
    """Return the folder holding the shipped files of ``kind`` (one of :data:`KINDS`)."""
    if kind not in KINDS:
        raise ValueError(f"unknown data kind {kind!r}; expected one of {KINDS}")
    packaged = Path(str(resources.files("genie_gl"))) / "_data" / kind
    if packaged.is_dir():
        return packaged
    checkout = Path(__file__).resolve().parent.parent / kind
    if checkout.is_dir():
        return checkout
    raise FileNotFoundError(
        f"genie-gl data folder '{kind}' not found (looked in {packaged} and {checkout})"
    )


def resolve(name_or_path: str | Path, kind: str, suffixes: tuple[str, ...]) -> Path:
    """Resolve a user's argument to a file: an existing path, or the bare name of a shipped file.

    ``resolve("realsense_d435", "sensors", (".yaml",))`` finds ``sensors/realsense_d435.yaml``.
    A path with a folder in it that does not exist is an error: it never falls back to a
    shipped file of the same name.
    """
    if not isinstance(name_or_path, (str, os.PathLike)):
        raise ConfigError(
            f"{kind[:-1]}: expected a file name or the name of a shipped {kind[:-1]} (str or "
            "path), got "
            f"{type(name_or_path).__name__} {name_or_path!r:.60}"
        )
    path = Path(name_or_path)
    if path.is_file():
        return path
    if path.exists():
        raise ConfigError(f"{name_or_path}: not a file")
    shipped = data_dir(kind)
    names = sorted({p.stem for s in suffixes for p in shipped.glob(f"*{s}")})
    bare = path.name == str(name_or_path) and str(name_or_path) not in ("", ".", "..")
    if bare:
        for candidate in [shipped / path.name, *(shipped / (path.name + s) for s in suffixes)]:
            if candidate.is_file():
                return candidate
        raise ConfigError(
            f"{name_or_path}: no such file, and no shipped {kind[:-1]} of that name "
            f"(shipped: {', '.join(names) or 'none'}){did_you_mean(path.stem, names)}"
        )
    hint = (
        f"; the shipped {kind[:-1]} of that name is reached by its bare name '{path.stem}'"
        if path.stem in names
        else ""
    )
    raise ConfigError(f"{name_or_path}: no such file{hint}")


def read_text(path: str | Path, what: str) -> str:
    """The text of an input file; a binary or unreadable file is a one-line ConfigError."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the {what} ({exc.strerror})") from None
    if b"\0" in data[:4096]:
        raise ConfigError(f"{path}: a binary file, expected a {what} (text)")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(
            f"{path}: not UTF-8 text at byte {exc.start}, expected a {what}"
        ) from None


def read_json(path: str | Path, what: str) -> Any:
    """The parsed JSON of an input file: a bad file (binary, not UTF-8, invalid, nested too
    deeply for the parser) is a one-line ConfigError naming it."""
    text = read_text(path, what)
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ConfigError(
            f"{path}: invalid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}"
        ) from None
    except RecursionError:
        raise ConfigError(f"{path}: JSON nested too deeply to be a {what}") from None
