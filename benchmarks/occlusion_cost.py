"""Occlusion culling's cost and saving on a benchmark scene: two renderers in one process, one
occlusion-culling every frame, one never, taking turns frame by frame over the same poses (CPU
time of ``Renderer.render``, all threads); then the culler alone on the frames' inputs, with
and without occlusion; then one frame of a full-screen box (llvmpipe's fixed cost)::

    python -m benchmarks occlusion_cost 1M 24
    python -m benchmarks occlusion_cost hall 12
"""

from __future__ import annotations

import time

import numpy as np
import trimesh

import genie_gl as gg
from genie_gl.render import Renderer, create_context

from .common import benchmark_scene, header, parser, scene_argument, sensor_640


def run(name: str = "1M", frames: int = 24, quad_frames: int = 20) -> dict:
    """{"off_ms", "on_ms", "ratio", "drawn_off", "drawn_on", "culler_off_ms", "culler_on_ms",
    "tested", "dropped", "written", "clusters_dropped", "clusters", "quad_ms"}: CPU ms per
    frame (medians), triangles drawn (means), the culler alone and its tallies per frame."""
    spec, scene = benchmark_scene(name)
    sensor = sensor_640()
    gl = create_context()
    out: dict = {}
    renderers = {}
    try:
        for on in (False, True):
            r = renderers[on] = Renderer(scene, context=gl)
            r.occlusion_min_faces = 0 if on else 1 << 62
            r._culler.break_even = 0.0  # occlusion-cull every frame (on), whatever it drops
            for p in spec.poses[:2]:
                r.render(sensor, p, depth_only=True)  # warm-up
        cpu: dict = {False: [], True: []}
        drawn: dict = {False: [], True: []}
        inputs = []
        select = renderers[True]._culler.select
        renderers[True]._culler.select = lambda *a: (inputs.append(a), select(*a))[1]
        for k in range(frames):
            pose = spec.poses[k % len(spec.poses)]
            for on in (False, True) if k % 2 else (True, False):
                c = time.process_time()
                renderers[on].render(sensor, pose, depth_only=True)
                cpu[on].append(time.process_time() - c)
                drawn[on].append(renderers[on].stats["triangles_drawn"])
        renderers[True]._culler.select = select
        off, on_ = np.array(cpu[False]), np.array(cpu[True])
        out.update(
            off_ms=1e3 * np.median(off),
            on_ms=1e3 * np.median(on_),
            ratio=float(np.median(on_ / off)),
            drawn_off=float(np.mean(drawn[False])),
            drawn_on=float(np.mean(drawn[True])),
        )
        culler = renderers[True]._culler
        for flag in (False, True):
            tally = np.zeros(8)
            c = time.process_time()
            for args in inputs:
                culler.select(*args[:-1], flag)
                tally += culler.tally
            out[f"culler_{'on' if flag else 'off'}_ms"] = (
                1e3 * (time.process_time() - c) / max(1, len(inputs))
            )
        n = max(1, len(inputs))
        out.update(
            tested=tally[3] / n,
            dropped=tally[5] / n,
            written=tally[6] / n,
            clusters_dropped=tally[2] / n,
            clusters=tally[0] / n,
        )
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
            for _ in range(quad_frames):
                r.render(sensor, np.eye(4), depth_only=True)
            out["quad_ms"] = 1e3 * (time.process_time() - c) / quad_frames
    finally:
        gl.release()
    return out


def main(argv: list[str]) -> None:
    p = parser("occlusion_cost", __doc__)
    scene_argument(p, "1M")
    p.add_argument("frames", nargs="?", type=int, default=24)
    a = p.parse_args(argv)
    print(header())
    r = run(a.scene, a.frames)
    print(
        f"{a.scene}: frame without occlusion {r['off_ms']:.1f} ms, with {r['on_ms']:.1f} ms of CPU "
        f"(median; with / without per pose, median {r['ratio']:.2f}); triangles drawn "
        f"{r['drawn_off']:,.0f} and {r['drawn_on']:,.0f} (mean of {a.frames} poses)"
    )
    print(f"culler alone, occlusion off: {r['culler_off_ms']:.1f} ms of CPU per frame")
    print(
        f"culler alone, occlusion on: {r['culler_on_ms']:.1f} ms of CPU per frame; per frame "
        f"{r['tested']:,.0f} triangles tested, {r['dropped']:,.0f} dropped, {r['written']:,.0f} "
        "written, "
        f"{r['clusters_dropped']:,.0f} of {r['clusters']:,.0f} clusters dropped"
    )
    print(f"a full-screen box (12 triangles): {r['quad_ms']:.1f} ms of CPU per frame")
