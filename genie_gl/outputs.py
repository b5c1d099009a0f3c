"""The one rule for everything genie-gl writes: write only what you create.

Every command and API function that writes files goes through this module:

- **A folder** (``genie layout --out DIR``, ``genie capture``, ``genie dataset``, ``genie bench``,
  ``gg.export(cloud, DIR)``) is claimed with :func:`claim_folder` before any work. A folder that
  does not exist is made. A folder that exists may hold the user's own files: genie-gl writes
  its outputs beside them and never touches them. Its ``manifest.json`` records which entries
  genie-gl wrote (``"outputs"``); only those may be replaced or removed by a later run of the
  same command. An output name already taken by an entry genie-gl did not write, a
  ``manifest.json`` genie-gl did not write, or a folder written by another command, is refused
  in one line before anything is written.
- **A single file** (``genie scene --out S.usda``, ``write_usd``, ``Layout.to_json``, a
  calibration or accuracy file) is replaced only when it is one genie-gl wrote, recognised by
  its own stamp (:func:`check_replaceable`); otherwise the write is refused.
- Every file is written to a temporary name in its folder and renamed into place
  (:func:`atomic_write_bytes`), so nothing half-written is ever visible.
- A run that fails after it began writing removes what it wrote
  (:meth:`OutputFolder.abandoning`): the entries new since the claim and the files of an
  earlier run it replaced; a folder it made goes with them, one of the user's is left as it was.
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import tempfile
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from PIL import Image
from PIL.PngImagePlugin import PngInfo

from . import __version__
from .errors import ConfigError, os_error_message

MANIFEST = "manifest.json"
#: names a claimed folder always owns: its manifest and a dataset run's lock
_ALWAYS_OURS = frozenset({MANIFEST, ".genie-lock"})
#: the ``Software`` text of the PNG files genie-gl writes (how a later run knows them)
PNG_SOFTWARE = "genie-gl"

log = logging.getLogger(__name__)


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file in the same folder, then rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(
        f".{path.name}.{os.getpid()}.tmp"
    )  # one per writer: workers may write the same file
    with written(path, tmp):
        with open(tmp, "wb") as fh:
            fh.write(data)
        tmp.replace(path)
    return path


@contextmanager
def written(path: Path, tmp: Path) -> Iterator[None]:
    """Around the writing of ``tmp`` and its rename to ``path``: the temporary file is removed
    whatever happens, and a file-system error names ``path`` (a full disk raises OSError
    without a file name)."""
    try:
        yield
    except OSError as exc:
        if not exc.filename:
            raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from None
        raise
    finally:
        if tmp.exists():
            tmp.unlink()


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    return atomic_write_bytes(path, text.encode())


def _describe(path: Path) -> str:
    return "a folder" if path.is_dir() else "a file"


def check_replaceable(
    path: str | os.PathLike,
    is_ours: Callable[[Path], bool],
    *,
    what: str,
    option: str | None = None,
) -> Path:
    """Refuse (:class:`ConfigError`) to write ``path`` when it exists and is not a file genie-gl
    wrote, as told by ``is_ours(path)`` (a stamp the writer puts in every file it writes).

    ``what`` names the file's kind for the message ("USD scene"); ``option`` the CLI option
    that named it, if any. A path the file system refuses outright (a name too long, a
    folder that cannot be read) is refused in one line too.
    """
    try:
        return _check_replaceable(path, is_ours, what=what, option=option)
    except OSError as exc:
        raise ConfigError(f"{option + ' ' if option else ''}{os_error_message(exc)}") from None


def _check_replaceable(
    path: str | os.PathLike,
    is_ours: Callable[[Path], bool],
    *,
    what: str,
    option: str | None = None,
) -> Path:
    path = Path(path)
    where = f"{option} {path}" if option else str(path)
    if path.is_dir():
        raise ConfigError(f"{where}: is a folder; expected the name of a {what} file to write")
    if path.exists():
        try:
            ours = bool(is_ours(path))
        except Exception:  # an unreadable or foreign file is not ours
            ours = False
        if not ours:
            raise ConfigError(
                f"{where}: already exists and was not written by genie-gl; it is left as it is "
                f"(remove or rename it, or write the {what} elsewhere)"
            )
    _check_parent_writable(path.parent, where)
    return path


def _check_parent_writable(folder: Path, where: str) -> None:
    """Refuse when nothing can be created in ``folder`` (or its nearest existing parent): a
    real probe, since permission bits say nothing of read-only or virtual file systems."""
    for p in (folder, *folder.parents):
        if (
            p.is_symlink() and not p.exists()
        ):  # dangling, or a loop: mkdir would say only "File exists"
            raise ConfigError(
                f"{where}: {p} is a symbolic link that leads nowhere (to {os.readlink(p)!r}: "
                "missing, "
                "or a loop of links); point it at a folder or choose another"
            )
        if p.exists():
            if not p.is_dir():
                raise ConfigError(f"{where}: not writable ({p} is a file, not a folder)")
            try:
                fd, probe = tempfile.mkstemp(prefix=".genie-write-test-", dir=p)
                os.close(fd)
                os.unlink(probe)
            except OSError as exc:
                raise ConfigError(f"{where}: not writable ({p}: {exc.strerror})") from None
            return


def png_is_ours(path: Path) -> bool:
    """True when ``path`` is a PNG that genie-gl wrote (its ``Software`` text chunk)."""
    with Image.open(path) as img:
        return getattr(img, "text", {}).get("Software") == PNG_SOFTWARE


def png_info() -> Any:
    """The PNG text chunks genie-gl writes into its pictures (Pillow ``pnginfo=``)."""
    info = PngInfo()
    info.add_text("Software", PNG_SOFTWARE)
    return info


def save_png(image: Any, path: str | os.PathLike, *, option: str | None = None) -> Path:
    """Save a Pillow image as a stamped PNG, atomically, replacing only a PNG genie-gl wrote."""
    path = check_replaceable(path, png_is_ours, what="PNG picture", option=option)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.png")
    with written(path, tmp):
        image.save(tmp, format="PNG", pnginfo=png_info())
        tmp.replace(path)
    return path


def read_manifest(folder: Path) -> dict[str, Any] | None:
    """The genie-gl manifest of ``folder``; None when there is none. A ``manifest.json`` that
    genie-gl did not write raises :class:`ConfigError`."""
    path = folder / MANIFEST
    if not path.exists():
        return None
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        data = None
    if not isinstance(data, dict) or "genie_gl" not in data or "command" not in data:
        raise ConfigError(
            f"{folder}: holds a {MANIFEST} that genie-gl did not write; genie-gl needs that name "
            "for its own record and leaves yours as it is: choose another folder"
        )
    return data


@dataclass
class OutputFolder:
    """A folder claimed by one run of ``command`` (see the module's text).

    ``owned`` holds the top-level entries a previous run of the same command wrote (from its
    manifest), ``declared`` the names this run announced, ``before`` what the folder held
    when it was claimed (so that everything new this run makes is recorded as its own).
    """

    path: Path
    command: str
    option: str
    owned: frozenset[str]
    declared: frozenset[str]
    before: frozenset[str]
    previous: dict[str, Any] | None
    made: bool  # the folder did not exist before this run
    _reserved: bool = field(default=False, repr=False)
    #: the (inode, mtime) of each entry of ``before``: a file replaced since is this run's
    stamps: dict[str, tuple[int, int]] = field(default_factory=dict, repr=False)

    def owns(self, name: str) -> bool:
        """True when the top-level entry ``name`` is genie-gl's to replace or remove."""
        top = Path(name).parts[0]
        return (
            top in _ALWAYS_OURS
            or top in self.owned
            or top in self.declared
            or top not in self.before
        )

    def outputs(self) -> list[str]:
        """Every top-level entry this folder's runs of ``command`` wrote, as the manifest lists
        them."""
        now = {p.name for p in self.path.iterdir()} if self.path.is_dir() else set()
        new = now - self.before
        mine = (set(self.owned) | set(self.declared) | new) & now
        return sorted(mine - _ALWAYS_OURS)

    def reserve(self, record: dict[str, Any] | None = None) -> None:
        """Write a manifest naming the outputs this run is about to write (``"writing"``) before
        the first of them is written, so a run killed half-way leaves nothing a later run would
        take for the user's; ``"outputs"`` lists only the entries that exist."""
        self.path.mkdir(parents=True, exist_ok=True)
        data = dict(record or self.previous or {})
        data.pop("writing", None)
        data.update(
            {
                "genie_gl": __version__,
                "command": self.command,
                "outputs": self.outputs(),
                "writing": sorted(set(self.declared) - _ALWAYS_OURS),
            }
        )
        atomic_write_text(self.path / MANIFEST, json.dumps(data, indent=1))
        self._reserved = True

    def written(self) -> list[str]:
        """The top-level entries this run wrote: those new since the claim, and the files of
        genie-gl's (an earlier run's) replaced since; never the user's, nor the manifest."""
        if not self.path.is_dir():
            return []
        mine = []
        for p in self.path.iterdir():
            if p.name in _ALWAYS_OURS:
                continue
            if p.name not in self.before:
                mine.append(p.name)
            elif (
                self.owns(p.name)
                and p.is_file()
                and not p.is_symlink()
                and _stamp(p) != self.stamps.get(p.name)
            ):
                mine.append(p.name)
        return sorted(mine)

    @contextmanager
    def abandoning(self, keep: Iterable[str] = ()) -> Iterator[OutputFolder]:
        """Around a run's writing: on any failure (an interrupt too) remove what this run
        wrote (:meth:`written`) except the entries ``keep`` (finished work a later run resumes
        from; an empty folder of those goes too), leave the folder as :meth:`abandon` does, and
        re-raise."""
        try:
            yield self
        except BaseException:
            kept = {n for n in keep if not _empty_folder(self.path / n)}
            try:
                self.abandon([n for n in self.written() if n not in kept])
            except Exception as exc:  # the run's own error is the one to report
                log.warning(
                    "%s %s: could not remove this run's outputs: %s", self.option, self.path, exc
                )
            raise

    def abandon(self, remove: Iterable[str] = ()) -> None:
        """After a failed run: remove the entries ``remove`` (outputs this run began and left
        partial; only genie-gl's), then leave a manifest listing only what exists, as the last
        finished run wrote it; a folder this run made and left holding nothing is removed, and
        a folder of the user's left with nothing of genie-gl's loses the manifest this run
        wrote (it had none)."""
        for name in remove:
            if (self.path / name).exists() or (self.path / name).is_symlink():
                self.remove(name)
        if not self.path.is_dir():
            return
        left = {p.name for p in self.path.iterdir()} - _ALWAYS_OURS
        if self.made and not left:
            for name in _ALWAYS_OURS:
                if (self.path / name).is_file():
                    (self.path / name).unlink()
            try:
                self.path.rmdir()
            except OSError:  # something appeared meanwhile: leave it
                pass
            return
        if self.previous is None and not self.outputs():  # the folder as the user had it
            (self.path / MANIFEST).unlink(missing_ok=True)  # none was there: this run's
            return
        if self.previous is None and not self._reserved:
            return
        data = dict(self.previous or {})
        data.pop("writing", None)
        data.update({"genie_gl": __version__, "command": self.command, "outputs": self.outputs()})
        atomic_write_text(self.path / MANIFEST, json.dumps(data, indent=1))

    def finish(self, manifest: dict[str, Any]) -> Path:
        """Write ``manifest`` (plus ``genie_gl``, ``command`` and ``outputs``) atomically."""
        data = {"genie_gl": __version__, "command": self.command, **manifest}
        data.pop("writing", None)
        data["outputs"] = self.outputs()
        return atomic_write_text(self.path / MANIFEST, json.dumps(data, indent=1))

    def remove(self, name: str) -> None:
        """Remove the entry ``name`` (a file or a folder) if genie-gl wrote it; refuse otherwise."""
        if not self.owns(name):
            raise ConfigError(
                f"{self.option} {self.path}: will not remove {name!r}: genie-gl did not write it"
            )
        p = self.path / name
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p)
        elif p.exists() or p.is_symlink():
            p.unlink()


