"""The least CPU time (of several repeats) per scene of three parts of a dataset scene:
building the scene (``build_scene``), the capture planner (``plan`` of the poses) and the
cloud stage (``frame_chunks`` and the class tally, on one scene's frames).

Assembly-line scenes, ideal pinhole; the least of repeats is what a loaded machine blurs
least. Run it once per version to compare, the versions taking turns::

    python -m benchmarks stage_parts          # six scenes of 40 cameras
"""

from __future__ import annotations

import time

import numpy as np

import genie_gl as gg
from genie_gl.capture.planner import plan
from genie_gl.cloud.process import frame_chunks, keep_cloud
from genie_gl.dataset.streams import SceneStreams
from genie_gl.layout.engine import generate_layout
from genie_gl.layout.strategy import load_strategy

from .common import header, parser


def least(fn, repeats: int) -> float:
    """The least CPU seconds of ``repeats`` calls of ``fn``."""
    best = np.inf
    for _ in range(repeats):
        c = time.process_time()
        fn()
        best = min(best, time.process_time() - c)
    return best


def run(scenes: int = 6, cameras: int = 40, repeats: int = 7) -> dict[str, float]:
    """{"build_scene", "plan", "cloud"}: least CPU seconds per scene, the mean over the scenes."""
    sensor = gg.load_sensor("ideal_pinhole")
    layouts = [
        generate_layout(load_strategy("assembly_line"), rng=SceneStreams(0, i).rng("layout"))
        for i in range(scenes)
    ]
    for lay in layouts:  # every variant's mesh made once, as a worker's first scene makes them
        gg.build_scene(lay, rng=SceneStreams(0, 0).rng("scene"))
    build = np.mean(
        [
            least(lambda: gg.build_scene(lay, rng=SceneStreams(0, i).rng("scene")), repeats)
            for i, lay in enumerate(layouts)
        ]
    )
    built = [
        gg.build_scene(lay, rng=SceneStreams(0, i).rng("scene")) for i, lay in enumerate(layouts)
    ]
    poses = [gg.place_sensors(lay, sensor, n=cameras, seed=i) for i, lay in enumerate(layouts)]
    planning = np.mean([least(lambda: plan(s, sensor, p), repeats) for s, p in zip(built, poses)])
    k = min(1, scenes - 1)
    frames = gg.capture(built[k], sensor, poses[k], seed=1, depth_only=True)

    def cloud() -> None:
        tiles, _ = frame_chunks(frames, 12.0, max_points=25000, rng=np.random.default_rng(5))
        counts = np.zeros(65536, np.int64)
        for _, tile in tiles:
            if keep_cloud(tile, min_points=2000, min_labelled_share=0.05)[0]:
                counts += np.bincount(tile.semantic, minlength=len(counts))

    return {
        "build_scene": float(build),
        "plan": float(planning),
        "cloud": least(cloud, repeats + 2),
    }


def main(argv: list[str]) -> None:
    p = parser("stage_parts", __doc__)
    p.add_argument("--scenes", type=int, default=6)
    p.add_argument("--cameras", type=int, default=40)
    p.add_argument("--repeats", type=int, default=7)
    a = p.parse_args(argv)
    print(header())
    r = run(a.scenes, a.cameras, a.repeats)
    print("least CPU s per scene: " + ", ".join(f"{k} {v:.4f}" for k, v in r.items()))
