"""What each part of the fifth round gives a dataset scene, in one process, scenes in turns:

* shipped: frames handed over while the next rasterises, each frame's points per tile counted
  beside the capture (``FrameTally``), the 0.5 ms switch interval while it counts;
* 5 ms switch: the same with the interpreter's default switch interval;
* no tally: the counts made in the cloud stage;
* no tally, read then draw: also each frame unpacked before the next one is drawn (the order
  before the round, ``Renderer.frames`` rewritten here).

Each variant makes the same scenes (indices 0..S-1) after one warm-up, ROUNDS times, the
variants' order turning each scene; a variant's ratio is the median over scenes and rounds of
its scene's wall time over the last variant's. The culling's first kernel is timed around
its call in each variant (the wait for the GIL after it shows there).

    python docs/pipeline_parts.py [ROUNDS] [SCENES] [SENSOR] [STRATEGY]     # e.g. 3 6
"""
import importlib
import os
import shutil
import sys
import tempfile
import time

import numpy as np

from genie_gl.cloud import tally as tally_module
from genie_gl.dataset import scene as scene_module
from genie_gl.dataset.config import DatasetConfig
from genie_gl.dataset.recipe import load_inputs, make
from genie_gl.dataset.warmup import warm_up

renderer_module = importlib.import_module("genie_gl.render.renderer")
visibility = importlib.import_module("genie_gl.render.visibility")
Renderer = renderer_module.Renderer
shipped_frames = Renderer.frames


def read_then_draw(self, sensor, poses, *, depth_only=False, normals=False, only=None, triangles=False):
    """``Renderer.frames`` before the round: frame i read back and unpacked after frame i+1 is
    drawn, before the caller gets it."""
    pending = None
    for k, pose in enumerate(poses):
        with self._current():
            job = self._draw(sensor, pose, not depth_only, normals, None if only is None else only[k],
                             slot=1 + k % 2, triangles=triangles)
            self._flush()
            frame = self._read(pending) if pending is not None else None
        if frame is not None:
            yield frame
        pending = job
    if pending is not None:
        with self._current():
            frame = self._read(pending)
        yield frame


def no_tally(*args, **kw):
    return make(*args, **{**kw, "chunk_m": None})


VARIANTS = {  # name: (make, frames, switch interval while a tally counts)
    "shipped": (make, shipped_frames, tally_module.SWITCH_INTERVAL_S),
    "5 ms switch": (make, shipped_frames, 0.005),
    "no tally": (no_tally, shipped_frames, None),
    "no tally, read then draw": (no_tally, read_then_draw, None),
}


def main() -> None:
    try:
        rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 3
        scenes = int(sys.argv[2]) if len(sys.argv) > 2 else 6
    except ValueError:
        sys.exit("usage: python docs/pipeline_parts.py [ROUNDS] [SCENES] [SENSOR] [STRATEGY]   (e.g. 3 6)")
    sensor = sys.argv[3] if len(sys.argv) > 3 else "ideal_pinhole"
    strategy = sys.argv[4] if len(sys.argv) > 4 else "assembly_line"
    out = tempfile.mkdtemp(prefix="pipeline-parts-")
    compose, waits = visibility.compose, []

    def timed_compose(*a):
        t = time.perf_counter()
        compose(*a)
        waits.append(time.perf_counter() - t)

    visibility.compose = timed_compose
    try:
        cfg = DatasetConfig(strategy=strategy, out=out, scenes=scenes, cameras=40, sensor=sensor, previews=0)
        inputs = load_inputs(cfg)
        warm_up(cfg, inputs)
        names = list(VARIANTS)
        wall = {v: [] for v in names}
        cpu = {v: [] for v in names}
        culling = {v: [] for v in names}
        load = os.getloadavg()[0]
        for r in range(rounds):
            for i in range(scenes):
                k = (r * scenes + i) % len(names)
                for v in names[k:] + names[:k]:
                    recipe, frames, interval = VARIANTS[v]
                    scene_module.make, Renderer.frames = recipe, frames
                    tally_module.SWITCH_INTERVAL_S = interval or tally_module.SWITCH_INTERVAL_S
                    shutil.rmtree(out, ignore_errors=True)
                    waits.clear()
                    c, w = time.process_time(), time.perf_counter()
                    scene_module.run_scene(cfg, i, inputs=inputs)
                    wall[v].append(time.perf_counter() - w)
                    cpu[v].append(time.process_time() - c)
                    culling[v].append(float(np.mean(waits)) if waits else float("nan"))
                    tally_module.SWITCH_INTERVAL_S = VARIANTS["shipped"][2]
    finally:
        scene_module.make, Renderer.frames, visibility.compose = make, shipped_frames, compose
        shutil.rmtree(out, ignore_errors=True)
    base = np.array(wall[names[-1]])
    print(f"{strategy}, {sensor}, 40 cameras, {scenes} scenes x {rounds} rounds in one process; load average "
          f"{load:.1f} -> {os.getloadavg()[0]:.1f}")
    for v in names:
        a = np.array(wall[v])
        print(f"   {v:26s} wall {np.median(a):.3f} s  CPU {np.median(cpu[v]):.3f} s  / '{names[-1]}' "
              f"{np.median(a / base):.3f}  culling's first kernel {1e3 * np.nanmean(culling[v]):.3f} ms a frame")


if __name__ == "__main__":
    main()
