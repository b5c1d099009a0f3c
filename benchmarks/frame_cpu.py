"""CPU of steady frames of a benchmark scene through ``Renderer.render``, and the culling
kernel's share. Wrap it in ``perf record -g`` to split the rest (llvmpipe's threads, its set-up
in the calling thread, Python):

    python docs/frame_profile.py 1M 80
    perf record -F 1999 -g -o frame.data -- python docs/frame_profile.py 1M 200
    perf report -i frame.data --no-children -g none --sort comm,dso
"""
import sys
import time

import numpy as np

from genie_gl.bench.render import sensor_640
from genie_gl.bench.scenes import bench_spec, to_scene
from genie_gl.render import Renderer
from genie_gl.render.cull import TriangleCuller

spec = bench_spec(sys.argv[1] if len(sys.argv) > 1 else "1M")
n = int(sys.argv[2]) if len(sys.argv) > 2 else 80
sensor = sensor_640()
cull: list[float] = []
select = TriangleCuller.select


def timed_select(self, *args, **kwargs):
    c = time.process_time()
    out = select(self, *args, **kwargs)
    cull.append(time.process_time() - c)
    return out


TriangleCuller.select = timed_select
with Renderer(to_scene(spec)) as r:
    for p in spec.poses[:4]:
        r.render(sensor, p, depth_only=True)   # warm-up
    cull.clear()
    drawn = []
    c = time.process_time()
    for k in range(n):
        r.render(sensor, spec.poses[k % len(spec.poses)], depth_only=True)
        drawn.append(r.stats["triangles_drawn"])
    total = time.process_time() - c
print(f"{spec.name}: {1e3 * total / n:.1f} ms of CPU per frame; culling {1e3 * np.mean(cull):.1f} ms "
      f"({100 * np.sum(cull) / total:.0f} %); {np.mean(drawn):,.0f} of {spec.triangles:,} triangles drawn")
