"""Where a frame of the CPU rasteriser (``raster="cpu"``) goes: the kernel cut
short after each of its stages in turn, one thread, CPU per frame over a benchmark scene's
40 poses (best of ``repeats`` passes), and what each stage counts per frame.

    python tools/raster_profile.py 1M 3
    python tools/raster_profile.py dataset 3     # a dataset scene (assembly line) and its 40
    cameras

Each cut is the rasteriser's source (its modules as one, :mod:`kernel_source`) with one line
changed, loaded from a temporary file and put in place of the kernel; the differences between
successive cuts are the stages'
costs. Numba compiles each cut once (a minute or two on a first run).
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

CUTS = (
    (
        "clusters: sphere, cone and occlusion tests, set-up, clear",
        "    tally[0] += 1\n",
        "    tally[0] += 1\n    return\n",
    ),
    (
        "+ vertices: transform, window coordinates, cells",
        "    for i in range(nf):\n        f = np.uint64(f0 + i)\n",
        "    for i in range(0):\n        f = np.uint64(f0 + i)\n",
    ),
    (
        "+ faces: cell test, box, orientation, occlusion test; one-centre boxes tested at once",
        "        rows = (vhi - vlo) <= (uhi - ulo)\n",
        "        rows = (vhi - vlo) <= (uhi - ulo)\n        continue\n",
    ),
    (
        "+ edge set-up: edge functions, spans per line",
        "        for iw in range(int(w_lo), int(w_hi) + 1):",
        "        for iw in range(int(w_lo), int(w_lo)):",
    ),
    ("+ pixels: exact tests, depth, occlusion tiles (the whole kernel)", None, None),
)


def variant(source: str, old: str | None, new: str | None, where: Path, k: int):
    """The rasteriser module with ``old`` replaced by ``new``, loaded from ``where``."""
    if old is not None:
        assert source.count(old) == 1, old
        source = source.replace(old, new)
    return load(source, where, f"raster_cut{k}")


def dataset_scene():
    """Scene 1 of a ``genie dataset assembly_line`` run (seed 0) and its 40 placed cameras."""
    import genie_gl as gg
    from genie_gl.dataset.streams import SceneStreams
    from genie_gl.layout import generate_layout, load_strategy

    streams = SceneStreams(0, 1)
    layout = generate_layout(load_strategy("assembly_line"), rng=streams.rng("layout"))
    scene = gg.build_scene(layout, rng=streams.rng("scene"))
    return scene, gg.place_sensors(
        layout, gg.load_sensor("ideal_pinhole"), n=40, seed=streams.placement_seed
    )


def main() -> None:
    size = sys.argv[1] if len(sys.argv) > 1 else "1M"
    repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    if size == "dataset":
        scene, poses = dataset_scene()
    else:
        spec = bench_spec(size)
        scene, poses = to_scene(spec), spec.poses
    sensor = sensor_640()
    K, W, H, near = sensor.K, sensor.width, sensor.height, float(sensor.clip_near_m)
    source = joined()
    numba.set_num_threads(1)
    r = Renderer(scene, raster="cpu")
    kernel = raster._raster
    print(
        f"scene {size}: {r.triangles:,} triangles, 640 x 480, one thread, CPU ms per frame (best "
        f"of {repeats})"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for k, (label, old, new) in enumerate(CUTS):
            raster._raster = variant(source, old, new, Path(tmp), k)._raster if old else kernel
            seen = r._visible(poses[0], K, W, H, near, None)  # compile the cut as it is timed
            cfm, slots, m, bc, eye = seen[:5]
            r._rasteriser.draw(slots, m, bc, cfm, eye, r._det[slots], K, W, H, near, seen.planes)
            best, counts = np.inf, np.zeros(8)
            for _ in range(repeats):
                c = time.process_time()
                counts[:] = 0
                for p in poses:
                    seen = r._visible(p, K, W, H, near, None)
                    cfm, slots, m, bc, eye = seen[:5]
                    r._rasteriser.draw(
                        slots, m, bc, cfm, eye, r._det[slots], K, W, H, near, seen.planes
                    )
                    counts += r._rasteriser.counts
                best = min(best, (time.process_time() - c) / len(poses))
            print(f"  {1e3 * best:6.1f} ms  {label}")
    raster._raster = kernel
    c = counts / len(poses)
    print(
        f"per frame: {c[0]:,.0f} clusters drawn, {c[1]:,.0f} faces with a pixel box, {c[2]:,.0f} "
        "of them hidden, "
        f"{c[3]:,.0f} drawn, {c[4]:,.0f} pixel centres tested, {c[5]:,.0f} occlusion tiles "
        "refreshed"
    )


if __name__ == "__main__":
    main()
