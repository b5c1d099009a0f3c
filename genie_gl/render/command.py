"""``genie capture SCENE.usda --sensor PROFILE --cameras K --out DIR --format FMT``.

Renders a USD scene (any stage) from K cameras placed inside it (mounted for the sensor's
range, :func:`genie_gl.sensors.placement.scene_poses`) or from ``--poses FILE``, following the
plan (:mod:`genie_gl.plan`); warns about frames with nothing in range; merges the frames into
one labelled cloud and exports it. The manifest sums, per effect, the frames it ran on, its
milliseconds and the pixels it changed.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from .. import __version__


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", help="USD scene (.usda/.usdc/.usd)")
    p.add_argument("--sensor", default="ideal_pinhole", help="sensor profile name or path")
    p.add_argument("--cameras", type=int, default=8)
    p.add_argument("--out", required=True)
    p.add_argument("--format", default="ply")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--height", type=float, default=None,
                   help="camera height above the scene's floor (m); default: chosen for the sensor's range")
    p.add_argument("--poses", help="poses file: .npy (K, 4, 4) or .json [[4x4], ...] (instead of --cameras)")


def run(args: argparse.Namespace) -> int:
    from ..cloud import to_cloud
    from ..export import FORMATS, export
    from ..errors import ConfigError
    from ..scene.model import Scene
    from ..sensors import load_sensor
    from .batch import capture

    if args.format not in FORMATS:
        raise ConfigError(f"--format {args.format!r}: unknown; expected one of {', '.join(FORMATS)}")
    if args.cameras < 1:
        raise ConfigError("--cameras must be >= 1")
    from ..plan import effect_totals
    from ..plan import plan as make_plan
    from ..plan_command import read_poses, warn_empty
    from ..sensors.placement import scene_poses

    sensor = load_sensor(args.sensor)
    scene = Scene.from_usd(args.scene)
    poses = (read_poses(args.poses) if args.poses
             else scene_poses(scene, sensor, args.cameras, args.seed, mount_height_m=args.height))
    plan = make_plan(scene, sensor, poses)
    warn_empty(plan, "capture")
    frames = capture(scene, sensor, poses, seed=args.seed, workers=None, plan=plan)
    cloud = to_cloud(frames)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = export(cloud, out, format=args.format)
    (out / "manifest.json").write_text(json.dumps({
        "genie_gl": __version__, "command": "capture", "scene": args.scene, "sensor": args.sensor,
        "cameras": len(poses), "seed": args.seed, "format": args.format, "points": len(cloud),
        "effects": effect_totals(frames), "empty_frames": plan.empty_frames}, indent=1))
    print(f"capture: {len(frames)} frames, {len(cloud):,} points -> {path}")
    return 0
