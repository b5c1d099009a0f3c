"""`genie dataset` of the work tree against that of a git revision, runs taking turns: each
run makes SCENES scenes of STRATEGY (the assembly line unless given; 40 cameras) with WORKERS
workers in a fresh
process, the revision's package (exported with ``git archive`` into a temporary folder)
and the work tree's alternating, the order flipping each round. A scene's stage time is the
sum of its stages in the run's manifest (``runs[-1].scene_s``, steady scenes: each worker's
first is left out); a scene index's time is its median over the rounds, and the ratio is
the median over scene indices of work tree / revision (the same scenes both sides: the
same seed makes the same scenes).

    python tools/pipeline_ab.py REV WORKERS ROUNDS [SCENES] [SENSOR] [STRATEGY]   # e.g. HEAD~1 1 8
"""

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def export(rev: str, where: Path) -> Path:
    """The package at ``rev`` in ``where`` (its numba caches are its own)."""
    where.mkdir(parents=True, exist_ok=True)
    tar = subprocess.run(
        [
            "git",
            "-C",
            str(ROOT),
            "archive",
            rev,
            "genie_gl",
            "layouts",
            "sensors",
            "shaders",
            "rigs",
        ],
        capture_output=True,
    )
    if tar.returncode:
        sys.exit(f"pipeline_ab.py: revision {rev!r}: {tar.stderr.decode().strip()}")
    subprocess.run(["tar", "-x", "-C", str(where)], input=tar.stdout, check=True)
    return where


def run(tree: Path, workers: int, scenes: int, sensor: str, strategy: str, out: Path) -> list[dict]:
    shutil.rmtree(out, ignore_errors=True)
    cmd = [
        sys.executable,
        "-m",
        "genie_gl.cli",
        "dataset",
        strategy,
        "--scenes",
        str(scenes),
        "--cameras",
        "40",
        "--sensor",
        sensor,
        "--workers",
        str(workers),
        "--previews",
        "0",
        "--no-progress",
        "--out",
        str(out),
    ]
    done = subprocess.run(
        cmd, cwd=tree, env=dict(os.environ, PYTHONPATH=str(tree)), capture_output=True, text=True
    )
    if done.returncode:
        sys.exit(f"pipeline_ab.py: {' '.join(cmd)} failed: {done.stderr.strip()[-400:]}")
    return [
        s
        for s in json.loads((out / "manifest.json").read_text())["runs"][-1]["scene_s"]
        if s["nth"]
    ]


def main() -> None:
    try:
        rev, workers, rounds = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
        scenes = int(sys.argv[4]) if len(sys.argv) > 4 else 8
    except (IndexError, ValueError):
        sys.exit(
            "usage: python tools/pipeline_ab.py REVISION WORKERS ROUNDS [SCENES] [SENSOR] "
            "[STRATEGY]   "
            "(e.g. HEAD~1 1 8)"
        )
    sensor = sys.argv[5] if len(sys.argv) > 5 else "ideal_pinhole"
    strategy = sys.argv[6] if len(sys.argv) > 6 else "assembly_line"
    with tempfile.TemporaryDirectory(prefix="pipeline-ab-") as tmp:
        trees = {rev: export(rev, Path(tmp) / "rev"), "work tree": ROOT}
        times: dict[str, dict[int, list[float]]] = {k: {} for k in trees}
        cpu: dict[str, list[float]] = {k: [] for k in trees}
        load = []
        for r in range(rounds):
            for name in list(trees) if r % 2 == 0 else list(trees)[::-1]:
                load.append(os.getloadavg()[0])
                for s in run(trees[name], workers, scenes, sensor, strategy, Path(tmp) / "out"):
                    times[name].setdefault(s["scene"], []).append(sum(s["stages"].values()))
                    cpu[name].append(s["cpu_s"])
    for name in trees:
        every = [x for v in times[name].values() for x in v]
        print(
            f"{name}: steady stage time {np.median(every):.3f} s a scene (IQR "
            f"{np.percentile(every, 25):.3f}-"
            f"{np.percentile(every, 75):.3f}, {len(every)} scenes), CPU {np.median(cpu[name]):.3f} "
            "s"
        )
    ratios = [
        np.median(times["work tree"][k]) / np.median(times[rev][k])
        for k in times[rev]
        if k in times["work tree"]
    ]
    print(
        f"{strategy}, {workers} worker(s), {sensor}, {rounds} rounds: work tree / {rev}, per scene "
        "index, median "
        f"{np.median(ratios):.3f} (range {min(ratios):.3f}-{max(ratios):.3f}); load average (1 "
        "min) at the runs' "
        f"starts {min(load):.1f}-{max(load):.1f}"
    )


if __name__ == "__main__":
    main()
