"""A one-frame capture of a matte convex sphere with the Azure Kinect profile (the planner
skips its multipath effect) against the same capture without that effect.

The calls take turns; CPU time of the process (all threads). ``fresh``: a new scene (new
meshes) per call, so the planner's first analysis of the mesh is included; ``same``: one scene
throughout::

    python -m benchmarks skip_cost fresh 40
    python -m benchmarks skip_cost same 40
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import trimesh

import genie_gl as gg
from genie_gl.resources import resolve
from genie_gl.scene.model import Material
from genie_gl.sensors.pose import look_at

from .common import header, parser


def run(fresh: bool = True, calls: int = 12) -> dict:
    """{"with_ms_cpu", "without_ms_cpu", "ratio"}: median CPU ms of a call with the skipped
    effect and without it, and their ratio."""
    azure = gg.load_sensor(resolve("azure_kinect_nfov", "sensors", (".yaml",)))
    without = dataclasses.replace(
        azure, effects=tuple(e for e in azure.effects if "multipath" not in e.name)
    )
    pose = look_at([0.0, 0.0, 2.0], [0.0, 0.0, 0.0], up=(0, 1, 0))
    ball = trimesh.creation.icosphere(subdivisions=4, radius=0.5)

    def scene() -> gg.Scene:
        s = gg.Scene()
        s.add(ball, np.eye(4), semantic=1, material=Material((0.5, 0.5, 0.5), 0.0, 0.9))
        return s

    shared = scene()
    for s in (azure, without):
        gg.capture(shared, s, [pose], seed=0)  # warm-up: imports, kernels, GL, shaders
    times: dict[str, list[float]] = {"with": [], "without": []}
    for k in range(calls):
        order = (
            (("with", azure), ("without", without))
            if k % 2
            else (("without", without), ("with", azure))
        )
        for name, s in order:
            sc = scene() if fresh else shared
            c = time.process_time()
            gg.capture(sc, s, [pose], seed=0)
            times[name].append(time.process_time() - c)
    w, wo = float(np.median(times["with"])), float(np.median(times["without"]))
    return {"with_ms_cpu": 1e3 * w, "without_ms_cpu": 1e3 * wo, "ratio": w / wo}


def main(argv: list[str]) -> None:
    p = parser("skip_cost", __doc__)
    p.add_argument("mode", nargs="?", default="fresh", choices=("fresh", "same"))
    p.add_argument("calls", nargs="?", type=int, default=12, help="calls of each (default 12)")
    a = p.parse_args(argv)
    print(header())
    r = run(a.mode == "fresh", a.calls)
    print(
        f"{'a new scene per call' if a.mode == 'fresh' else 'the same scene'}: with multipath "
        "(skipped) "
        f"{r['with_ms_cpu']:.1f} ms of CPU, without {r['without_ms_cpu']:.1f} ms: {r['ratio']:.3f}x"
    )
