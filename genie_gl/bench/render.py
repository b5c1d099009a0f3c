"""``genie bench render``: genie-gl against Open3D ray casting and pyrender (SEG mode).

Scenes (:mod:`genie_gl.bench.scenes`): ``100k``, ``1M`` and ``10M`` triangles of 221 meshes,
``hall`` (~9.8 M triangles: one 81,920-triangle mesh placed 120 times) and ``generated`` (a
shipped strategy built into a scene). Camera 640 x 480, fx = fy = 525; every tool returns
depth and per-pixel instance ids.

Each measurement runs in a fresh process of its own (tools never share a process, its
memory or its thread pools), the tools taking turns, ``--repeats`` times. A process builds
the tool's scene from the same arrays in memory and renders the scene's 40 poses in turn:

* library: before the clock, each tool loads what it needs once per process, whatever the
  scene, by drawing a box before the first camera (Open3D: its import, Embree; genie-gl: its
  compiled kernels from numba's cache; pyrender: its GL context's libraries), timed apart;
* build: meshes in memory -> first frame (genie-gl: ``Scene`` + ``Renderer`` + the first
  ``render``; Open3D: the instances' triangles into a ``RaycastingScene`` + the first
  ``cast_rays``; pyrender: its scene from our ``Scene`` + the first render);
* steady frame: the mean time of the 39 frames after the first (genie-gl through
  :meth:`Renderer.frames`, which is what ``capture`` uses);
* N cameras with the build: build + the next N - 1 frames, for N = 24 and 40; and "cold",
  with the library's loading too (what a process that draws one scene pays);
* peak memory: the process's peak resident set (VmHWM), and what it held before the build
  (interpreter, imports and the scene's arrays) to read the build's own share;
* whole machine (``--whole-machine``): P = cores processes of one tool at once, each with
  1 / P of the cores, after a barrier; frames/s summed.

Reported per tool: the minimum and median over the repeats. Ratio columns say what they
divide. A peer that is not installed is listed as skipped with its install command. Writes
``render.json`` under ``--out``.
"""

from __future__ import annotations

import argparse
import gc
import importlib.util
import json
import multiprocessing as mp
import os
import time
from pathlib import Path

import numpy as np
import trimesh

from ..errors import ConfigError, did_you_mean
from ..outputs import atomic_write_text
from ..render import Renderer
from ..render.reference import ReferenceRenderer
from ..render.threads import limit_threads
from ..scene.model import Scene
from ..sensors.camera import Sensor
from .scenes import SIZES, bench_spec, to_scene

CAMERAS = (24, 40)


def sensor_640():
    return Sensor(
        640,
        480,
        np.array([[525.0, 0, 319.5], [0, 525.0, 239.5], [0, 0, 1]]),
        near_m=0.1,
        far_m=100.0,
    )


def bench_scene(size: str, seed: int = 0):
    """The benchmark scene ``size`` as a genie_gl.Scene and its first four camera poses."""
    spec = bench_spec(size, seed)
    return to_scene(spec), list(spec.poses[:4])


PEERS = {
    "pyrender": ("pyrender", "pip install pyrender"),
    "Open3D": ("open3d", "pip install open3d"),
}


class _Ours:
    """The default path: the raster gg.capture and genie dataset draw with on this machine
    (:func:`genie_gl.render.rasters.default_raster`)."""

    name = "genie-gl"
    raster: str | None = None

    def __init__(self, spec) -> None:
        self.r = Renderer(to_scene(spec), raster=self.raster)
        self.triangles = self.r.triangles

    @classmethod
    def load_library(cls, sensor, pose) -> None:
        """The compiled kernels from numba's cache (a frame and frames side by side of a
        box before the camera)."""
        r = Renderer(_box_scene(pose), raster=cls.raster)
        r.render(sensor, pose, depth_only=True)
        for _ in r.frames(sensor, [pose] * 3, depth_only=True):
            pass
        r.release()

    def frame(self, sensor, pose):
        return self.r.render(sensor, pose, depth_only=True)

    def frames(self, sensor, poses):
        for _ in self.r.frames(sensor, poses, depth_only=True):
            pass

    def release(self) -> None:
        self.r.release()


class _OursExact(_Ours):
    name = "genie-gl-exact"
    raster = "cpu"


class _OursGL(_Ours):
    name = "genie-gl-gl"
    raster = "gl"


