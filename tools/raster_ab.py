"""The exact raster of the work tree against that of a git revision, side by side in one
process: both versions' kernels (``render/cpu/coverage.py`` and ``render/cpu/raster.py`` as one
module each, loaded from temporary files) draw a benchmark scene's 40 poses in turns, pose by
pose, the order flipping each round; a pose's time is its least over the rounds (process CPU
time with one thread, wall time with more), and the ratio is of the sums.

    python tools/raster_ab.py 1M 2 5 HEAD~1      # scene, threads, rounds, revision
"""

import importlib.util
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

from genie_gl.bench.render import sensor_640
from genie_gl.bench.scenes import bench_spec, to_scene
from genie_gl.render import Renderer
from genie_gl.render.cpu import raster

ROOT = Path(__file__).resolve().parent.parent


def kernel(coverage: str, frame: str, where: Path, name: str):
    """The frame kernel of one version (the two modules' sources) as a module of its own."""
    source = coverage + frame.replace("from __future__ import annotations\n", "")
    source = re.sub(r"^from \.coverage import .*\n", "", source, flags=re.M)
    for old, new in (
        ("from ..clusters", "from genie_gl.render.clusters"),
        ("from ..cull", "from genie_gl.render.cull"),
        ("from ..geometry", "from genie_gl.render.geometry"),
        ("from ...jit", "from genie_gl.jit"),
    ):
        source = source.replace(old, new)
    path = where / f"{name}.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod._raster


def at(rev: str, name: str) -> str:
    got = subprocess.run(
        ["git", "-C", str(ROOT), "show", f"{rev}:genie_gl/render/cpu/{name}"],
        capture_output=True,
        text=True,
    )
    if got.returncode:
        sys.exit(
            f"raster_ab.py: revision {rev!r}: no genie_gl/render/cpu/{name} there "
            f"({got.stderr.strip()})"
        )
    return got.stdout


def main() -> None:
    try:
        size, threads, rounds = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    except (IndexError, ValueError):
        sys.exit(
            "usage: python tools/raster_ab.py SCENE THREADS ROUNDS [REVISION]   (e.g. 1M 2 5 "
            "HEAD~1)"
        )
    rev = sys.argv[4] if len(sys.argv) > 4 else "HEAD"
    numba.set_num_threads(threads)
    clock = time.process_time if threads == 1 else time.perf_counter
    spec = bench_spec(size)
    poses, sensor = spec.poses, sensor_640()
    r = Renderer(to_scene(spec), raster="cpu")
    own = raster._raster
    with tempfile.TemporaryDirectory() as tmp:
        kernels = {
            rev: kernel(at(rev, "coverage.py"), at(rev, "raster.py"), Path(tmp), "ab_base"),
            "work tree": kernel(
                (ROOT / "genie_gl/render/cpu/coverage.py").read_text(),
                (ROOT / "genie_gl/render/cpu/raster.py").read_text(),
                Path(tmp),
                "ab_new",
            ),
        }
        best = {k: np.full(len(poses), np.inf) for k in kernels}
        try:
            for f in kernels.values():  # compile
                raster._raster = f
                r.render(sensor, poses[0], depth_only=True)
            for k in range(rounds):
                for i, p in enumerate(poses):
                    for name, f in kernels.items() if k % 2 else reversed(kernels.items()):
                        raster._raster = f
                        t = clock()
                        r.render(sensor, p, depth_only=True)
                        best[name][i] = min(best[name][i], clock() - t)
        finally:
            raster._raster = own
    base, new = (1e3 * best[k].mean() for k in kernels)
    print(
        f"{size}, {threads} thread(s), {rounds} rounds: {rev} {base:.2f} ms, work tree {new:.2f} "
        "ms a frame; "
        f"work tree / {rev} {new / base:.3f}"
    )


if __name__ == "__main__":
    main()
