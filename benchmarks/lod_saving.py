"""What level of detail saves and costs on the benchmark scenes: per scene and raster, the
steady frame (depth and ids, 640 x 480, both cores) with LOD off and at each ``below_px``, and
against the frame without LOD the depth error where both hit (per frame its 99th and
99.9th percentiles, averaged over the poses), the pixels whose instance
differs and the instances simplified per frame.

    python docs/lod_saving.py                  # 1M and hall, both rasters, 16 / 48 / 128 px
    python docs/lod_saving.py hall exact 3     # one scene, one raster, rounds
    python docs/lod_saving.py generated gl 2   # the generated hall (assets of a few hundred faces)

The settings take turns pose by pose in one process; a pose's time is its least over the
rounds (what a loaded machine blurs least), a setting's the mean of those over the poses.
"""
import sys
import time

import numpy as np

from genie_gl.bench.render import sensor_640
from genie_gl.bench.scenes import bench_spec, to_scene
from genie_gl.render import LevelOfDetail, Renderer

SETTINGS = (None, 16.0, 48.0, 128.0)


def measure(scene_name: str, raster: str, rounds: int) -> None:
    spec = bench_spec(scene_name)
    scene, poses, sensor = to_scene(spec), spec.poses, sensor_640()
    precisions = {"gl": "float32", "exact": "exact"}
    if raster not in precisions:
        raise SystemExit(f"lod_saving.py: raster {raster!r} is unknown; expected gl or exact")
    precision = precisions[raster]
    renderers = {px: Renderer(scene, depth_precision=precision,
                              lod=None if px is None else LevelOfDetail(below_px=px)) for px in SETTINGS}
    best = {px: np.full(len(poses), np.inf) for px in SETTINGS}
    errors = {px: [] for px in SETTINGS}
    for rep in range(rounds):
        for i, pose in enumerate(poses):
            frames = {}
            for px in (SETTINGS if rep % 2 == 0 else SETTINGS[::-1]):
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
                    errors[px][-1] = (errors[px][-1], np.percentile(dz, 99) * 1e3 if dz.size else 0.0,
                                      np.percentile(dz, 99.9) * 1e3 if dz.size else 0.0,
                                      100.0 * np.mean(f.instance != ref.instance))
    base = best[None].mean()
    print(f"{scene_name}, {raster} raster, {renderers[None].triangles:,} triangles, {len(poses)} poses, "
          f"{rounds} rounds")
    print("| below_px | ms / frame | x off | instances simplified | dz p99 mm | dz p99.9 mm | id differs % |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for px in SETTINGS:
        e = np.array(errors[px], dtype=float)
        ms = 1e3 * best[px].mean()
        print(f"| {'off' if px is None else f'{px:g}'} | {ms:.1f} | {best[px].mean() / base:.2f} | "
              f"{e[:, 0].mean():.1f} | {e[:, 1].mean():.2f} | {e[:, 2].mean():.1f} | {e[:, 3].mean():.3f} |")


def main() -> None:
    scenes = [sys.argv[1]] if len(sys.argv) > 1 else ["1M", "hall"]
    rasters = [sys.argv[2]] if len(sys.argv) > 2 else ["exact", "gl"]
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 3
    print(time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "load", " ".join(f"{x:.1f}" for x in __import__("os").getloadavg()))
    for s in scenes:
        for r in rasters:
            measure(s, r, rounds)


if __name__ == "__main__":
    main()
