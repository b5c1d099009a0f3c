"""Signals and kills of a run with workers: SIGTERM (or SIGINT) to the leader stops its workers
before the output folder's lock is released; SIGKILL of the leader takes its workers with it
(the kernel's parent-death signal); what was written whole is kept and a new run finishes."""

import fcntl
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from .common import ROOT, _env, fault

pytestmark = pytest.mark.gl
# four scenes for two workers: both are still at work once the first scene is whole (with two, the
# run could end between two looks at it, and the case fail on a healthy run)
ARGS = [
    "dataset",
    "assembly_line",
    "--scenes",
    "4",
    "--cameras",
    "2",
    "--sensor",
    "ideal_pinhole",
    "--points",
    "3000",
    "--min-points",
    "100",
    "--previews",
    "0",
    "--workers",
    "2",
    "--split",
    "1,0,0",
    "--no-progress",
]


def children(pid: int) -> list[int]:
    """The live processes whose parent is ``pid``."""
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            fields = stat.rsplit(")", 1)[1].split()
            if int(fields[1]) == pid and fields[0] != "Z":
                out.append(int(entry.name))
    return out


def alive(pids: list[int]) -> list[int]:
    left = []
    for p in pids:
        try:
            if (Path(f"/proc/{p}/stat").read_text().rsplit(")", 1)[1].split()[0]) != "Z":
                left.append(p)
        except OSError:
            pass
    return left


def lock_is_free(out: Path) -> bool:
    try:
        with open(out / ".genie-lock", "a+") as fh:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
            fcntl.flock(fh, fcntl.LOCK_UN)
        return True
    except FileNotFoundError:
        return True
    except OSError:
        return False


# a recording along a trajectory written as ROS 2 bags (a folder written whole, then moved in)
MOVING = [
    "dataset",
    "assembly_line",
    "--scenes",
    "2",
    "--capture",
    "trajectory",
    "--duration-s",
    "3",
    "--sensor",
    "ideal_pinhole",
    "--format",
    "rosbag",
    "--previews",
    "0",
    "--workers",
    "2",
    "--split",
    "1,0,0",
    "--no-progress",
]


def start(
    out: Path, writing: bool = True, args: list[str] = ARGS
) -> tuple[subprocess.Popen, list[int]]:
    """A --workers 2 run, once both workers are at work: writing a scene (``writing``), or
    started (warming up or rendering, for seconds yet)."""
    # SIGINT as a terminal sends it, even when the suite runs in the background (a shell starts
    # background jobs with SIGINT ignored, and Python then leaves it ignored)
    p = subprocess.Popen(
        [sys.executable, "-m", "genie_gl.cli", *args, "--out", str(out)],
        env=_env(),
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    t = time.time()
    while time.time() - t < 240:
        workers = [
            c
            for c in children(p.pid)
            if "spawn_main" in Path(f"/proc/{c}/cmdline").read_text(errors="ignore")
            and "resource_tracker" not in Path(f"/proc/{c}/cmdline").read_text(errors="ignore")
        ]
        if len(workers) >= 2 and (
            not writing or (out / "scenes").is_dir() and any((out / "scenes").iterdir())
        ):
            return p, workers
        if p.poll() is not None:
            raise AssertionError(f"the run ended early: {p.stderr.read()[-2000:]}")
        time.sleep(0.1)
    p.kill()
    raise AssertionError("the workers never started")


def finish(out: Path, args: list[str] = ARGS) -> None:
    r = subprocess.run(
        [sys.executable, "-m", "genie_gl.cli", *args, "--out", str(out)],
        env=_env(),
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    assert len(list((out / "scenes").glob("[0-9]*"))) == int(args[args.index("--scenes") + 1])


@fault("signal", "loss")
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_to_the_leader_stops_its_workers_before_the_lock_is_released(sig, tmp_path):
    out = tmp_path / "d"
    p, workers = start(out)
    assert not lock_is_free(out)
    p.send_signal(sig)
    while p.poll() is None:  # until the leader is gone: its lock must outlive every worker
        if lock_is_free(out):
            assert not alive(workers), f"lock released while workers {alive(workers)} still run"
        time.sleep(0.02)
    assert not alive(workers), f"workers {alive(workers)} outlived their leader"
    assert p.returncode == 128 + sig, p.stderr.read()[-2000:]
    err = p.stderr.read().strip().splitlines()
    assert err and "its workers are stopped" in err[-1], err[-3:]


@fault("kill", "loss")
def test_a_killed_leader_takes_its_workers_with_it(tmp_path):
    out = tmp_path / "d"
    p, workers = start(out)
    p.send_signal(signal.SIGKILL)
    p.wait(30)
    t = time.time()
    while (
        alive(workers) and time.time() - t < 1.0
    ):  # the kernel kills them with it (else: their scenes first)
        time.sleep(0.02)
    assert not alive(workers), f"workers {alive(workers)} outlived their killed leader"
    assert lock_is_free(out)
    finish(out)


@fault("signal", "loss")
def test_a_signal_to_a_recording_run_leaves_no_half_bag_and_it_resumes(tmp_path):
    """SIGTERM to a --capture trajectory --format rosbag run while its workers record: the
    workers stop with the leader, and the same command then finishes with two whole bags and no
    temporary folder left anywhere."""
    out = tmp_path / "d"
    p, workers = start(out, writing=False, args=MOVING)
    time.sleep(1.0)
    p.send_signal(signal.SIGTERM)
    p.wait(60)
    assert not alive(workers), f"workers {alive(workers)} outlived their leader"
    assert p.returncode == 128 + signal.SIGTERM, p.stderr.read()[-2000:]
    finish(out, MOVING)
    bags = sorted(out.glob("scenes/*/bag"))
    assert len(bags) == 2
    for bag in bags:
        assert sorted(x.name for x in bag.iterdir()) == ["bag.mcap", "metadata.yaml"]
    assert not [str(x) for x in out.rglob("*.tmp*")], "a temporary file or folder was left"
