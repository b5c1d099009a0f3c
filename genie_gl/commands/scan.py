"""``genie scan STRATEGY --scanner PROFILE | --rig RIG --out DIR --format FMT``.

Builds the strategy's layout and scene (seeded), makes a trajectory on its free floor
(``--path``, ``--motion``, ``--duration``), scans it with one scanner or a rig of heads (each
firing from its own pose on the trajectory) and writes the scans in a scanner format
(:mod:`genie_gl.export.lidar_output`). A bad scanner or rig file is one line, before any
work, and nothing is written.
"""

from __future__ import annotations

import argparse
import os

from ..errors import ConfigError
from . import count, positive, seed, stages

FORMATS = (
    "kitti",
    "rosbag",
    "las",
    "e57",
    "pcd",
    "ply",
)  # genie_gl.export.lidar_output.SCAN_FORMATS


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("strategy", help="layout strategy (a shipped name or a JSON file)")
    head = p.add_mutually_exclusive_group(required=True)
    head.add_argument(
        "--scanner", help="scanner profile (a shipped name, e.g. velodyne_vlp16, or a .lidar.yml)"
    )
    head.add_argument(
        "--rig", help="scanner rig (a shipped name, e.g. navvis_wearable, or a .lidar.yml)"
    )
    p.add_argument(
        "--path", default="aisles", choices=("aisles", "random"), help="the route on the free floor"
    )
    p.add_argument(
        "--motion", default="person", choices=("person", "robot"), help="how the body moves"
    )
    p.add_argument(
        "--duration", type=positive(3600), default=10.0, metavar="S", help="seconds of the walk"
    )
    p.add_argument("--format", default="kitti", choices=FORMATS, help="the scans' format")
    p.add_argument("--out", required=True)
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument(
        "--workers",
        type=count(1, 4096),
        default=os.cpu_count() or 1,
        help="processes making the scans (default: the machine's cores; same bytes with any)",
    )
    p.add_argument("--no-progress", action="store_true")


def run(args: argparse.Namespace) -> int:
    from ..effects.scanner_profile import load_scanner
    from ..motion.scanner_rig import ScannerRig, load_scanner_rig

    if args.format not in FORMATS:
        raise ConfigError(f"--format {args.format!r}: expected one of {', '.join(FORMATS)}")
    # the scanner files first: a mistake in them is one line before the pipeline is even imported
    rig = load_scanner_rig(args.rig) if args.rig else ScannerRig.single(load_scanner(args.scanner))

    from ..capture.scanning import scan
    from ..export.lidar_output import export_scans
    from ..layout import generate_layout
    from ..scene import build_scene
    from ..motion.paths import make_trajectory

    with stages(
        ["layout", "scene", "trajectory", "scan", "export"],
        title="genie scan",
        enabled=not args.no_progress,
    ) as step:
        step("layout")
        layout = generate_layout(args.strategy, seed=args.seed)
        step("scene")
        scene = build_scene(layout, seed=args.seed)
        step("trajectory")
        path = make_trajectory(
            layout, scene, args.path, seed=args.seed, motion=args.motion, duration_s=args.duration
        )
        step(f"scan {path.duration_s:.1f} s with {len(rig.heads)} head(s)")
        scans = scan(scene, rig, path, seed=args.seed, workers=args.workers)
        step("export")
        files = export_scans(scans, args.out, args.format)
    points = sum(len(s) for s in scans)
    print(
        f"scan: {len(scans)} scans, {points:,} points over {path.duration_s:.1f} s -> {args.out} "
        f"({len(files)} files)"
    )
    return 0