class _Pyrender:
    name = "pyrender"

    def __init__(self, spec, scene=None) -> None:
        self.r = ReferenceRenderer(scene if scene is not None else to_scene(spec))

    @staticmethod
    def load_library(sensor, pose) -> None:
        """pyrender and its GL context's libraries (a frame of a box)."""
        r = ReferenceRenderer(_box_scene(pose))
        r.render(sensor, pose)
        r.release()

    def frame(self, sensor, pose) -> None:
        self.r.render(sensor, pose)

    def frames(self, sensor, poses) -> None:
        for p in poses:
            self.r.render(sensor, p)

    def release(self) -> None:
        self.r.release()


class _Open3D:
    name = "Open3D"

    def __init__(self, spec) -> None:
        import open3d as o3d

        self.o3d = o3d
        self.rc = o3d.t.geometry.RaycastingScene()
        for m, T in zip(spec.mesh_of, spec.world_from_model):
            v, f, _ = spec.meshes[m]
            w = v.astype(np.float64) @ T[:3, :3].T + T[:3, 3]
            self.rc.add_triangles(o3d.core.Tensor(w.astype(np.float32)), o3d.core.Tensor(f))

    @staticmethod
    def load_library(sensor, pose) -> None:
        """Open3D and Embree (a cast of a frame at one triangle)."""
        import open3d as o3d

        rc = o3d.t.geometry.RaycastingScene()
        c = (pose @ [0.0, 0.0, 2.0, 1.0])[:3]
        tri = np.array([c, c + [1.0, 0.0, 0.0], c + [0.0, 1.0, 0.0]], np.float32)
        rc.add_triangles(o3d.core.Tensor(tri), o3d.core.Tensor(np.array([[0, 1, 2]], np.uint32)))
        rays = o3d.t.geometry.RaycastingScene.create_rays_pinhole(
            o3d.core.Tensor(sensor.K), o3d.core.Tensor(np.linalg.inv(pose)), sensor.width,
            sensor.height,
        )  # fmt: skip
        rc.cast_rays(rays)["t_hit"].numpy()

    def frame(self, sensor, pose) -> None:
        o3d = self.o3d
        K = sensor.K.copy()
        K[0, 2] += 0.5  # Open3D puts pixel centres at +0.5
        K[1, 2] += 0.5
        rays = o3d.t.geometry.RaycastingScene.create_rays_pinhole(
            o3d.core.Tensor(K), o3d.core.Tensor(np.linalg.inv(pose)), sensor.width, sensor.height
        )
        ans = self.rc.cast_rays(rays)
        ans["t_hit"].numpy()
        ans["geometry_ids"].numpy()

    def frames(self, sensor, poses) -> None:
        for p in poses:
            self.frame(sensor, p)

    def release(self) -> None:
        self.rc = None


def _box_scene(pose: np.ndarray):
    """A 1 m box 2 m before a camera at ``pose``: what loads a tool's libraries."""
    scene = Scene()
    T = np.eye(4)
    T[:3, 3] = (pose @ [0.0, 0.0, 2.0, 1.0])[:3]
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), T, semantic=1)
    return scene


TOOLS = {
    "genie-gl": _Ours,
    "genie-gl-exact": _OursExact,
    "genie-gl-gl": _OursGL,
    "Open3D": _Open3D,
    "pyrender": _Pyrender,
}
OURS = ("genie-gl", "genie-gl-exact", "genie-gl-gl")


def available(name: str) -> bool:
    return name not in PEERS or importlib.util.find_spec(PEERS[name][0]) is not None


def bench_frames(scene, sensor, poses) -> list:
    """The frames ``genie bench render`` times, made by the object it times (depth and ids,
    what ``capture`` calls for a sensor without effects): the default path's raster."""
    with Renderer(scene, raster=_Ours.raster) as r:
        first = [r.render(sensor, poses[0], depth_only=True)]
        return first + list(r.frames(sensor, poses[1:], depth_only=True))


def _rss(field: str) -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def peak_rss_mib() -> float:
    """This process's peak resident memory (VmHWM; unlike ru_maxrss it does not carry the
    parent's peak across the exec of a spawned worker)."""
    return _rss("VmHWM")


