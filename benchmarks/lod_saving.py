"""What level of detail saves and costs on the benchmark scenes: per scene and raster, the
steady frame (depth and ids, 640 x 480, every core) with LOD off and at each ``below_px``, and
against the frame without LOD the depth error where both hit (per frame its 99th and 99.9th
percentiles, averaged over the poses), the pixels whose instance differs and the instances
simplified per frame.

The settings take turns pose by pose in one process; a pose's time is its least over the
rounds (what a loaded machine blurs least), a setting's the mean of those over the poses::

    python -m benchmarks lod_saving                  # 1M and hall, both rasters, 16 / 48 / 128 px
    python -m benchmarks lod_saving hall exact 3     # one scene, one raster, rounds
    python -m benchmarks lod_saving generated gl 2   # the generated hall (assets of a few hundred
    faces)
"""

from __future__ import annotations

import time

import numpy as np

from genie_gl.render import LevelOfDetail, Renderer

from .common import benchmark_scene, header, parser, sensor_640

SETTINGS = (None, 16.0, 48.0, 128.0)
RASTERS = {"gl": "gl", "exact": "cpu"}


def run(scene_name: str, raster: str, rounds: int, poses: int | None = None) -> list[dict]:
    """One row per setting of :data:`SETTINGS`: ``below_px`` (None: off), ``ms``, ``x_off``,
    ``simplified``, ``dz_p99_mm``, ``dz_p999_mm``, ``id_differs_pct``; the first ``poses``
    poses of the scene (all 40 by default)."""
    spec, scene = benchmark_scene(scene_name)
    views, sensor = spec.poses[:poses], sensor_640()
    renderers = {
        px: Renderer(
            scene, raster=RASTERS[raster], lod=None if px is None else LevelOfDetail(below_px=px)
        )
        for px in SETTINGS
    }
    best = {px: np.full(len(views), np.inf) for px in SETTINGS}
    errors: dict = {px: [] for px in SETTINGS}
    try:
        for rep in range(rounds):
            for i, pose in enumerate(views):
                frames = {}
                for px in SETTINGS if rep % 2 == 0 else SETTINGS[::-1]:
                    t = time.perf_counter()
                    frames[px] = renderers[px].render(sensor, pose, depth_only=True)
                    best[px][i] = min(best[px][i], time.perf_counter() - t)
                    if rep == 0:
                        errors[px].append(renderers[px].stats["instances_simplified"])
                if rep == 0:
                    ref = frames[None]
                    for px in SETTINGS:
                        f = frames[px]
                        both = (ref.depth > 0) & (f.depth > 0)
                        dz = np.abs(f.depth[both].astype(np.float64) - ref.depth[both])
                        errors[px][-1] = (
                            errors[px][-1],
                            np.percentile(dz, 99) * 1e3 if dz.size else 0.0,
                            np.percentile(dz, 99.9) * 1e3 if dz.size else 0.0,
                            100.0 * np.mean(f.instance != ref.instance),
                        )
    finally:
        for r in renderers.values():
            r.release()
    base = best[None].mean()
    rows = []
    for px in SETTINGS:
        e = np.array(errors[px], dtype=float)
        rows.append(
            {
                "below_px": px,
                "ms": 1e3 * best[px].mean(),
                "x_off": best[px].mean() / base,
                "simplified": e[:, 0].mean(),
                "dz_p99_mm": e[:, 1].mean(),
                "dz_p999_mm": e[:, 2].mean(),
                "id_differs_pct": e[:, 3].mean(),
                "triangles": spec.triangles,
            }
        )
    return rows


def main(argv: list[str]) -> None:
    p = parser("lod_saving", __doc__)
    p.add_argument("scene", nargs="?", help="benchmark scene (default: 1M and hall)")
    p.add_argument("raster", nargs="?", choices=tuple(RASTERS), help="default: both")
    p.add_argument("rounds", nargs="?", type=int, default=3)
    a = p.parse_args(argv)
    print(header())
    for s in [a.scene] if a.scene else ["1M", "hall"]:
        for raster in [a.raster] if a.raster else ["exact", "gl"]:
            rows = run(s, raster, a.rounds)
            print(
                f"{s}, {raster} raster, {rows[0]['triangles']:,} triangles, 40 poses, {a.rounds} "
                "rounds"
            )
            print(
                "| below_px | ms / frame | x off | instances simplified | dz p99 mm | dz p99.9 mm "
                "| id differs % |"
            )
            print("| --- | --- | --- | --- | --- | --- | --- |")
            for r in rows:
                px = "off" if r["below_px"] is None else f"{r['below_px']:g}"
                print(
                    f"| {px} | {r['ms']:.1f} | {r['x_off']:.2f} | {r['simplified']:.1f} | "
                    f"{r['dz_p99_mm']:.2f} | "
                    f"{r['dz_p999_mm']:.1f} | {r['id_differs_pct']:.3f} |"
                )
