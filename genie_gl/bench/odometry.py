"""``genie bench odometry``: an outside check of the sequences. A rig's recording is written as
a SemanticKITTI sequence, read back as the SemanticKITTI tools read it, and run through the
KISS-ICP odometry pipeline (``kiss-icp``); ``evo`` reports the absolute trajectory error
(translation RMSE, no alignment: both start at the first scan) and the relative pose error
per metre of KISS-ICP's trajectory against the sequence's own ground truth.

Needs ``pip install 'genie-gl[bench]'`` (kiss-icp, evo).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from ..capture.trajectory import record
from ..export.semantickitti_sequence import write_recording
from ..layout import generate_layout, load_strategy
from ..outputs import atomic_write_text
from ..render import shared_context
from ..scene import build_scene
from ..sensors.paths import make_trajectory
from ..sensors.rig import load_rig


def read_sequence(seq: Path) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """Scans (body frame), the ground-truth body poses in the first scan's body frame
    (``Tr⁻¹ · pose · Tr``, as the SemanticKITTI tools compute them) and the times."""
    calib = {}
    for line in (seq / "calib.txt").read_text().splitlines():
        key, content = line.split(":")
        calib[key] = np.r_[np.array(content.split(), float).reshape(3, 4), [[0, 0, 0, 1]]]
    Tr = calib["Tr"]
    poses = [np.linalg.inv(Tr) @ np.r_[p.reshape(3, 4), [[0, 0, 0, 1]]] @ Tr for p in np.loadtxt(seq / "poses.txt")]
    scans = [np.fromfile(seq / "velodyne" / f"{j:06d}.bin", "<f4").reshape(-1, 4)[:, :3] for j in range(len(poses))]
    return scans, np.array(poses), np.loadtxt(seq / "times.txt")


def check_arguments(args: argparse.Namespace) -> None:
    """The rig and the strategy read before the output folder is claimed (``genie bench`` calls it)."""
    load_rig(args.rig)
    load_strategy(args.strategy)


def run(args: argparse.Namespace) -> int:
    from evo.core import metrics     # the bench extra: evo and kiss-icp
    from evo.core.trajectory import PoseTrajectory3D
    from kiss_icp.config import KISSConfig
    from kiss_icp.kiss_icp import KissICP

    rig = load_rig(args.rig)   # a bad rig file is refused before the scene is built
    layout = generate_layout(args.strategy, seed=args.seed)
    scene = build_scene(layout, seed=args.seed)
    tr = make_trajectory(layout, scene, args.path, seed=args.seed, duration_s=args.duration_s)
    out = Path(args.out) / "odometry"
    seq, = write_recording(rig, tr, record(scene, rig, tr, seed=args.seed, depth_only=True, context=shared_context()),
                           out)
    scans, gt, times = read_sequence(seq)
    config = KISSConfig()
    config.data.deskew = False          # every scan is taken at one instant
    config.data.max_range = 30.0
    config.mapping.voxel_size = 0.1
    odo = KissICP(config)
    est = []
    for scan in scans:
        odo.register_frame(scan.astype(np.float64), np.zeros(len(scan)))
        est.append(np.array(odo.last_pose))
    ref = PoseTrajectory3D(poses_se3=list(gt), timestamps=times)
    mine = PoseTrajectory3D(poses_se3=est, timestamps=times)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((ref, mine))
    rpe = metrics.RPE(metrics.PoseRelation.translation_part, delta=1.0, delta_unit=metrics.Unit.meters,
                      all_pairs=True)
    rpe.process_data((ref, mine))
    result = {"strategy": args.strategy, "rig": rig.name, "path": args.path, "seed": args.seed, "scans": len(scans),
              "length_m": tr.length_m, "duration_s": tr.duration_s,
              "ate_rmse_m": float(ape.get_statistic(metrics.StatisticsType.rmse)),
              "ate_max_m": float(ape.get_statistic(metrics.StatisticsType.max)),
              "rpe_per_m_rmse_m": float(rpe.get_statistic(metrics.StatisticsType.rmse)),
              "end_error_m": float(np.linalg.norm(gt[-1][:3, 3] - est[-1][:3, 3]))}
    atomic_write_text(Path(args.out) / "odometry.json", json.dumps(result, indent=1))
    print(f"KISS-ICP on {len(scans)} scans of {rig.name} along {tr.length_m:.1f} m ({args.strategy}, {args.path}, "
          f"seed {args.seed}): evo ATE RMSE {100 * result['ate_rmse_m']:.2f} cm (max {100 * result['ate_max_m']:.2f} cm), "
          f"RPE per metre {100 * result['rpe_per_m_rmse_m']:.2f} cm, end point {100 * result['end_error_m']:.2f} cm")
    return 0
