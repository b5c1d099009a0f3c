"""What lets a dataset run resume safely: the fingerprint of its inputs, the lock on its
output folder, and the record of each finished scene's files.

- Fingerprint: SHA-256 of the inputs that decide the bytes written (the strategy file and the
  asset files it names, the sensor profile and calibration files, the fingerprinted options of
  :class:`DatasetConfig` and the package version). A resume whose fingerprint differs is
  refused with one line naming what changed.
- Lock: ``DIR/.genie-lock``, held with ``flock`` while a run writes; the kernel releases it
  when the process ends, so a lock left by a crash is stale and taken over.
- Scene record: each scene's ``stats.json`` lists its files with size and SHA-256, written
  before the folder is renamed into place; a scene whose files are missing or of another size
  (``verify=True``: another hash) is made again.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import weakref
from pathlib import Path
from typing import Any

from .. import __version__
from ..errors import ConfigError
from .config import DatasetConfig
from .modes.base import get_mode, mode_options

LOCK = ".genie-lock"
RECORD = "stats.json"


def _file_hash(path: str | os.PathLike) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def input_files(strategy, sensor) -> dict[str, str]:
    """Role -> path of every input file whose content decides the output."""
    files = {"strategy": strategy.source}
    for cls, entries in sorted((strategy.scene.get("assets") or {}).items()):
        for k, e in enumerate(entries if isinstance(entries, list) else []):
            p = e if isinstance(e, str) else (e.get("path") if isinstance(e, dict) else None)
            if p:
                files[f"asset {cls}[{k}]"] = p
    for key, path in sensor.files.items():
        files[f"sensor {key}"] = str(path)
    return files


def fingerprint(cfg: DatasetConfig, strategy, sensor) -> dict[str, Any]:
    """{"sha256": ..., "parts": {name: value or file hash}} of a run's inputs."""
    parts: dict[str, Any] = {"genie_gl": __version__}
    for role, path in input_files(strategy, sensor).items():
        parts[role] = _file_hash(path) if Path(path).is_file() else f"missing: {path}"
    values = cfg.model_dump()  # plain values (the --accuracy record as its {"file", "settings"})
    mode, options = get_mode(cfg.capture), mode_options()
    for k in DatasetConfig.FINGERPRINTED:
        v = values[k]
        if (
            v is None
        ):  # an option not asked for (--class-balance, ...): the fingerprint of a run without it
            continue
        if k == "raster" and v == "gl":  # datasets made before the choice existed were drawn by GL
            continue
        if k == "capture" and not mode.fingerprints_mode:  # standing cameras: as before other modes
            continue
        if k in options and k not in mode.options:  # an option this capture does not use
            continue
        parts[k] = list(v) if isinstance(v, tuple) else v
    for role, path in mode.input_files(cfg).items():  # a rig's files, a waypoints file
        parts[role] = _file_hash(path)
    blob = json.dumps(parts, sort_keys=True).encode()
    return {"sha256": hashlib.sha256(blob).hexdigest(), "parts": parts}


def check_resume(out: Path, fp: dict[str, Any], scenes: int | None = None) -> dict[str, Any] | None:
    """The manifest of an earlier run in ``out`` when its inputs are ``fp``'s; None when there
    is none. A folder made from other inputs is refused (one line, naming what differs), and so
    is one made for more ``scenes`` than asked now (its extra scenes would stay, undescribed)."""
    path = out / "manifest.json"
    if not path.exists():
        return None
    try:
        old = json.loads(path.read_text())
        old_fp = old["fingerprint"]
    except (OSError, ValueError, KeyError, TypeError):
        raise ConfigError(
            f"--out {out}: manifest.json is not a genie-gl dataset manifest (or predates "
            "fingerprints); use another --out"
        ) from None
    if old_fp.get("sha256") == fp["sha256"]:
        before = (old.get("inputs") or {}).get("scenes")
        if scenes is not None and isinstance(before, int) and before > scenes:
            raise ConfigError(
                f"--out {out}: holds a dataset of {before} scenes; --scenes {scenes} would leave "
                "scenes "
                f"{scenes}..{before - 1} in it: give --scenes {before} (or more), or another --out"
            )
        return old
    if not old.get("runs") and not any(
        (out / str(name)).exists() for name in old.get("outputs") or []
    ):
        # an earlier attempt that was refused or stopped before it made anything: start afresh
        return None
    a, b = old_fp.get("parts", {}), fp["parts"]
    changed = [k for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]
    shown = ", ".join(
        f"{k} {a.get(k)!r:.20} -> {b.get(k)!r:.20}"
        if k in DatasetConfig.FINGERPRINTED or k == "genie_gl"
        else f"{k} (file content)"
        for k in changed[:4]
    )
    raise ConfigError(
        f"--out {out}: holds a dataset made from other inputs ({shown}); resume with the same "
        "inputs, or choose another --out"
    )


