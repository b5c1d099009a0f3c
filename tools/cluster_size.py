"""The CPU raster's frame against the size of the scene's clusters (faces per cluster,
:data:`genie_gl.render.clusters.CLUSTER`): per scene and size a fresh process (its own numba
cache, so every kernel compiles with that size) draws the benchmark scene's 40 poses twice
on one thread (CPU ms a frame); sizes take turns in each round; medians over the rounds.

    python tools/cluster_size.py hall,10M,1M,100k 128,256,512 2
    python tools/cluster_size.py dataset,lens100k 128,512 4   # a dataset scene; a lens

``lensSCENE``: the frames through the OpenCV tutorial lens of ``benchmarks/lens_ids.py``.
The size must be a multiple of 64 (the GL culler keeps a bit a face in 64-bit words). The
first round compiles every kernel once per size (a minute or two each).
"""

import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

CHILD = """
import sys, time
sys.path[:0] = [{tools!r}, {root!r}]
import numba
from genie_gl.render import clusters, cull
from genie_gl.render.cpu import coverage, raster
# every module that took the size at import, before any kernel compiles (fresh cache)
for mod in (clusters, cull, coverage, raster):
    mod.CLUSTER = {size}
cull._MASK_WORDS = {size} // 64
from genie_gl.bench.render import sensor_640
from genie_gl.bench.scenes import bench_spec, to_scene
from genie_gl.render import Renderer
what = {scene!r}
numba.set_num_threads(1)
if what == "dataset":
    import genie_gl as gg
    from raster_profile import dataset_scene
    scene, poses = dataset_scene()
    sensor = gg.load_sensor("ideal_pinhole")
elif what.startswith("lens"):
    from benchmarks.lens_frame import LENS
    from benchmarks.lens_ids import LENSES
    spec = bench_spec(what[4:])
    scene, poses, sensor = to_scene(spec), spec.poses, LENSES[LENS]
else:
    spec = bench_spec(what)
    scene, poses, sensor = to_scene(spec), spec.poses, sensor_640()
r = Renderer(scene, raster="cpu")
r.render(sensor, poses[0], depth_only=True)
t = time.process_time()
for _ in range(2):
    for p in poses:
        r.render(sensor, p, depth_only=True)
print(1e3 * (time.process_time() - t) / (2 * len(poses)))
"""


def main() -> None:
    try:
        scenes, sizes = sys.argv[1].split(","), [int(s) for s in sys.argv[2].split(",")]
        rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 2
    except (IndexError, ValueError):
        sys.exit("usage: python tools/cluster_size.py SCENES SIZES [ROUNDS]  (e.g. hall 128,512 2)")
    if any(s % 64 for s in sizes):
        sys.exit("cluster_size.py: every size must be a multiple of 64")
    got: dict[tuple[str, int], list[float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for scene in scenes:
            for _ in range(rounds):
                for size in sizes:
                    code = CHILD.format(
                        tools=str(ROOT / "tools"), root=str(ROOT), size=size, scene=scene
                    )
                    env = {**os.environ, "NUMBA_CACHE_DIR": f"{tmp}/c{size}"}
                    out = subprocess.run(
                        [sys.executable, "-c", code], env=env, capture_output=True, text=True
                    )
                    if out.returncode:
                        sys.exit(out.stderr[-2000:])
                    got.setdefault((scene, size), []).append(float(out.stdout.split()[-1]))
    for scene in scenes:
        base = statistics.median(got[(scene, sizes[0])])
        row = ", ".join(
            f"{s}: {statistics.median(got[(scene, s)]):.2f} ms "
            f"({statistics.median(got[(scene, s)]) / base:.2f}x)"
            for s in sizes
        )
        print(f"{scene}, one thread, median of {rounds}: {row}")


if __name__ == "__main__":
    main()
