"""``genie bench render``: genie-gl against pyrender (SEG mode) and Open3D ray casting.

Scenes: a floor plus 200 boxes, 10 icospheres and 10 cylinders at random poses in a 20 x 20 m
area, in two sizes (~100 k and ~1 M triangles); camera 640 x 480, fx = fy = 525, cx = 319.5,
cy = 239.5, four poses; every tool returns depth and per-pixel instance ids.

What is timed is what users call: genie-gl's :meth:`Renderer.render` (the call ``capture``
makes per pose; a test checks both give the same frames), and, on a line of its own,
``capture`` as a whole (scene upload included) per frame. For each tool:

* per frame: median and interquartile range (IQR) of single frames in one process, the tools
  taking turns pose by pose so that a drifting machine hits all alike;
* whole machine: frames/s of P processes (P = the number of cores, the same P for every
  tool) rendering at once after a barrier (genie-gl with ``LP_NUM_THREADS`` = cores / P), and
  each process's peak resident memory.

Ratio columns say what they divide. A peer that is not installed is listed as skipped with
its install command. Writes ``render.json`` under ``--out``.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import multiprocessing as mp
import os
import time
from pathlib import Path

import numpy as np
import trimesh

from ..capture import capture
from ..render import Renderer
from ..render.projection import look_at
from ..render.reference import ReferenceRenderer
from ..render.threads import limit_threads
from ..scene.model import Scene
from ..sensors.camera import Sensor

SIZES = {"100k": (4, 1024), "1M": (6, 4096)}   # icosphere subdivisions, cylinder sections


def bench_scene(size: str, seed: int = 0):
    """The benchmark scene (a genie_gl.Scene) and its four camera poses."""
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
    return Sensor(640, 480, np.array([[525.0, 0, 319.5], [0, 525.0, 239.5], [0, 0, 1]]), near_m=0.1, far_m=100.0)


PEERS = {"pyrender SEG": ("pyrender", "pip install pyrender"),
         "Open3D cast_rays": ("open3d", "pip install open3d")}


def _stats(ms: list[float]) -> dict:
    q1, med, q3 = np.percentile(ms, [25, 50, 75])
    return {"median_ms": float(med), "iqr_ms": float(q3 - q1), "q1_ms": float(q1), "q3_ms": float(q3), "n": len(ms)}


def bench_frames(scene, sensor, poses) -> list:
    """The frames ``genie bench render`` times, made by the object it times:
    :meth:`Renderer.render` per pose, depth and ids (what ``capture`` calls for a sensor
    without effects)."""
    ours = _Ours(scene)
    try:
        return [ours.frame(sensor, p) for p in poses]
    finally:
        ours.release()


class _Ours:
    name = "genie-gl"

    def __init__(self, scene) -> None:
        self.r = Renderer(scene)
        self.triangles = self.r.triangles

    def frame(self, sensor, pose):
        return self.r.render(sensor, pose, depth_only=True)

    def release(self) -> None:
        self.r.release()


class _Pyrender:
    name = "pyrender SEG"

    def __init__(self, scene) -> None:
        self.r = ReferenceRenderer(scene)

    def frame(self, sensor, pose) -> None:
        self.r.render(sensor, pose)

    def release(self) -> None:
        self.r.release()


class _Open3D:
    name = "Open3D cast_rays"

    def __init__(self, scene) -> None:
        import open3d as o3d

        self.o3d = o3d
        self.rc = o3d.t.geometry.RaycastingScene()
        for inst in scene.instances:
            m = scene.meshes[inst.mesh]
            v = m.vertices.astype(np.float64) @ inst.world_from_model[:3, :3].T + inst.world_from_model[:3, 3]
            self.rc.add_triangles(o3d.core.Tensor(v.astype(np.float32)), o3d.core.Tensor(m.faces.astype(np.uint32)))

    def frame(self, sensor, pose) -> None:
        o3d = self.o3d
        K = sensor.K.copy()
        K[0, 2] += 0.5  # Open3D puts pixel centres at +0.5
        K[1, 2] += 0.5
        rays = o3d.t.geometry.RaycastingScene.create_rays_pinhole(
            o3d.core.Tensor(K), o3d.core.Tensor(np.linalg.inv(pose)), sensor.width, sensor.height)
        ans = self.rc.cast_rays(rays)
        ans["t_hit"].numpy()
        ans["geometry_ids"].numpy()

    def release(self) -> None:
        self.rc = None


TOOLS = {"genie-gl": _Ours, "pyrender SEG": _Pyrender, "Open3D cast_rays": _Open3D}


def available(name: str) -> bool:
    return name not in PEERS or importlib.util.find_spec(PEERS[name][0]) is not None


def per_frame(scene, poses, tools: list[str], repeats: int) -> dict:
    """ms per frame of each tool in this process, tools taking turns pose by pose."""
    sensor = sensor_640()
    made = {name: TOOLS[name](scene) for name in tools}
    for t in made.values():
        t.frame(sensor, poses[0])  # warm-up: programs, buffers, compiled kernels
    ms: dict[str, list[float]] = {name: [] for name in tools}
    for _ in range(repeats):
        for p in poses:
            for name, t in made.items():
                t0 = time.perf_counter()
                t.frame(sensor, p)
                ms[name].append(1e3 * (time.perf_counter() - t0))
    out = {name: _stats(v) for name, v in ms.items()}
    if "genie-gl" in made:
        out["genie-gl"]["triangles_in_scene"] = int(made["genie-gl"].triangles)
        r = made["genie-gl"].r
        r.render(sensor, poses[0], depth_only=True)
        out["genie-gl"]["triangles_drawn"] = int(r.stats["triangles_drawn"])
    for t in made.values():
        t.release()
    return out


def capture_per_frame(scene, poses, repeats: int) -> float:
    """ms per frame of ``capture`` over all poses, one call (scene upload included)."""
    sensor = sensor_640()
    t = time.perf_counter()
    capture(scene, sensor, list(poses) * repeats, seed=0, depth_only=True)
    return 1e3 * (time.perf_counter() - t) / (len(poses) * repeats)


def _worker(args) -> tuple[int, float, float]:
    name, size, barrier, frames, lp_threads = args
    os.environ["LP_NUM_THREADS"] = str(lp_threads)
    limit_threads(lp_threads)
    scene, poses = bench_scene(size)
    sensor = sensor_640()
    tool = TOOLS[name](scene)
    tool.frame(sensor, poses[0])
    barrier.wait()
    t = time.perf_counter()
    for i in range(frames):
        tool.frame(sensor, poses[i % len(poses)])
    dt = time.perf_counter() - t
    tool.release()
    return frames, dt, peak_rss_mib()


def peak_rss_mib() -> float:
    """This process's peak resident memory (VmHWM; unlike ru_maxrss it does not carry the
    parent's peak across the exec of a spawned worker)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def whole_machine(name: str, size: str, frames: int) -> dict:
    """Frames/s of P = cores processes of one tool at once, and their peak RSS (MiB)."""
    n = os.cpu_count() or 1
    ctx = mp.get_context("spawn")
    manager = ctx.Manager()
    barrier = manager.Barrier(n)
    with ctx.Pool(n) as pool:
        parts = pool.map(_worker, [(name, size, barrier, frames, 1)] * n)
    manager.shutdown()
    return {"processes": n, "fps": float(sum(f / t for f, t, _ in parts)),
            "peak_rss_mib": float(max(m for _, _, m in parts))}


