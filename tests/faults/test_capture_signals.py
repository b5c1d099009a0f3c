"""Ctrl-C (SIGINT to the whole process group, as a terminal sends it) while ``genie capture``
starts its worker processes: "interrupted" in one line, no worker's traceback after it, no
process left behind."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh

import genie_gl as gg

from .common import _env, fault
from .test_processes import children

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("scene")
    s = gg.Scene()
    s.add(trimesh.creation.box((4, 4, 1)), [0, 0, 0.5], semantic=2)
    s.add(trimesh.creation.box((20, 20, 0.02)), np.eye(4), semantic=0)
    return gg.write_usd(s, d / "s.usda")


def workers(pid: int) -> list[int]:
    """The leader's children that multiprocessing started (its resource tracker, its workers)."""
    out = []
    for c in children(pid):
        try:
            if b"multiprocessing" in Path(f"/proc/{c}/cmdline").read_bytes():
                out.append(c)
        except OSError:
            continue
    return out


def group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    return True


SLOW = pytest.mark.slow


@fault("signal", "traceback")
@pytest.mark.parametrize(
    "delay_s",
    [
        0.02,
        0.3,
        1.0,
        pytest.param(0.0, marks=SLOW),
        pytest.param(0.05, marks=SLOW),
        pytest.param(0.6, marks=SLOW),
    ],
)
def test_ctrl_c_while_capture_starts_its_workers(tmp_path, scene_file, delay_s):
    """The signal goes ``delay_s`` after the leader's first multiprocessing child appears: the
    workers are being spawned, unpickling their start-up data or loading their imports (a
    leader without the fix failed at 0.05, 0.2-0.45 and 0.9-1.6 s in one run of twelve delays,
    passed at 0, 0.02, 0.1 and 0.6 s: the window moves with the machine's load)."""
    cmd = [
        sys.executable,
        "-m",
        "genie_gl.cli",
        "capture",
        str(scene_file),
        "--cameras",
        "4",
        "--sensor",
        "ideal_pinhole",
        "--out",
        str(tmp_path / "o"),
        "--no-progress",
    ]
    p = subprocess.Popen(
        cmd,
        env=_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    t0 = time.monotonic()
    while not workers(p.pid) and p.poll() is None and time.monotonic() - t0 < 120:
        time.sleep(0.005)
    assert p.poll() is None, "the capture ended before it started a worker"
    time.sleep(delay_s)
    os.killpg(p.pid, signal.SIGINT)
    try:
        out, err = p.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        raise
    deadline = time.monotonic() + 10
    while group_alive(p.pid) and time.monotonic() < deadline:  # workers end with their leader
        time.sleep(0.05)
    left = group_alive(p.pid)
    if left:
        os.killpg(p.pid, signal.SIGKILL)
    assert "Traceback" not in err and "Error" not in err, err[-3000:]
    assert p.returncode == 128 + signal.SIGINT, (p.returncode, err[-2000:])
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert lines[-1].startswith("genie capture: interrupted; its workers are stopped"), lines[-3:]
    assert "resumes" not in lines[-1]
    assert not left, "a process of the capture outlived it"