_HELD: "weakref.WeakSet[OutputLock]" = weakref.WeakSet()  # the locks this process holds


def _drop_held_in_child() -> None:
    """In a process forked from a lock holder (the scene helper of :mod:`.ahead`): close its
    copies of the held locks' files, so that the lock lives and dies with the run that took
    it (an flock belongs to the open file, which a fork shares; closing a copy, unlike
    unlocking it, leaves the parent's hold as it is)."""
    for lock in list(_HELD):
        if lock.fh is not None:
            lock.fh.close()
            lock.fh = None
    _HELD.clear()


os.register_at_fork(after_in_child=_drop_held_in_child)


class OutputLock:
    """Exclusive hold on an output folder for one run (``with OutputLock(out): ...``); a
    process forked meanwhile does not hold it."""

    def __init__(self, out: Path) -> None:
        self.path = Path(out) / LOCK
        self.fh = None

    def __enter__(self) -> "OutputLock":
        self.fh = open(self.path, "a+")
        try:
            fcntl.flock(self.fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self.fh.seek(0)
            who = self.fh.read().strip() or "another process"
            self.fh.close()
            self.fh = None
            raise ConfigError(
                f"--out {self.path.parent}: another genie dataset run ({who}) is writing there; "
                "wait for it, or choose another --out"
            ) from None
        self.fh.seek(0)
        self.fh.truncate()
        self.fh.write(f"pid {os.getpid()} on {os.uname().nodename}\n")
        self.fh.flush()
        _HELD.add(self)
        return self

    def __exit__(self, *exc) -> None:
        _HELD.discard(self)
        if self.fh is not None:
            try:
                self.path.unlink()
            except OSError:
                pass
            fcntl.flock(self.fh, fcntl.LOCK_UN)
            self.fh.close()
            self.fh = None


def record_files(folder: Path) -> dict[str, list]:
    """{relative path: [size, sha256]} of every file under ``folder`` (the record excepted)."""
    return {
        str(p.relative_to(folder)): [p.stat().st_size, _file_hash(p)]
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.name != RECORD
    }


def recorded_files(folder: Path) -> list[str]:
    """The files genie-gl wrote in scene ``folder``, as its record lists them (the record
    included); none when there is no readable record (then only the names a new run writes are
    replaced, and nothing is removed)."""
    try:
        files = json.loads((folder / RECORD).read_text())["files"]
        return [RECORD, *(str(k) for k in files)]
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return []


def scene_complete(folder: Path, *, verify: bool = False) -> dict[str, Any] | None:
    """The scene's record when every file it lists is there with its size (and hash when
    ``verify``); None when the scene must be made again."""
    try:
        stats = json.loads((folder / RECORD).read_text())
        files = stats["files"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    for rel, (size, digest) in files.items():
        p = folder / rel
        try:
            if p.stat().st_size != size or (verify and _file_hash(p) != digest):
                return None
        except OSError:
            return None
    return stats


def recorded_raster(out: Path) -> str | None:
    """The raster an earlier run in ``out`` drew with (its manifest's ``inputs.raster``; "gl"
    for a manifest written before the choice existed), or None when ``out`` holds no
    readable manifest."""
    try:
        old = json.loads((out / "manifest.json").read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(old, dict) or not isinstance(old.get("inputs"), dict):
        return None
    raster = old["inputs"].get("raster") or "gl"
    return raster if raster in ("cpu", "gl") else None