def claim_folder(
    path: str | os.PathLike,
    command: str,
    writes: Iterable[str] = (),
    *,
    option: str = "--out",
    reserve: bool = False,
) -> OutputFolder:
    """Claim ``path`` as the output folder of one run of ``command``, before any work.

    Parameters
    ----------
    path : the folder (made, with its parents, when missing).
    command : the writer's name, recorded in the manifest ("layout", "capture", "dataset", ...).
    writes : the top-level names this run will write (files or folders). A name held by an
        entry genie-gl did not write is refused here.
    option : the CLI option (or API argument) that named the folder, for messages.
    reserve : write the manifest at once (see :meth:`OutputFolder.reserve`).

    Raises
    ------
    ConfigError
        ``path`` is a file or unwritable; it holds a ``manifest.json`` genie-gl did not write or
        one of another command; a name this run must write is taken by the user's entry; the
        file system refuses the path outright (a name too long, ...).
    """
    try:
        return _claim_folder(path, command, writes, option=option, reserve=reserve)
    except OSError as exc:
        raise ConfigError(f"{option} {os_error_message(exc)}") from None


def _claim_folder(
    path: str | os.PathLike,
    command: str,
    writes: Iterable[str] = (),
    *,
    option: str = "--out",
    reserve: bool = False,
) -> OutputFolder:
    """The claim itself (:func:`claim_folder`)."""
    folder = Path(path)
    where = f"{option} {folder}"
    if folder.exists() and not folder.is_dir():
        raise ConfigError(f"{where}: is a file; expected a folder")
    made = not folder.exists()
    try:
        _check_parent_writable(folder, where)
    except OSError as exc:
        raise ConfigError(f"{where}: cannot be used ({exc.strerror})") from None
    before = frozenset(p.name for p in folder.iterdir()) if not made else frozenset()
    previous = None if made else read_manifest(folder)
    if previous is not None and previous.get("command") != command:
        raise ConfigError(
            f"{where}: holds the output of `genie {previous.get('command')}`; write the output of "
            f"`genie {command}` into another folder"
        )
    if previous is None:
        owned: frozenset[str] = frozenset()
    elif isinstance(previous.get("outputs"), list):  # and what a run stopped half-way was writing
        owned = frozenset(str(n) for n in previous["outputs"] + list(previous.get("writing") or []))
    else:  # a manifest of ours from before outputs were recorded: it vouches for the names we write
        owned = frozenset(n for n in writes if n in before)
    writes = list(writes)
    for n in writes:  # a name joined to the folder stays inside it
        if not str(n) or Path(n).is_absolute() or ".." in Path(n).parts:
            raise ConfigError(f"{where}: will not write {str(n)!r}: a name outside the folder")
    declared = frozenset(Path(n).parts[0] for n in writes)
    taken = sorted(n for n in declared if n in before and n not in owned and n not in _ALWAYS_OURS)
    if taken:
        shown = ", ".join(repr(n) for n in taken[:3]) + (
            f" and {len(taken) - 3} more" if len(taken) > 3 else ""
        )
        raise ConfigError(
            f"{where}: already holds {shown}, which genie-gl did not write; they are left as they "
            "are: choose another folder (or move them)"
        )
    out = OutputFolder(folder, command, option, owned, declared, before, previous, made)
    out.stamps = {n: _stamp(folder / n) for n in before}  # (0, 0): gone meanwhile
    if reserve:
        out.reserve()
    return out


