"""``genie capture SCENE.usda --sensor PROFILE --cameras K --out DIR --format FMT``.

Renders a USD scene (any stage) from K cameras on a ring around it, looking at its centre,
merges the frames into one labelled cloud and exports it.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from .. import __version__
from . import count, positive, seed, stages


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", help="USD scene (.usda/.usdc/.usd)")
    p.add_argument("--sensor", default="ideal_pinhole", help="sensor profile name or path")
    p.add_argument("--cameras", type=count(1, 10_000), default=8)
    p.add_argument("--out", required=True)
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--format", default="ply")
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument("--height", type=positive(1e4), default=3.5, help="camera height above the scene's floor (m)")


def ring_poses(bounds: np.ndarray, n: int, height: float) -> list[np.ndarray]:
    from ..render.projection import look_at

    lo, hi = bounds
    centre = (lo + hi) / 2
    radius = 0.5 * float(np.linalg.norm(hi[:2] - lo[:2])) * 0.8
    return [look_at([centre[0] + radius * np.cos(a), centre[1] + radius * np.sin(a), lo[2] + height],
                    [centre[0], centre[1], lo[2]]) for a in np.linspace(0, 2 * np.pi, n, endpoint=False)]


def run(args: argparse.Namespace) -> int:
    from ..cloud import to_cloud
    from ..export import FORMATS, export
    from ..errors import ConfigError, did_you_mean
    from ..scene.model import Scene
    from ..sensors import load_sensor
    from ..render.batch import capture

    if args.format not in FORMATS:
        raise ConfigError(f"--format {args.format!r}: unknown; expected one of {', '.join(FORMATS)}"
                          f"{did_you_mean(args.format, FORMATS)}")
    sensor = load_sensor(args.sensor)
    with stages(["read scene", "render", "cloud", "export"], title="genie capture", enabled=not args.no_progress) as step:
        step("read scene")
        scene = Scene.from_usd(args.scene)
        poses = ring_poses(scene.bounds(), args.cameras, args.height)
        step(f"render {args.cameras} cameras")
        frames = capture(scene, sensor, poses, seed=args.seed, workers=None)
        step("cloud")
        cloud = to_cloud(frames)
        step("export")
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        path = export(cloud, out, format=args.format)
    (out / "manifest.json").write_text(json.dumps({
        "genie_gl": __version__, "command": "capture", "scene": args.scene, "sensor": args.sensor,
        "cameras": args.cameras, "seed": args.seed, "format": args.format, "points": len(cloud)}, indent=1))
    print(f"capture: {len(frames)} frames, {len(cloud):,} points -> {path}")
    return 0