def _measure(args) -> dict:
    """One tool on one scene in this (fresh) process: build, 39 more frames, peak memory."""
    name, scene_name = args
    spec = bench_spec(scene_name)
    scene = to_scene(spec) if name == "pyrender" else None  # pyrender's build starts from our Scene
    sensor = sensor_640()
    poses = list(spec.poses)
    t_lib = time.perf_counter()
    TOOLS[name].load_library(sensor, poses[0])
    library = time.perf_counter() - t_lib
    gc.collect()
    before = _rss("VmRSS")
    c0, t0 = time.process_time(), time.perf_counter()
    tool = TOOLS[name](spec) if scene is None else _Pyrender(spec, scene)
    tool.frame(sensor, poses[0])
    build = time.perf_counter() - t0
    build_cpu = time.process_time() - c0
    marks = {}
    t1, c1 = time.perf_counter(), time.process_time()
    done = 1
    for n in CAMERAS:  # frames 1 .. n - 1, going on from where the last count stopped
        tool.frames(sensor, poses[done:n])
        marks[n] = time.perf_counter() - t1
        done = n
    frames_cpu = time.process_time() - c1
    out = {
        "tool": name,
        "scene": scene_name,
        "build_s": build,
        "build_cpu_s": build_cpu,
        "steady_ms": 1e3 * marks[CAMERAS[-1]] / (CAMERAS[-1] - 1),
        "steady_cpu_ms": 1e3 * frames_cpu / (CAMERAS[-1] - 1),
        **{f"cameras_{n}_s": build + marks[n] for n in CAMERAS},
        "library_s": library,
        **{f"cameras_{n}_cold_s": library + build + marks[n] for n in CAMERAS},
        "peak_rss_mib": peak_rss_mib(),
        "rss_before_mib": before,
        "triangles": spec.triangles,
    }
    if name in OURS:
        r = tool.r
        r.render(sensor, poses[0], depth_only=True)
        out["triangles_drawn_pose0"] = int(r.stats["triangles_drawn"])
    tool.release()
    return out


def _worker(args) -> tuple[int, float, float]:
    name, scene_name, barrier, frames, lp_threads = args
    os.environ["LP_NUM_THREADS"] = str(lp_threads)
    limit_threads(lp_threads)
    spec = bench_spec(scene_name)
    sensor = sensor_640()
    tool = TOOLS[name](spec) if name != "pyrender" else _Pyrender(spec)
    poses = list(spec.poses)
    tool.frame(sensor, poses[0])
    barrier.wait()
    t = time.perf_counter()
    tool.frames(sensor, [poses[i % len(poses)] for i in range(frames)])
    dt = time.perf_counter() - t
    tool.release()
    return frames, dt, peak_rss_mib()


def whole_machine(name: str, scene_name: str, frames: int) -> dict:
    """Frames/s of P = cores processes of one tool at once, and their peak RSS (MiB)."""
    n = os.cpu_count() or 1
    ctx = mp.get_context("spawn")
    manager = ctx.Manager()
    barrier = manager.Barrier(n)
    with ctx.Pool(n) as pool:
        parts = pool.map(_worker, [(name, scene_name, barrier, frames, 1)] * n)
    manager.shutdown()
    return {
        "processes": n,
        "fps": float(sum(f / t for f, t, _ in parts)),
        "peak_rss_mib": float(max(m for _, _, m in parts)),
    }


def _fresh(name: str, scene_name: str) -> dict:
    ctx = mp.get_context("spawn")
    with ctx.Pool(1, maxtasksperchild=1) as pool:
        return pool.apply(_measure, ((name, scene_name),))


def _warm() -> None:
    """Compile (or load) every cached kernel once in a throw-away process, so that no
    measured process pays numba's first compilation."""
    ctx = mp.get_context("spawn")
    with ctx.Pool(1) as pool:
        for tool in OURS:
            pool.apply(_measure, ((tool, "100k"),))


METRICS = (
    ("library_s", "library s", 1.0),
    ("build_s", "build s", 1.0),
    ("steady_ms", "steady ms/frame", 1.0),
    ("cameras_24_s", "24 cams s", 1.0),
    ("cameras_24_cold_s", "24 cams cold s", 1.0),
    ("cameras_40_s", "40 cams s", 1.0),
    ("peak_rss_mib", "peak MiB", 1.0),
)


def summarise(runs: list[dict]) -> dict:
    """Per scene and tool: min and median of every metric over the repeats."""
    out: dict = {}
    for r in runs:
        out.setdefault(r["scene"], {}).setdefault(r["tool"], []).append(r)
    table: dict = {}
    for scene, tools in out.items():
        table[scene] = {}
        for tool, rs in tools.items():
            row = {"n": len(rs), "triangles": rs[0]["triangles"]}
            for key in [k for k in rs[0] if isinstance(rs[0][k], float)]:
                vals = [x[key] for x in rs]
                row[key] = {"min": float(np.min(vals)), "median": float(np.median(vals))}
            if "triangles_drawn_pose0" in rs[0]:
                row["triangles_drawn_pose0"] = rs[0]["triangles_drawn_pose0"]
            table[scene][tool] = row
    return table


