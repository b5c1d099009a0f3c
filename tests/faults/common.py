"""What the fault-injection cases share: running a command in this process or in a child with
limits (time, memory, a tmpfs of its own), and the checks of an outcome: refused in one line,
no traceback, nothing of the user's touched.

Every case carries ``@pytest.mark.fault(kind, guard)``: ``kind`` is the input injected (bad
file, bad option, bad API call, kill, signal, full disk, read-only disk, huge input, a re-run
over its own output holding the user's files); ``guard`` the failure it would be if the code
regressed (loss, traceback, hang, wrong). The suite's
counts are printed at the end of the run (tests/conftest.py)."""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import resource
import shutil
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from genie_gl.cli import main

ROOT = Path(__file__).resolve().parent.parent.parent
KINDS = (
    "bad file",
    "bad option",
    "bad API call",
    "kill",
    "signal",
    "full disk",
    "read-only disk",
    "huge input",
    "re-run",
)
GUARDS = ("loss", "traceback", "hang", "wrong")


def fault(kind: str, guard: str):
    assert kind in KINDS and guard in GUARDS, (kind, guard)
    return pytest.mark.fault(kind=kind, guard=guard)


@dataclass
class Run:
    rc: int
    out: str
    err: str
    seconds: float = 0.0


class Hang(Exception):
    """A case ran past its time."""


@contextlib.contextmanager
def deadline(seconds: float):
    """Raise :class:`Hang` in this (main) thread after ``seconds``."""

    def fire(signum, frame):
        raise Hang(f"still running after {seconds} s")

    old = signal.signal(signal.SIGALRM, fire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def cli(*argv: str, timeout: float = 120) -> Run:
    """``genie ARGV`` in this process (an exception escaping it fails the case as a traceback)."""
    import time

    out, err = io.StringIO(), io.StringIO()
    t = time.perf_counter()
    with deadline(timeout), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main([str(a) for a in argv])
    return Run(rc, out.getvalue(), err.getvalue(), time.perf_counter() - t)


def _env() -> dict:
    return dict(os.environ, PYTHONPATH=str(ROOT), PYTHONUNBUFFERED="1")


def cli_proc(
    *argv: str, timeout: float = 120, memory_gb: float = 6.0, mounts: dict | None = None
) -> Run:
    """``genie ARGV`` in a child process with at most ``memory_gb`` of address space and
    ``timeout`` seconds; ``mounts`` {folder: "size=64k" or "ro"} are tmpfs mounted for the child
    alone (a user and mount namespace of its own: ``unshare -rm``)."""
    import time

    cmd = [sys.executable, "-m", "genie_gl.cli", *map(str, argv)]
    if mounts:
        script = " && ".join(
            f"mkdir -p {d} && mount -t tmpfs -o {o} tmpfs {d}" for d, o in mounts.items()
        )
        cmd = ["unshare", "-rm", "sh", "-c", f'{script} && exec "$0" "$@"', *cmd]

    def limits() -> None:
        lim = int(memory_gb * 2**30)
        resource.setrlimit(resource.RLIMIT_AS, (lim, lim))

    t = time.perf_counter()
    try:
        r = subprocess.run(
            cmd, capture_output=True, text=True, timeout=timeout, env=_env(), preexec_fn=limits
        )
    except subprocess.TimeoutExpired as exc:
        raise Hang(f"genie {' '.join(map(str, argv))}: still running after {timeout} s") from exc
    return Run(r.returncode, r.stdout, r.stderr, time.perf_counter() - t)


def namespaces_work() -> bool:
    """True when this machine lets a child mount a tmpfs of its own (unshare -rm)."""
    if not shutil.which("unshare"):
        return False
    r = subprocess.run(
        ["unshare", "-rm", "sh", "-c", "mount -t tmpfs -o size=4k tmpfs /mnt"], capture_output=True
    )
    return r.returncode == 0


def refused(run: Run, *needles: str) -> str:
    """The run exited 2 with exactly one line on stderr holding every needle; no traceback."""
    err = run.err.strip()
    assert "Traceback" not in run.err, run.err[-2000:]
    assert run.rc == 2, (run.rc, err[-2000:])
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err[-2000:]
    for n in needles:
        assert n in err, (n, err)
    return err


def plant(folder: Path) -> dict[str, str]:
    """The user's own files where a careless writer would touch them; their hashes."""
    files = {
        "notes.txt": b"my notes\n",
        "draft.tmp": b"not yours\n",
        ".hidden.tmp": b"mine",
        "scenes_of_mine/0000/cloud.ply": b"ply? no: mine",
        "work/deep/x.tmp": b"nested tmp, mine",
    }
    for rel, data in files.items():
        p = folder / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)
    return {rel: hashlib.sha256(data).hexdigest() for rel, data in files.items()}


def intact(folder: Path, planted: dict[str, str]) -> None:
    for rel, digest in planted.items():
        p = folder / rel
        assert p.is_file(), f"{rel} was removed"
        assert hashlib.sha256(p.read_bytes()).hexdigest() == digest, f"{rel} was changed"


def no_temporaries(folder: Path) -> None:
    """Nothing half-written left: no temporary file genie-gl names (``.NAME.PID.tmp*``)."""
    left = [str(p) for p in folder.rglob(".*.tmp*") if p.name != ".hidden.tmp"]
    left += [str(p) for p in folder.rglob(".tmp-*")]
    assert not left, left


def write_calibration(path, w, h):
    """An OpenCV calibration file of a w x h pinhole (fx = fy = w, no distortion) at ``path``."""
    import cv2
    import numpy as np

    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", w)
    fs.write("image_height", h)
    fs.write("camera_matrix", np.array([[w, 0, w / 2], [0, w, h / 2], [0, 0, 1]], np.float64))
    fs.write("distortion_coefficients", np.zeros((5, 1)))
    fs.release()
    return path
