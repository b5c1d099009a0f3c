"""``genie bench sequence``: what cameras that move cost, as frames per second along a
trajectory against the same number of standing frames of the same sensors, in one process.

Along the trajectory every rig sensor's shots are rendered as ``gg.capture`` renders them, a
window at a time, with one renderer and one plan for the whole recording
(:mod:`genie_gl.capture.trajectory`); the standing frames are the same sensors at as many
poses placed for coverage, captured in one ``gg.capture`` call per sensor, as a static
dataset does; and, to tell what the views cost from what recording costs, the trajectory's own
poses captured standing, one ``gg.capture`` call per sensor. Wall and CPU seconds, best of
``--repeat``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from ..capture import capture
from ..capture.trajectory import record, schedule
from ..layout import generate_layout, load_strategy
from ..outputs import atomic_write_text
from ..render import shared_context
from ..scene import build_scene
from ..placement.genetic import place_sensors
from ..motion.paths import make_trajectory
from ..motion.rig import load_rig


def check_arguments(args: argparse.Namespace) -> None:
    """The rig and the strategy read before the output folder is claimed (``genie bench`` calls
    it)."""
    load_rig(args.rig)
    load_strategy(args.strategy)


def run(args: argparse.Namespace) -> int:
    rig = load_rig(args.rig)  # a bad rig file is refused before the scene is built
    layout = generate_layout(args.strategy, seed=args.seed)
    scene = build_scene(layout, seed=args.seed)
    tr = make_trajectory(layout, scene, "aisles", seed=args.seed, duration_s=args.duration_s)
    shots = schedule(rig, tr)
    per = [sum(s.sensor == k for s in shots) for k in range(len(rig))]
    standing = [
        place_sensors(layout, s.sensor, n=n, seed=args.seed, method="greedy")
        for s, n in zip(rig.sensors, per)
    ]
    ctx = shared_context()
    same = [[sh.world_from_camera for sh in shots if sh.sensor == k] for k in range(len(rig))]
    best = {"trajectory": float("inf"), "standing": float("inf"), "same_poses": float("inf")}
    cpu = dict(best)  # CPU seconds of the process, all threads
    for _ in range(max(1, args.repeat)):
        t, c = time.perf_counter(), time.process_time()
        n = sum(1 for _ in record(scene, rig, tr, seed=args.seed, depth_only=True, context=ctx))
        best["trajectory"] = min(best["trajectory"], time.perf_counter() - t)
        cpu["trajectory"] = min(cpu["trajectory"], time.process_time() - c)
        t, c = time.perf_counter(), time.process_time()
        for s, poses in zip(rig.sensors, standing):
            capture(scene, s.sensor, poses, seed=args.seed, workers=1, depth_only=True, context=ctx)
        best["standing"] = min(best["standing"], time.perf_counter() - t)
        cpu["standing"] = min(cpu["standing"], time.process_time() - c)
        t, c = time.perf_counter(), time.process_time()
        for s, poses in zip(rig.sensors, same):
            capture(scene, s.sensor, poses, seed=args.seed, workers=1, depth_only=True, context=ctx)
        best["same_poses"] = min(best["same_poses"], time.perf_counter() - t)
        cpu["same_poses"] = min(cpu["same_poses"], time.process_time() - c)
    result = {
        "strategy": args.strategy,
        "rig": rig.name,
        "frames": n,
        "duration_s": tr.duration_s,
        "trajectory_s": best["trajectory"],
        "standing_s": best["standing"],
        "trajectory_fps": n / best["trajectory"],
        "standing_fps": n / best["standing"],
        "ratio": best["trajectory"] / best["standing"],
        "trajectory_cpu_s": cpu["trajectory"],
        "standing_cpu_s": cpu["standing"],
        "cpu_ratio": cpu["trajectory"] / cpu["standing"],
        "same_poses_s": best["same_poses"],
        "same_poses_cpu_s": cpu["same_poses"],
        "cpu_ratio_same_poses": cpu["trajectory"] / cpu["same_poses"],
    }
    atomic_write_text(Path(args.out) / "sequence.json", json.dumps(result, indent=1))
    print(
        f"{n} frames of {rig.name} ({len(rig)} sensors) on {args.strategy}: along a "
        f"{tr.duration_s:.1f} s "
        f"trajectory {result['trajectory_fps']:.1f} frames/s, standing {result['standing_fps']:.1f}"
        " frames/s "
        f"(trajectory / standing time = {result['ratio']:.2f}; CPU time {result['cpu_ratio']:.2f}: "
        f"{result['trajectory_cpu_s']:.1f} s against {result['standing_cpu_s']:.1f} s); the "
        "trajectory's own poses "
        f"standing, one call per sensor: {n / best['same_poses']:.1f} frames/s, CPU time ratio "
        f"{result['cpu_ratio_same_poses']:.2f}"
    )
    return 0
