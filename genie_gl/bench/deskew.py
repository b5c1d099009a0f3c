"""``genie bench deskew``: the motion skew of a spinning head, proven from outside.

A VLP-16 (ideal: no effects) rides a fast walk with turns through a scene of ``--strategy``;
its raw scans (each point in the head's frame at its own firing, with its time from the scan
start, as a driver publishes them) go through the KISS-ICP odometry pipeline three times:

- ``deskew on``: KISS-ICP's own deskewing, from the per-point times;
- ``deskew off``: the scans taken as if at one instant;
- ``time shuffled``: deskewing on, the time field permuted within each scan.

evo's absolute trajectory error (translation RMSE, the two trajectories starting together)
against the head's true pose at each scan's end (KISS-ICP deskews to the scan's end) then
shows what the time field buys: the skew must be undone for the error to be least, and a
wrong time field makes it worse than none. It also checks, without KISS-ICP, that the raw
points moved by the true pose at their own times lie on the scene's surfaces (the distance
to the exact hit, max over every point).

Needs ``pip install 'genie-gl[bench]'`` (kiss-icp, evo).
"""

from __future__ import annotations

import argparse
import json
import os
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..capture.scanning import scan
from ..layout import generate_layout
from ..outputs import atomic_write_text
from ..scene import build_scene
from ..motion.follow import Motion
from ..motion.paths import make_trajectory
from ..effects.scanner_profile import load_scanner
from ..motion.scanner_rig import ScannerRig

# a brisk walk with quick turns: 1.8 m/s, 120 deg/s (the skew of one 10 Hz scan: 18 cm, 12 deg)
FAST = Motion(
    speed_mps=1.8, height_m=1.7, max_yaw_rate_rad_s=float(np.radians(120.0)), max_accel_mps2=1.5
)
MODES = ("deskew on", "deskew off", "time shuffled")


def odometry(
    scans, mode: str, *, max_range: float, voxel_m: float, rng: np.random.Generator
) -> np.ndarray:
    """(n, 4, 4) KISS-ICP's pose of each scan (the first the identity)."""
    from kiss_icp.config import KISSConfig
    from kiss_icp.kiss_icp import KissICP

    config = KISSConfig()
    config.data.deskew = mode != "deskew off"
    config.data.max_range = max_range
    config.mapping.voxel_size = voxel_m
    odo = KissICP(config)
    out = []
    for s in scans:
        t = s.time_s.copy()
        if mode == "time shuffled":
            t = rng.permutation(t)
        odo.register_frame(s.sensor_xyz.astype(np.float64), t)
        out.append(np.array(odo.last_pose))
    return np.stack(out)


def ate(gt: np.ndarray, est: np.ndarray, times: np.ndarray) -> dict:
    from evo.core import metrics
    from evo.core.trajectory import PoseTrajectory3D

    ref = PoseTrajectory3D(poses_se3=list(gt), timestamps=times)
    mine = PoseTrajectory3D(poses_se3=list(est), timestamps=times)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((ref, mine))
    return {
        "ate_rmse_m": float(ape.get_statistic(metrics.StatisticsType.rmse)),
        "ate_max_m": float(ape.get_statistic(metrics.StatisticsType.max)),
        "end_error_m": float(np.linalg.norm(gt[-1][:3, 3] - est[-1][:3, 3])),
    }


def run(args: argparse.Namespace) -> int:
    layout = generate_layout(args.strategy, seed=args.seed)
    scene = build_scene(layout, seed=args.seed)
    path = make_trajectory(
        layout, scene, "random", seed=args.seed, motion=FAST, duration_s=args.duration_s
    )
    head = replace(load_scanner("velodyne_vlp16"), effects=())
    scans = scan(scene, ScannerRig.single(head), path, seed=args.seed)
    # ground truth: the head at each scan's end, relative to the first scan's end
    ends = np.array([s.start_s + head.scan_period_s for s in scans])
    gt_world = path.at(np.minimum(ends, path.end_s))
    gt = np.linalg.inv(gt_world[0]) @ gt_world
    # raw points moved by the true pose at their own time: on the surfaces they were cast to
    worst = 0.0
    for s in scans:
        poses = path.at(np.minimum(s.start_s + s.time_s, path.end_s))
        moved = np.einsum("nij,nj->ni", poses[:, :3, :3], s.sensor_xyz) + poses[:, :3, 3]
        worst = max(worst, float(np.linalg.norm(moved - s.world_xyz, axis=1).max(initial=0.0)))
    length = float(np.linalg.norm(np.diff(path.positions, axis=0), axis=1).sum())
    print(
        f"{len(scans)} scans over {path.duration_s:.1f} s, {length:.1f} m; raw points moved by "
        "their own "
        f"time's pose lie {1000 * worst:.3f} mm (max) from their surface hits",
        flush=True,
    )
    rows: dict = {}
    result = {
        "strategy": args.strategy,
        "seed": args.seed,
        "scans": len(scans),
        "duration_s": path.duration_s,
        "length_m": length,
        "motion": {"speed_mps": FAST.speed_mps, "max_yaw_rate_deg_s": 120.0},
        "max_range_m": args.max_range,
        "voxel_m": args.voxel_m,
        "modes": rows,
        "own_time_pose_max_error_m": worst,
        "load_avg_1_5_15": os.getloadavg(),
    }
    for mode in MODES[
        ::-1
    ]:  # each mode's figures written as soon as they are known (the slowest first)
        rng = np.random.default_rng(np.random.SeedSequence([args.seed, MODES.index(mode)]))
        est = odometry(scans, mode, max_range=args.max_range, voxel_m=args.voxel_m, rng=rng)
        rows[mode] = ate(gt, est, ends)
        print(
            f"{mode:>14}: evo ATE RMSE {100 * rows[mode]['ate_rmse_m']:6.2f} cm (max "
            f"{100 * rows[mode]['ate_max_m']:6.2f} cm), end point "
            f"{100 * rows[mode]['end_error_m']:6.2f} cm",
            flush=True,
        )
        atomic_write_text(Path(args.out) / "deskew.json", json.dumps(result, indent=1))
    return 0
