"""How a frame of the CPU rasteriser (``raster="cpu"``) shares its two threads: the
rasteriser's source with the processor's cycle counter read at the phase boundaries of the
frame kernel (loaded from a temporary file and put in place of the kernel), over a benchmark
scene's 40 poses: cycles of the cluster bounds (parallel), of the order and strip cut
(serial), of each thread's strip, and how much the slower strip takes over the mean of the two.

    python tools/raster_threads.py 1M
"""

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

CLOCK = """from numba import types as _types
from numba.core import cgutils as _cgutils
from numba.extending import intrinsic as _intrinsic
from llvmlite import ir as _ir


@_intrinsic
def _cycles(typingctx):
    def codegen(context, builder, signature, args):
        fn = _cgutils.get_or_insert_function(builder.module, _ir.FunctionType(_ir.IntType(64), []),
                                             "llvm.readcyclecounter")
        return builder.call(fn, [])
    return _types.int64(), codegen

"""
# (where, what to put before it): tally[0, 6] bounds, tally[0, 7] order and cut, tally[t, 4]
# thread t's strip (clear and draw)
MARKS = (
    ("    W = int(width)\n    H = int(height)\n", "    c0 = _cycles()\n"),
    ("    order = _nearest_first(alive, bounds, near)\n", "    c1 = _cycles()\n"),
    ("    tmin[:, :] = 0.0\n    buf = DepthBuffers(", "    c2 = _cycles()\n"),
    (
        "        # the strip's depth and ids at once",
        "        tally[t, 4] = _cycles() - s0\n",
    ),
)


def instrumented(where: Path):
    source = joined()
    for old, before in MARKS:
        assert source.count(old) == 1, old
        source = source.replace(old, before + old)
    old = "        col_lo, col_hi = float(cut[t]), float(cut[t + 1] - 1)\n"
    assert source.count(old) == 1
    source = source.replace(old, old + "        s0 = _cycles()\n")
    old = "    tally[:, :] = 0\n"
    assert source.count(old) == 1
    source = source.replace(old, old + "    tally[0, 6] = c1 - c0\n    tally[0, 7] = c2 - c1\n")
    head, sep, rest = source.partition("from __future__ import annotations\n")
    return load(head + sep + CLOCK + rest, where, "raster_threads_kernel")._raster


def main() -> None:
    size = sys.argv[1] if len(sys.argv) > 1 else "1M"
    spec = bench_spec(size)
    scene, poses, sensor = to_scene(spec), spec.poses, sensor_640()
    r = Renderer(scene, raster="cpu")
    kernel = raster._raster
    with tempfile.TemporaryDirectory() as tmp:
        raster._raster = instrumented(Path(tmp))
        try:
            numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
            r.render(sensor, poses[0], depth_only=True)  # compile
            print(
                f"scene {size}, {numba.get_num_threads()} threads, 640 x 480, depth and ids; per "
                "frame, "
                "millions of cycles, mean over the poses; three passes"
            )
            for _ in range(3):
                acc, slow, wall = np.zeros(4), 0.0, 0.0
                for p in poses:
                    t = time.perf_counter()
                    r.render(sensor, p, depth_only=True)
                    wall += time.perf_counter() - t
                    tl = r._rasteriser.tally
                    acc += [tl[0, 6], tl[0, 7], tl[0, 4], tl[1, 4]]
                    slow += max(tl[0, 4], tl[1, 4])
                a = acc / len(poses) / 1e6
                print(
                    f"  frame {1e3 * wall / len(poses):.1f} ms: bounds {a[0]:.2f}, order and cut "
                    f"{a[1]:.2f}, "
                    f"strips {a[2]:.1f} / {a[3]:.1f}; slower strip / mean "
                    f"{slow / len(poses) / 1e6 / ((a[2] + a[3]) / 2):.3f}"
                )
        finally:
            raster._raster = kernel


if __name__ == "__main__":
    main()
