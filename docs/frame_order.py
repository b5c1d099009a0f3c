"""GL frames of a benchmark scene in the order `Renderer.frames` uses (frame i+1 planned, its
culling and draw buffers written, while frame i rasterises) against the fifth round's order
(frame i+1 planned after frame i's read-back), in one process, the two taking turns: ms a
frame, medians over the rounds, depth and ids, the ideal pinhole, the scene's 40 poses.

    python docs/frame_order.py [SCENE] [ROUNDS]   # e.g. 100k 8; SCENE: 100k, 1M, 10M, hall, generated
"""
import sys
import time

import numpy as np

import genie_gl as gg
from genie_gl.bench.scenes import bench_spec, to_scene
from genie_gl.render import Renderer


def planned_after_the_read(r: Renderer, sensor, poses):
    """The fifth round's order: plan and issue frame i+1 only once frame i is read back."""
    fetched = None
    for k, pose in enumerate(poses):
        with r._current():
            job = r._plan(sensor, pose, False, False, None, slot=1 + k % 2)
            r._issue(job)
            r._flush()
        if fetched is not None:
            yield r._finish(fetched)
        with r._current():
            r._fetch(job)
        fetched = job
    if fetched is not None:
        yield r._finish(fetched)


def main() -> None:
    name = sys.argv[1] if len(sys.argv) > 1 else "100k"
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 8
    spec = bench_spec(name)
    r = Renderer(to_scene(spec))
    sensor = gg.load_sensor("ideal_pinhole")
    poses = list(spec.poses)
    for _ in r.frames(sensor, poses[:4], depth_only=True):
        pass
    ms = {"shipped": [], "before": []}
    for k in range(rounds):
        for which in (("shipped", "before") if k % 2 == 0 else ("before", "shipped")):
            t = time.perf_counter()
            frames = r.frames(sensor, poses, depth_only=True) if which == "shipped" else \
                planned_after_the_read(r, sensor, poses)
            for _ in frames:
                pass
            ms[which].append(1e3 * (time.perf_counter() - t) / len(poses))
    a, b = float(np.median(ms["shipped"])), float(np.median(ms["before"]))
    print(f"{name}: planned while the frame before rasterises {a:.2f} ms a frame, planned after its read-back "
          f"{b:.2f} ms; {a / b:.3f} ({rounds} rounds)")


if __name__ == "__main__":
    main()
