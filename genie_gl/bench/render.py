"""``genie bench render``: our renderer against pyrender (SEG mode) and Open3D ray casting.

Scenes: a floor plus 200 boxes, 10 icospheres and 10 cylinders at random poses in a 20 x 20 m
area, in two sizes (~100 k and ~1 M triangles); camera 640 x 480, fx = fy = 525, cx = 319.5,
cy = 239.5, four poses. For each renderer: ms per depth+instance+semantic frame, median
(min–max) over repeats, and frames/s using the whole machine (our renderer: one process per
core, one GL context each; pyrender: one process, llvmpipe already threads its rasteriser;
Open3D: its ray caster uses every core). Writes ``render.json`` under ``--out``.
"""
from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import time
from pathlib import Path

import numpy as np

SIZES = {"100k": (4, 1024), "1M": (6, 4096)}   # icosphere subdivisions, cylinder sections


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--repeats", type=int, default=5, help="timed passes over the 4 poses")
    parser.add_argument("--sizes", default="100k,1M", help="scene sizes to run (100k, 1M)")
    parser.add_argument("--no-peers", action="store_true", help="time genie-gl only")


def bench_scene(size: str, seed: int = 0):
    """The benchmark scene (a genie_gl.Scene) and its four camera poses."""
    import trimesh

    from ..render.projection import look_at
    from ..scene.model import Scene

    subdiv, sections = SIZES[size]
    rng = np.random.default_rng(seed)
    scene = Scene()
    scene.add(trimesh.creation.box((20.0, 20.0, 0.05)), [0, 0, -0.025], semantic=0)
    box = trimesh.creation.box((1, 1, 1))
    sphere = trimesh.creation.icosphere(subdiv, radius=0.5)
    cylinder = trimesh.creation.cylinder(0.4, 1.0, sections=sections)
    for i in range(220):
        T = trimesh.transformations.random_rotation_matrix(rng.random(3))
        T[:3, :3] *= rng.uniform(0.3, 1.5)
        T[:3, 3] = [*rng.uniform(-10, 10, 2), rng.uniform(0.3, 2.0)]
        mesh = box if i < 200 else sphere if i < 210 else cylinder
        scene.add(mesh, T, semantic=1 + i % 9)
    poses = [look_at([12 * np.cos(a), 12 * np.sin(a), 6.0], [0, 0, 0.5])
             for a in np.linspace(0, 2 * np.pi, 4, endpoint=False)]
    return scene, poses


def sensor_640():
    from ..sensors.camera import Sensor

    return Sensor(640, 480, np.array([[525.0, 0, 319.5], [0, 525.0, 239.5], [0, 0, 1]]), near_m=0.1, far_m=100.0)


def _stats(ms: list[float]) -> dict:
    return {"median_ms": float(np.median(ms)), "min_ms": float(np.min(ms)), "max_ms": float(np.max(ms))}


def time_ours(scene, poses, repeats: int) -> dict:
    from ..render import Renderer

    sensor = sensor_640()
    with Renderer(scene) as r:
        r.render(sensor, poses[0], depth_only=True)  # warm-up: programs, framebuffers
        ms, readback = [], []
        for _ in range(repeats):
            for p in poses:
                t = time.perf_counter()
                r.render(sensor, p, depth_only=True)
                ms.append(1e3 * (time.perf_counter() - t))
                readback.append(1e3 * r.stats["readback_s"])
        out = _stats(ms)
        out["readback_share"] = float(np.median(readback) / np.median(ms))
        out["triangles_in_scene"] = int(r.triangles)
    return out


def _worker(args) -> tuple[int, float]:
    size, barrier, frames, lp_threads = args
    os.environ["LP_NUM_THREADS"] = str(lp_threads)
    from ..render import Renderer

    scene, poses = bench_scene(size)
    sensor = sensor_640()
    with Renderer(scene) as r:
        r.render(sensor, poses[0], depth_only=True)
        barrier.wait()
        t = time.perf_counter()
        for i in range(frames):
            r.render(sensor, poses[i % len(poses)], depth_only=True)
        return frames, time.perf_counter() - t