def _empty_folder(path: Path) -> bool:
    return path.is_dir() and not path.is_symlink() and not any(path.iterdir())


def _stamp(path: Path) -> tuple[int, int]:
    """(inode, modification time in ns) of ``path`` itself: a file renamed into place or
    rewritten changes it."""
    try:
        st = path.lstat()
    except OSError:
        return 0, 0
    return st.st_ino, st.st_mtime_ns


# -- replacing a folder genie-gl wrote, keeping what the user put in it ---------------------------
def _inside(rel: str) -> bool:
    """True when ``rel`` names a path inside its folder (not absolute, no ``..``)."""
    p = Path(rel)
    return bool(rel) and not p.is_absolute() and ".." not in p.parts


def remove_files(folder: str | os.PathLike, rels: Iterable[str]) -> None:
    """Remove the files ``rels`` (paths relative to ``folder``, files genie-gl wrote there) and
    the folders that this leaves empty, ``folder`` included; anything else stays."""
    folder = Path(folder)
    for rel in sorted(set(rels)):
        p = folder / rel
        if not _inside(rel) or not (p.is_file() or p.is_symlink()):
            continue
        p.unlink()
        for parent in p.parents:
            if parent == folder.parent:
                break
            try:
                parent.rmdir()  # only when empty: a user's file keeps its folder
            except OSError:
                break