def _print(table: dict, whole: dict) -> None:
    for scene, tools in table.items():
        ours = tools.get("genie-gl")
        tri = next(iter(tools.values()))["triangles"]
        drawn = f", {ours['triangles_drawn_pose0']:,} drawn at pose 0" if ours else ""
        print(
            f"\nscene {scene}: {tri:,} triangles{drawn}; 640x480, depth + instance ids; min "
            "(median) of "
            f"{next(iter(tools.values()))['n']} fresh processes per tool"
        )
        print(f"  {'tool':<13}" + "".join(f"{label:>22}" for _, label, _ in METRICS))
        for tool, row in tools.items():
            cells = "".join(
                f"{row[k]['min']:>12.3g} ({row[k]['median']:.3g})" for k, _, _ in METRICS
            )
            print(f"  {tool:<13}{cells}")
        for mine in (t for t in OURS if t in tools):
            for tool, row in tools.items():
                if tool in OURS:
                    continue
                ratios = [row[k]["median"] / tools[mine][k]["median"] for k, _, _ in METRICS]
                print(
                    f"  {tool + ' / ' + mine:<10}"
                    + "".join(f"{x:>22.2f}" for x in ratios)
                    + "   (medians)"
                )
        for tool, w in whole.get(scene, {}).items():
            print(
                f"  whole machine {tool}: {w['fps']:.1f} frames/s with {w['processes']} processes, "
                f"peak {w['peak_rss_mib']:.0f} MiB per process"
            )


def _listed(value, known, option: str) -> list[str]:
    """The names of ``value`` (a list from the command line or a comma-separated string from
    a caller), each one of ``known`` (a ConfigError in the option's words otherwise)."""
    parts = [
        v.strip() for v in (value.split(",") if isinstance(value, str) else value) if v.strip()
    ]
    for name in parts or [""]:
        if name not in known:
            raise ConfigError(
                f"genie bench render {option}: unknown name {name!r}{did_you_mean(name, known)}; "
                f"expected some of {', '.join(known)}"
            )
    return parts


def run(args: argparse.Namespace) -> int:
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    scenes, tools = _listed(args.scenes, SIZES, "--scenes"), _listed(args.tools, TOOLS, "--tools")
    skipped = {t: f"not installed: {PEERS[t][1]}" for t in tools if not available(t)}
    tools = [t for t in tools if t not in skipped]
    load = os.getloadavg()
    print(
        "genie bench render: compiling (or loading) the kernels once in a throw-away process "
        "(the first run on a machine takes about a minute) ...",
        flush=True,
    )
    _warm()
    runs = []
    total, done = len(scenes) * args.repeats * len(tools), 0
    for scene in scenes:
        for k in range(args.repeats):
            turn = tools[k % len(tools) :] + tools[: k % len(tools)]  # who goes first rotates
            for tool in turn:
                done += 1
                print(
                    f"  [{done}/{total}] scene {scene}, {tool}, turn {k + 1} of {args.repeats}: a "
                    "fresh process "
                    "builds the scene and renders its 40 poses ...",
                    flush=True,
                )
                runs.append(_fresh(tool, scene))
    whole: dict = {}
    if args.whole_machine:
        for scene in scenes:
            print(
                f"  scene {scene}: each tool on the whole machine ({args.frames} frames per "
                "process) ...",
                flush=True,
            )
            whole[scene] = {t: whole_machine(t, scene, args.frames) for t in tools}
    table = summarise(runs)
    results = {
        "machine": {"cpus": os.cpu_count(), "load_before": load, "load_after": os.getloadavg()},
        "runs": runs,
        "table": table,
        "whole_machine": whole,
        "skipped": skipped,
    }
    _print(table, whole)
    print(
        f"\nload average before {load[0]:.1f}, after {os.getloadavg()[0]:.1f} ({os.cpu_count()} "
        "cores)"
    )
    for name, why in skipped.items():
        print(f"  skipped {name}: {why}")
    atomic_write_text(out_dir / "render.json", json.dumps(results, indent=2))
    print(f"\nwrote {out_dir / 'render.json'}")
    return 0
