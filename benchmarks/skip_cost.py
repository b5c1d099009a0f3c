"""A one-frame capture of a matte convex sphere with the Azure Kinect profile (the planner
skips its multipath effect) against the same capture without that effect; the calls take
turns, CPU time of the process (all threads). ``fresh``: a new scene (new meshes) per call,
so the planner's first analysis of the mesh is included; ``same``: one scene throughout.

    python docs/skip_cost.py fresh|same [calls]
"""
import dataclasses
import sys
import time

import numpy as np
import trimesh

import genie_gl as gg
from genie_gl.render.projection import look_at
from genie_gl.resources import resolve
from genie_gl.scene.model import Material

azure = gg.load_sensor(resolve("azure_kinect_nfov", "sensors", (".yaml",)))
without = dataclasses.replace(azure, effects=tuple(e for e in azure.effects if "multipath" not in e.name))
pose = look_at([0.0, 0.0, 2.0], [0.0, 0.0, 0.0], up=(0, 1, 0))
ball = trimesh.creation.icosphere(subdivisions=4, radius=0.5)


def scene():
    s = gg.Scene()
    s.add(ball, np.eye(4), semantic=1, material=Material((0.5, 0.5, 0.5), 0.0, 0.9))
    return s


fresh = (sys.argv[1] if len(sys.argv) > 1 else "fresh") == "fresh"
calls = int(sys.argv[2]) if len(sys.argv) > 2 else 12
shared = scene()
for s in (azure, without):
    gg.capture(shared, s, [pose], seed=0)   # warm-up: imports, kernels, GL, shaders
times = {"with": [], "without": []}
for k in range(calls):
    order = (("with", azure), ("without", without)) if k % 2 else (("without", without), ("with", azure))
    for name, s in order:
        sc = scene() if fresh else shared
        c = time.process_time()
        gg.capture(sc, s, [pose], seed=0)
        times[name].append(time.process_time() - c)
w, wo = np.median(times["with"]), np.median(times["without"])
print(f"{'a new scene per call' if fresh else 'the same scene'}: with multipath (skipped) {1e3 * w:.1f} ms of CPU, "
      f"without {1e3 * wo:.1f} ms: {w / wo:.3f}x")
