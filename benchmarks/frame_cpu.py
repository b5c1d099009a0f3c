"""CPU of steady frames of a benchmark scene through ``Renderer.render``, and the culling
kernel's share.

Wrap it in ``perf record -g`` to split the rest (llvmpipe's threads, its set-up in the calling
thread, Python)::

    python -m benchmarks frame_cpu 1M 80
    perf record -F 1999 -g -o frame.data -- python -m benchmarks frame_cpu 1M 200
    perf report -i frame.data --no-children -g none --sort comm,dso
"""

from __future__ import annotations

import time

import numpy as np

from genie_gl.render import Renderer
from genie_gl.render.cull import TriangleCuller

from .common import benchmark_scene, header, parser, scene_argument, sensor_640


def run(scene_name: str = "1M", frames: int = 80) -> dict:
    """{"scene", "frames", "ms_cpu", "cull_ms_cpu", "cull_share", "drawn", "triangles"}: the mean
    CPU ms of a steady frame (depth and ids, all threads), the culling's share of it, and the
    mean triangles drawn of the scene's."""
    spec, scene = benchmark_scene(scene_name)
    sensor = sensor_640()
    cull: list[float] = []
    select = TriangleCuller.select

    def timed_select(self, *args, **kwargs):
        c = time.process_time()
        out = select(self, *args, **kwargs)
        cull.append(time.process_time() - c)
        return out

    TriangleCuller.select = timed_select
    try:
        r = Renderer(scene)
        for p in spec.poses[:4]:
            r.render(sensor, p, depth_only=True)  # warm-up
        cull.clear()
        drawn = []
        c = time.process_time()
        for k in range(frames):
            r.render(sensor, spec.poses[k % len(spec.poses)], depth_only=True)
            drawn.append(r.stats["triangles_drawn"])
        total = time.process_time() - c
        r.release()
    finally:
        TriangleCuller.select = select
    return {
        "scene": scene_name,
        "frames": frames,
        "ms_cpu": 1e3 * total / frames,
        "cull_ms_cpu": 1e3 * float(np.mean(cull)) if cull else 0.0,
        "cull_share": float(np.sum(cull) / total) if total > 0 else 0.0,
        "drawn": float(np.mean(drawn)),
        "triangles": spec.triangles,
    }


def main(argv: list[str]) -> None:
    p = parser("frame_cpu", __doc__)
    scene_argument(p, "1M")
    p.add_argument(
        "frames", nargs="?", type=int, default=80, help="steady frames timed (default 80)"
    )
    a = p.parse_args(argv)
    print(header())
    r = run(a.scene, a.frames)
    print(
        f"{r['scene']}: {r['ms_cpu']:.1f} ms of CPU per frame; culling {r['cull_ms_cpu']:.1f} ms "
        f"({100 * r['cull_share']:.0f} %); {r['drawn']:,.0f} of {r['triangles']:,} triangles drawn"
    )