def publish_folder(
    tmp: str | os.PathLike,
    final: str | os.PathLike,
    *,
    previous: Iterable[str] | None = (),
    record: str | None = None,
) -> None:
    """Put the freshly written folder ``tmp`` in place as ``final``.

    A new ``final`` is ``tmp`` renamed. An existing one (an earlier run's) keeps what the user
    put in it: the files ``previous`` (relative paths genie-gl wrote there before) that ``tmp``
    does not hold are removed, ``tmp``'s files replace their namesakes, and nothing else is
    touched. ``record``: the name of the file that vouches for the folder's completeness; it
    is removed first and moved in last, so a run killed half-way leaves an incomplete folder,
    never one that passes for whole.
    """
    tmp, final = Path(tmp), Path(final)
    if not final.exists() and not final.is_symlink():
        tmp.replace(final)
        return
    if final.is_symlink() or not final.is_dir():
        raise ConfigError(
            f"{final}: expected a folder genie-gl wrote; it is left as it is (move it away)"
        )
    new = sorted(
        p.relative_to(tmp).as_posix() for p in tmp.rglob("*") if p.is_file() or p.is_symlink()
    )
    if record is not None and ((final / record).is_file() or (final / record).is_symlink()):
        (final / record).unlink()
    stale = [rel for rel in previous or () if rel not in set(new)]
    for rel in stale:  # emptied folders of ours go, the folder itself stays
        p = final / rel
        if _inside(rel) and (p.is_file() or p.is_symlink()):
            p.unlink()
            for parent in p.parents:
                if parent == final:
                    break
                try:
                    parent.rmdir()
                except OSError:
                    break
    for rel in [r for r in new if r != record] + ([record] if record in new else []):
        dst = final / rel
        dst.parent.mkdir(parents=True, exist_ok=True)
        if dst.is_dir() and not dst.is_symlink():
            raise ConfigError(
                f"{dst}: a folder where genie-gl writes a file; it is left as it is (move it away)"
            )
        os.replace(tmp / rel, dst)
    shutil.rmtree(tmp)  # empty folders only, now