def run(args: argparse.Namespace) -> int:
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    results: dict = {"machine": {"cpus": os.cpu_count()}, "sizes": {}, "skipped": {}}
    tools = ["genie-gl"] + ([] if args.no_peers else list(PEERS))
    for name in list(tools):
        if not available(name):
            tools.remove(name)
            results["skipped"][name] = f"not installed: {PEERS[name][1]}"
    for size in [s.strip() for s in args.sizes.split(",") if s.strip()]:
        scene, poses = bench_scene(size)
        row = per_frame(scene, poses, tools, args.repeats)
        for name in tools:
            row[name].update(whole_machine(name, size, args.frames))
        row["genie-gl"]["capture_ms_per_frame"] = capture_per_frame(scene, poses, args.repeats)
        results["sizes"][size] = row
        g = row["genie-gl"]
        P = g["processes"]
        print(f"\nscene {size}: {g['triangles_in_scene']:,} triangles ({g['triangles_drawn']:,} drawn after exact "
              f"culling), 640x480, depth + instance ids")
        print(f"  {'tool':<18}{'ms/frame median (IQR)':>24}{'peer ms / ours':>16}"
              f"{f'frames/s, {P} proc':>20}{'ours / peer fps':>17}{'peak RSS/proc':>15}")
        for name in tools:
            r = row[name]
            print(f"  {name:<18}{r['median_ms']:>15.1f} ({r['iqr_ms']:4.1f})"
                  f"{r['median_ms'] / g['median_ms']:>16.2f}{r['fps']:>20.1f}{g['fps'] / r['fps']:>17.2f}"
                  f"{r['peak_rss_mib']:>11.0f} MiB")
        print(f"  genie-gl through capture(), one call over {len(poses) * args.repeats} poses with the scene upload: "
              f"{g['capture_ms_per_frame']:.1f} ms/frame")
    for name, why in results["skipped"].items():
        print(f"  skipped {name}: {why}")
    tmp = out_dir / "render.json.tmp"
    tmp.write_text(json.dumps(results, indent=2))
    tmp.replace(out_dir / "render.json")
    print(f"\nwrote {out_dir / 'render.json'}")
    return 0
