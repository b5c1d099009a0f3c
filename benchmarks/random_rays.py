"""``gg.cast_rays`` on random rays against Open3D's ``RaycastingScene.cast_rays``.

Origins uniform in a benchmark scene's box, directions normal (unit), the same float64 rays to
both; each caster's scene built once (not timed), then the rays cast in turns, best of
``rounds``. Agreement: the share of rays with the same instance (misses included) and the p99
relative distance difference where both hit::

    python -m benchmarks random_rays [SCENE] [RAYS] [ROUNDS]
"""

from __future__ import annotations

import time

import numpy as np

import genie_gl as gg
from genie_gl.bench.lidar import open3d_caster, open3d_cast

from .common import benchmark_scene, header, parser


def run(scene_name: str = "1M", rays: int = 1_000_000, rounds: int = 2, seed: int = 0) -> dict:
    """{"genie_gl_s", "open3d_s", "ratio" (Open3D's time over ours), "ids_agree",
    "range_rel_p99", "rays"}."""
    _, scene = benchmark_scene(scene_name)
    rng = np.random.default_rng(seed)
    lo, hi = scene.bounds()
    origins = lo + (hi - lo) * rng.random((rays, 3))
    dirs = rng.normal(size=(rays, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    gg.cast_rays(scene, origins[:1], dirs[:1])  # builds the hierarchy once
    caster = open3d_caster(scene)
    best_ours = best_o3d = np.inf
    for _ in range(rounds):
        t = time.perf_counter()
        ours = gg.cast_rays(scene, origins, dirs)
        best_ours = min(best_ours, time.perf_counter() - t)
        t = time.perf_counter()
        theirs = open3d_cast(caster, origins, dirs)
        best_o3d = min(best_o3d, time.perf_counter() - t)
    t_dist, t_ids = theirs
    both = ours.hit & (t_dist > 0)
    rel = np.abs(ours.distance[both] - t_dist[both]) / ours.distance[both]
    return {
        "rays": rays,
        "genie_gl_s": best_ours,
        "open3d_s": best_o3d,
        "ratio": best_o3d / best_ours,
        "ids_agree": float(np.mean(ours.instance == t_ids)),
        "range_rel_p99": float(np.quantile(rel, 0.99)) if rel.size else 0.0,
    }


def main(argv: list[str]) -> None:
    p = parser("random_rays", __doc__)
    p.add_argument("scene", nargs="?", default="1M")
    p.add_argument("rays", nargs="?", type=int, default=1_000_000)
    p.add_argument("rounds", nargs="?", type=int, default=2)
    a = p.parse_args(argv)
    print(header())
    r = run(a.scene, a.rays, a.rounds)
    print(
        f"{a.scene}: {r['rays']:,} random rays: genie-gl {r['genie_gl_s']:.2f} s, Open3D "
        f"{r['open3d_s']:.2f} s (Open3D / genie-gl {r['ratio']:.2f}); same instance "
        f"{r['ids_agree']:.4%}, distance p99 relative {r['range_rel_p99']:.1e}"
    )
