"""The least CPU time (of several repeats) per scene of the parts of a dataset scene that the
pipeline work changed: building the scene (``build_scene``), the capture planner (``plan`` of
40 poses) and the cloud stage (``frame_chunks`` and the class tally, on one scene's 40
frames). Six assembly-line scenes, ideal pinhole; run it once per version to compare, the
versions taking turns (the least of repeats is what a loaded machine blurs least).

    python docs/stage_parts.py
"""
import os
import time

import numpy as np

import genie_gl as gg
from genie_gl.capture.planner import plan
from genie_gl.cloud.process import frame_chunks, keep_cloud
from genie_gl.dataset.streams import SceneStreams
from genie_gl.layout.engine import generate_layout
from genie_gl.layout.strategy import load_strategy

sensor = gg.load_sensor("ideal_pinhole")
layouts = [generate_layout(load_strategy("assembly_line"), rng=SceneStreams(0, i).rng("layout")) for i in range(6)]


def least(fn, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        c = time.process_time()
        fn()
        best = min(best, time.process_time() - c)
    return best


for lay in layouts:  # every variant's mesh made once, as a worker's first scene makes them
    gg.build_scene(lay, rng=SceneStreams(0, 0).rng("scene"))
build = np.mean([least(lambda: gg.build_scene(lay, rng=SceneStreams(0, i).rng("scene")), 7) for i, lay in enumerate(layouts)])
scenes = [gg.build_scene(lay, rng=SceneStreams(0, i).rng("scene")) for i, lay in enumerate(layouts)]
poses = [gg.place_sensors(lay, sensor, n=40, seed=i) for i, lay in enumerate(layouts)]
planning = np.mean([least(lambda: plan(s, sensor, p), 7) for s, p in zip(scenes, poses)])
frames = gg.capture(scenes[1], sensor, poses[1], seed=1, depth_only=True)


def cloud() -> None:
    tiles, _ = frame_chunks(frames, 12.0, max_points=25000, rng=np.random.default_rng(5))
    counts = np.zeros(65536, np.int64)
    for _, tile in tiles:
        if keep_cloud(tile, min_points=2000, min_labelled_share=0.05)[0]:
            counts += np.bincount(tile.semantic, minlength=len(counts))


print(f"load average (1 min) {os.getloadavg()[0]:.1f}; least CPU s per scene: build_scene {build:.4f}, "
      f"plan {planning:.4f}, cloud {least(cloud, 9):.4f}")
