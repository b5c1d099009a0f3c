"""The CPU raster's frame against a variant of its own source, side by side in one process:
the modules of ``render/cpu/`` as one (:mod:`kernel_source`) loaded twice from temporary
files, once as they are and once with the replacements of a Python file (``REPL``: a list of
(old, new) pairs, each old text found exactly once), each drawing a benchmark scene's 40
poses in turns, pose by pose, the order flipping each round; a pose's time is its least over
the rounds (CPU time on one thread, wall time on more); the ratio is of the sums.

    python tools/raster_variant.py 100k 3 change.py            # scene, rounds, replacements
    python tools/raster_variant.py lens100k 3 change.py 1 flip # through the tutorial lens,
                                                               # one thread, variant loaded last

``lensSCENE``: the frames through the OpenCV tutorial lens of ``benchmarks/lens_ids.py``.
Unlike ``raster_ab.py``, both copies come from the work tree (no revision's files, whose
imports outside ``render/cpu/`` may not match); ``flip`` loads the variant second, to see
what the load order alone does (an empty ``REPL`` gives that, too).
"""

import runpy
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
from kernel_source import joined, load

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    try:
        size, rounds, repl_file = sys.argv[1], int(sys.argv[2]), sys.argv[3]
        threads = int(sys.argv[4]) if len(sys.argv) > 4 else 1
    except (IndexError, ValueError):
        sys.exit(
            "usage: python tools/raster_variant.py SCENE ROUNDS REPLACEMENTS.py [THREADS] [flip]"
        )
    flip = len(sys.argv) > 5 and sys.argv[5] == "flip"
    lens = size.startswith("lens")
    spec = bench_spec(size[4:] if lens else size)
    scene, poses, sensor = to_scene(spec), spec.poses, sensor_640()
    if lens:
        sys.path.insert(0, str(ROOT))
        from benchmarks.lens_frame import LENS
        from benchmarks.lens_ids import LENSES

        sensor = LENSES[LENS]
    K, W, H, near = sensor.K, sensor.width, sensor.height, float(sensor.clip_near_m)
    source = variant = joined()
    for old, new in runpy.run_path(repl_file)["REPL"]:
        if variant.count(old) != 1:
            sys.exit(f"raster_variant.py: {repl_file}: found {variant.count(old)} times: {old!r}")
        variant = variant.replace(old, new)
    numba.set_num_threads(threads)
    clock = time.process_time if threads == 1 else time.perf_counter
    r = Renderer(scene, raster="cpu")
    own = raster._raster

    def frame(pose):
        if lens:
            r.render(sensor, pose, depth_only=True)
            return
        seen = r._visible(pose, K, W, H, near, None)
        cfm, slots, m, bc, eye = seen[:5]
        r._rasteriser.draw(slots, m, bc, cfm, eye, r._det[slots], K, W, H, near, seen.planes)

    with tempfile.TemporaryDirectory() as tmp:
        texts = [("variant", variant, "rv_var"), ("work tree", source, "rv_own")]
        kernels = [(name, load(text, Path(tmp), mod)._raster) for name, text, mod in texts]
        if flip:
            kernels.reverse()
        best = {name: np.full(len(poses), np.inf) for name, _ in kernels}
        try:
            for _, f in kernels:  # compile
                raster._raster = f
                frame(poses[0])
            for k in range(rounds):
                for i, p in enumerate(poses):
                    for name, f in kernels if k % 2 else kernels[::-1]:
                        raster._raster = f
                        t = clock()
                        frame(p)
                        best[name][i] = min(best[name][i], clock() - t)
        finally:
            raster._raster = own
    a, b = (1e3 * best[name].mean() for name in ("variant", "work tree"))
    print(
        f"{size}, {threads} thread(s), {rounds} rounds: variant {a:.2f} ms, work tree {b:.2f} ms "
        f"a frame; variant / work tree {a / b:.3f}"
    )


if __name__ == "__main__":
    main()
