"""``genie bench odometry``: an outside check of the sequences. A rig's recording is written as
a SemanticKITTI sequence, read back as the SemanticKITTI tools read it, and run through the
KISS-ICP odometry pipeline (``kiss-icp``); ``evo`` reports the absolute trajectory error
(translation RMSE, no alignment: both start at the first scan) and the relative pose error
per metre of KISS-ICP's trajectory against the sequence's own ground truth.

KISS-ICP is fed what a LiDAR odometry expects: each scan drawn down to a spinning LiDAR's
density (``--scan-points``, in random order: see :func:`reduced`) inside the bench (the
sequence on disk keeps every point), deskewing off (a scan is taken at one instant), a hall's
range and a 0.1 m map voxel, the rig's sensors firing at a spinning LiDAR's 20 Hz
(``--rate-hz``). KISS-ICP predicts each scan's pose at the last one's velocity and pairs
nearest points: a turn on the spot that starts between two scans 12° apart (a person's
60 °/s at the panorama rig's own 5 Hz) moves far points a metre or more off their pair, and
it loses the trajectory there.

Needs ``pip install 'genie-gl[bench]'`` (kiss-icp, evo).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..capture.trajectory import record
from ..errors import ConfigError
from ..export.semantickitti_sequence import write_recording
from ..layout import generate_layout, load_strategy
from ..outputs import atomic_write_text
from ..render import shared_context
from ..scene import build_scene
from ..motion.paths import make_trajectory
from ..motion.rig import Rig, load_rig


SCAN_POINTS = 100_000  # a spinning LiDAR's points per scan: the density KISS-ICP is tuned for
MAX_RANGE_M = 30.0  # an indoor hall: nothing useful lies farther
VOXEL_M = 0.1
RATE_HZ = 20.0  # a spinning LiDAR's scan rate: 3 degrees a scan at a person's 60 °/s turn


def at_rate(rig: Rig, rate_hz: float) -> Rig:
    """``rig`` with every sensor firing at ``rate_hz``."""
    return Rig(rig.name, tuple(dataclasses.replace(s, rate_hz=float(rate_hz)) for s in rig.sensors))


def reduced(scan: np.ndarray, n: int, *, rng: np.random.Generator) -> np.ndarray:
    """``n`` points of ``scan`` drawn at random without replacement, in random order (all of
    them, shuffled, when it has fewer; ``n`` 0: the scan unchanged): a spinning LiDAR's
    density, which KISS-ICP is tuned for (fed the million points of a panorama's scan it
    drifts centimetres in the first five scans, in image order or shuffled; see
    docs/sequences.md)."""
    if n <= 0:
        return scan
    return scan[rng.permutation(len(scan))[:n]]


def read_sequence(seq: Path) -> tuple[Iterator[np.ndarray], np.ndarray, np.ndarray]:
    """Scans (body frame, (N, 3) float32, read one at a time), the ground-truth body poses in the
    first scan's body frame
    (``Tr⁻¹ · pose · Tr``, as the SemanticKITTI tools compute them) and the times."""
    calib = {}
    for line in (seq / "calib.txt").read_text().splitlines():
        key, content = line.split(":")
        calib[key] = np.r_[np.array(content.split(), float).reshape(3, 4), [[0, 0, 0, 1]]]
    Tr = calib["Tr"]
    poses = [
        np.linalg.inv(Tr) @ np.r_[p.reshape(3, 4), [[0, 0, 0, 1]]] @ Tr
        for p in np.loadtxt(seq / "poses.txt")
    ]
    scans = (
        np.fromfile(seq / "velodyne" / f"{j:06d}.bin", "<f4").reshape(-1, 4)[:, :3]
        for j in range(len(poses))
    )
    return scans, np.array(poses), np.loadtxt(seq / "times.txt")


def check_arguments(args: argparse.Namespace) -> None:
    """The rig and the strategy read before the output folder is claimed (``genie bench`` calls
    it)."""
    load_rig(args.rig)
    load_strategy(args.strategy)
    if args.sequence:
        missing = [
            n
            for n in ("calib.txt", "poses.txt", "times.txt", "velodyne")
            if not (Path(args.sequence) / n).exists()
        ]
        if missing:
            raise ConfigError(
                f"--sequence {args.sequence}: expected a SemanticKITTI sequence folder; it lacks "
                f"{', '.join(missing)}"
            )


def run(args: argparse.Namespace) -> int:
    from evo.core import metrics  # the bench extra: evo and kiss-icp
    from evo.core.trajectory import PoseTrajectory3D
    from kiss_icp.config import KISSConfig
    from kiss_icp.kiss_icp import KissICP

    if args.sequence:  # a sequence written before (by this bench or a dataset run)
        seq, what = Path(args.sequence), f"the sequence {args.sequence}"
    else:
        rig = at_rate(load_rig(args.rig), args.rate_hz)
        layout = generate_layout(args.strategy, seed=args.seed)
        scene = build_scene(layout, seed=args.seed)
        tr = make_trajectory(layout, scene, args.path, seed=args.seed, duration_s=args.duration_s)
        (seq,) = write_recording(
            rig,
            tr,
            record(scene, rig, tr, seed=args.seed, depth_only=True, context=shared_context()),
            Path(args.out) / "odometry",
        )
        what = (
            f"{rig.name} at {rig.sensors[0].rate_hz:g} Hz ({args.strategy}, {args.path}, seed "
            f"{args.seed})"
        )
    scans, gt, times = read_sequence(seq)
    config = KISSConfig()
    config.data.deskew = False  # every scan is taken at one instant
    config.data.max_range = args.max_range
    config.mapping.voxel_size = args.voxel_m
    odo = KissICP(config)
    est = []
    rng = np.random.default_rng(np.random.SeedSequence([args.seed, 0x6B697373]))  # "kiss"
    for scan in scans:
        scan = reduced(scan, args.scan_points, rng=rng)
        odo.register_frame(scan.astype(np.float64), np.zeros(len(scan)))
        est.append(np.array(odo.last_pose))
    ref = PoseTrajectory3D(poses_se3=list(gt), timestamps=times)
    mine = PoseTrajectory3D(poses_se3=est, timestamps=times)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((ref, mine))
    rpe = metrics.RPE(
        metrics.PoseRelation.translation_part,
        delta=1.0,
        delta_unit=metrics.Unit.meters,
        all_pairs=True,
    )
    rpe.process_data((ref, mine))
    length = float(np.linalg.norm(np.diff(gt[:, :3, 3], axis=0), axis=1).sum())
    result = {
        "sequence": str(seq),
        "what": what,
        "scans": len(est),
        "scan_points": args.scan_points,
        "max_range_m": args.max_range,
        "voxel_m": args.voxel_m,
        "length_m": length,
        "duration_s": float(times[-1] - times[0]),
        "ate_rmse_m": float(ape.get_statistic(metrics.StatisticsType.rmse)),
        "ate_max_m": float(ape.get_statistic(metrics.StatisticsType.max)),
        "rpe_per_m_rmse_m": float(rpe.get_statistic(metrics.StatisticsType.rmse)),
        "end_error_m": float(np.linalg.norm(gt[-1][:3, 3] - est[-1][:3, 3])),
    }
    atomic_write_text(Path(args.out) / "odometry.json", json.dumps(result, indent=1))
    print(
        f"KISS-ICP on {len(est)} scans ({args.scan_points or 'all'} points each) of {what} along "
        f"{length:.1f} m: "
        f"evo ATE RMSE {100 * result['ate_rmse_m']:.2f} cm (max {100 * result['ate_max_m']:.2f} "
        "cm), "
        f"RPE per metre {100 * result['rpe_per_m_rmse_m']:.2f} cm, end point "
        f"{100 * result['end_error_m']:.2f} cm"
    )
    return 0
