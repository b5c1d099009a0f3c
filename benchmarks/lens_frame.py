"""A frame through the OpenCV tutorial lens against the pinhole frame of the same K.

The plumb-bob lens of ``lens_ids`` (k1 = -0.42, 640 x 480) and the pinhole sensor of its K on
a benchmark scene's first poses, in turns, the best of ``rounds`` calls, ms a frame, and
their ratio, two ways: each through ``gg.capture`` (the default raster, exact ids through the
lens; a call builds its renderer and shades colour too), and frames of depth and ids alone
from one renderer of the default raster (``Renderer.frames``: the frame's own cost)::

    python -m benchmarks lens_frame [SCENE] [FRAMES] [ROUNDS]
"""

from __future__ import annotations

import time

import genie_gl as gg

from .common import benchmark_scene, header, parser
from .lens_ids import K, LENSES

LENS = "plumb-bob (k1 -0.42)"


def run(scene_name: str = "100k", frames: int = 10, rounds: int = 3) -> dict[str, float]:
    """{"pinhole_ms", "lens_ms", "ratio"}: ms a frame through ``gg.capture``, and
    {"pinhole_frames_ms", "lens_frames_ms", "frames_ratio"}: ms a frame of depth and ids from
    ``Renderer.frames``; best of ``rounds`` calls of ``frames`` poses each, the two sensors
    taking turns."""
    spec, scene = benchmark_scene(scene_name)
    poses = spec.poses[:frames]
    sensors = {"pinhole": gg.Sensor(640, 480, K), "lens": LENSES[LENS]}
    best = {f"{k}{way}_ms": float("inf") for way in ("", "_frames") for k in sensors}
    with gg.Renderer(scene, raster=None) as r:
        for s in sensors.values():  # compiled kernels and cached lens tables before the clock
            gg.capture(scene, s, poses[:1], seed=0)
            list(r.frames(s, poses[:2], depth_only=True))
        for _ in range(rounds):
            for key, s in sensors.items():
                t = time.perf_counter()
                gg.capture(scene, s, poses, seed=0)
                ms = 1e3 * (time.perf_counter() - t) / len(poses)
                best[f"{key}_ms"] = min(best[f"{key}_ms"], ms)
                t = time.perf_counter()
                for _ in r.frames(s, poses, depth_only=True):
                    pass
                ms = 1e3 * (time.perf_counter() - t) / len(poses)
                best[f"{key}_frames_ms"] = min(best[f"{key}_frames_ms"], ms)
    return {
        **best,
        "ratio": best["lens_ms"] / best["pinhole_ms"],
        "frames_ratio": best["lens_frames_ms"] / best["pinhole_frames_ms"],
    }


def main(argv: list[str]) -> None:
    p = parser("lens_frame", __doc__)
    p.add_argument("scene", nargs="?", default="100k")
    p.add_argument("frames", nargs="?", type=int, default=10)
    p.add_argument("rounds", nargs="?", type=int, default=3)
    a = p.parse_args(argv)
    print(header())
    r = run(a.scene, a.frames, a.rounds)
    print(
        f"{a.scene}: gg.capture: pinhole {r['pinhole_ms']:.1f} ms a frame, through the {LENS} "
        f"lens {r['lens_ms']:.1f} ms: {r['ratio']:.2f}x; frames of depth and ids: pinhole "
        f"{r['pinhole_frames_ms']:.1f} ms, lens {r['lens_frames_ms']:.1f} ms: "
        f"{r['frames_ratio']:.2f}x"
    )