def throughput_ours(size: str, frames: int) -> dict:
    """Frames/s with one process (one GL context) per core."""
    n = os.cpu_count() or 1
    manager = mp.get_context("spawn").Manager()
    barrier = manager.Barrier(n)
    with mp.get_context("spawn").Pool(n) as pool:
        parts = pool.map(_worker, [(size, barrier, frames, 1)] * n)
    manager.shutdown()
    return {"processes": n, "fps": float(sum(f / t for f, t in parts))}


def time_pyrender(scene, poses, repeats: int) -> dict:
    from ..render.reference import ReferenceRenderer

    sensor = sensor_640()
    ref = ReferenceRenderer(scene)
    ref.render(sensor, poses[0])
    ms = []
    for _ in range(repeats):
        for p in poses:
            t = time.perf_counter()
            ref.render(sensor, p)
            ms.append(1e3 * (time.perf_counter() - t))
    ref.release()
    return _stats(ms)


def time_open3d(scene, poses, repeats: int) -> dict | None:
    try:
        import open3d as o3d
    except ImportError:
        return None
    sensor = sensor_640()
    rc = o3d.t.geometry.RaycastingScene()
    for inst in scene.instances:
        m = scene.meshes[inst.mesh]
        v = (m.vertices.astype(np.float64) @ inst.world_from_model[:3, :3].T + inst.world_from_model[:3, 3])
        rc.add_triangles(o3d.core.Tensor(v.astype(np.float32)), o3d.core.Tensor(m.faces.astype(np.uint32)))
    K = sensor.K.copy()
    K[0, 2] += 0.5  # Open3D puts pixel centres at +0.5
    K[1, 2] += 0.5
    ms = []
    for _ in range(repeats):
        for p in poses:
            t = time.perf_counter()
            rays = o3d.t.geometry.RaycastingScene.create_rays_pinhole(
                o3d.core.Tensor(K), o3d.core.Tensor(np.linalg.inv(p)), sensor.width, sensor.height)
            ans = rc.cast_rays(rays)
            ans["t_hit"].numpy()
            ans["geometry_ids"].numpy()
            ms.append(1e3 * (time.perf_counter() - t))
    return _stats(ms)


def run(args: argparse.Namespace) -> int:
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    results: dict = {"machine": {"cpus": os.cpu_count()}, "sizes": {}}
    for size in [s.strip() for s in args.sizes.split(",") if s.strip()]:
        scene, poses = bench_scene(size)
        row: dict = {"genie-gl": time_ours(scene, poses, args.repeats)}
        row["genie-gl"].update(throughput_ours(size, frames=8 * args.repeats))
        if not args.no_peers:
            row["pyrender SEG"] = time_pyrender(scene, poses, args.repeats)
            row["pyrender SEG"]["fps"] = 1e3 / row["pyrender SEG"]["median_ms"]
            o3d_row = time_open3d(scene, poses, args.repeats)
            if o3d_row is not None:
                o3d_row["fps"] = 1e3 / o3d_row["median_ms"]
                row["Open3D cast_rays"] = o3d_row
        results["sizes"][size] = row
        tris = row["genie-gl"]["triangles_in_scene"]
        print(f"\nscene {size}: {tris:,} triangles, 640x480, depth + instance + semantic")
        print(f"  {'renderer':<18}{'ms/frame median (min-max)':>30}{'frames/s (machine)':>21}{'ours is x faster':>18}")
        ours_fps = row["genie-gl"]["fps"]
        for name, r in row.items():
            ratio = ours_fps / r["fps"] if name != "genie-gl" else 1.0
            print(f"  {name:<18}{r['median_ms']:>12.1f} ({r['min_ms']:.1f}-{r['max_ms']:.1f}){'':>6}"
                  f"{r['fps']:>15.1f}{ratio:>18.2f}")
        print(f"  readback share of a genie-gl frame: {100 * row['genie-gl']['readback_share']:.1f} %")
    tmp = out_dir / "render.json.tmp"
    tmp.write_text(json.dumps(results, indent=2))
    tmp.replace(out_dir / "render.json")
    print(f"\nwrote {out_dir / 'render.json'}")
    return 0
