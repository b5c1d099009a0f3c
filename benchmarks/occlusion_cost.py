"""Occlusion culling's cost and saving on a benchmark scene: two renderers in one process, one
occlusion-culling every frame, one never, taking turns frame by frame over the same poses
(CPU time of ``Renderer.render``, all threads); then the culler alone on the frames' inputs,
with and without occlusion; then one frame of a full-screen quad (llvmpipe's fixed cost).

    python docs/occlusion_cost.py 1M 24
"""
import sys
import time

import numpy as np
import trimesh

import genie_gl as gg
from genie_gl.bench.render import sensor_640
from genie_gl.bench.scenes import bench_spec, to_scene
from genie_gl.render import Renderer, create_context

name = sys.argv[1] if len(sys.argv) > 1 else "1M"
n = int(sys.argv[2]) if len(sys.argv) > 2 else 24
spec = bench_spec(name)
sensor = sensor_640()
scene = to_scene(spec)
gl = create_context()
renderers = {}
for on in (False, True):
    r = renderers[on] = Renderer(scene, context=gl)
    r.occlusion_min_faces = 0 if on else 1 << 62
    r._culler.break_even = 0.0   # occlusion-cull every frame (on), whatever it drops
    for p in spec.poses[:2]:
        r.render(sensor, p, depth_only=True)   # warm-up
cpu = {False: [], True: []}
drawn = {False: [], True: []}
inputs = []
select = renderers[True]._culler.select
renderers[True]._culler.select = lambda *a: (inputs.append(a), select(*a))[1]
for k in range(n):
    pose = spec.poses[k % len(spec.poses)]
    for on in ((False, True) if k % 2 else (True, False)):
        c = time.process_time()
        renderers[on].render(sensor, pose, depth_only=True)
        cpu[on].append(time.process_time() - c)
        drawn[on].append(renderers[on].stats["triangles_drawn"])
renderers[True]._culler.select = select
off, on = np.array(cpu[False]), np.array(cpu[True])
print(f"{name}: frame without occlusion {1e3 * np.median(off):.1f} ms, with {1e3 * np.median(on):.1f} ms of CPU "
      f"(median; with / without per pose, median {np.median(on / off):.2f}); triangles drawn "
      f"{np.mean(drawn[False]):,.0f} and {np.mean(drawn[True]):,.0f} (mean of {n} poses)")
culler = renderers[True]._culler
for flag in (False, True):
    tally = np.zeros(8)
    c = time.process_time()
    for args in inputs:
        culler.select(*args[:-1], flag)
        tally += culler.tally
    print(f"culler alone, occlusion {'on ' if flag else 'off'}: {1e3 * (time.process_time() - c) / len(inputs):.1f} ms "
          f"of CPU per frame" + (f"; per frame {tally[3] / len(inputs):,.0f} triangles tested, "
                                 f"{tally[5] / len(inputs):,.0f} dropped, {tally[6] / len(inputs):,.0f} written, "
                                 f"{tally[2] / len(inputs):,.0f} of {tally[0] / len(inputs):,.0f} clusters dropped"
                                 if flag else ""))
for r in renderers.values():
    r.release()
quad = gg.Scene()
wall = np.eye(4)
wall[2, 3] = 5.0
quad.add(trimesh.creation.box(extents=[100.0, 100.0, 0.1]), wall, semantic=1)
with Renderer(quad, context=gl) as r:
    for _ in range(3):
        r.render(sensor, np.eye(4), depth_only=True)
    c = time.process_time()
    for _ in range(20):
        r.render(sensor, np.eye(4), depth_only=True)
    print(f"a full-screen box (12 triangles): {1e3 * (time.process_time() - c) / 20:.1f} ms of CPU per frame")
gl.release()
