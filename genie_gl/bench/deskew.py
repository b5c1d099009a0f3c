"""``genie bench deskew``: the motion skew of a spinning head, proven from outside.

A VLP-16 (ideal: no effects) rides a fast walk with turns through a scene of ``--strategy``,
once per seed (``--seeds``: each its own scene and walk); its raw scans (each point in the
head's frame at its own firing, with its time from the scan start, as a driver publishes
them) go through the KISS-ICP odometry pipeline four times:

- ``deskew on``: KISS-ICP's own deskewing, from the per-point times;
- ``deskew off``: the scans taken as if at one instant;
- ``time shuffled``: deskewing on, the time field permuted within each scan;
- ``true poses``: each raw point moved by the head's true pose at its own time into the
  head's frame at the scan's end, deskewing off: what a perfect deskew gives, so KISS-ICP's
  own error (its drift in the scene) is told apart from the skew's.

evo's absolute trajectory error (translation RMSE, the two trajectories starting together)
and relative pose error from one scan to the next (translation and rotation RMSE), against
the head's true pose at each scan's end (KISS-ICP deskews to the scan's end), then show what
the time field buys, seed by seed and as the mean and range over the seeds. It
also checks, without KISS-ICP, that the raw points moved by the true pose at their own times
lie on the scene's surfaces (the distance to the exact hit, max over every point).

The walk turns at ``--turn-deg-s`` at most (60 deg/s by default, a person's brisk turn),
each turn's rate built up and let go over ``--turn-ease-s`` (0.4 s by default, an
engineering figure for a person leaning into a turn; 0: at full rate at once, where a
straight leg meets an arc). KISS-ICP
deskews a scan by the motion of the scan before it, so a turn that starts at once is
deskewed as if straight: up to 6 deg of a scan wrong at 60 deg/s, and from about 90 deg/s its
registration loses the path at a turn's start whatever the time field says; eased over
0.4 s, 120 deg/s turns are followed (docs/lidar.md).

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

SPEED_MPS = 1.8  # a brisk walk: the skew of one 10 Hz scan is 18 cm (and 6 deg in a turn)
MODES = ("deskew on", "deskew off", "time shuffled", "true poses")


def fast_walk(turn_deg_s: float, turn_ease_s: float = 0.0) -> Motion:
    """The walk's motion: 1.8 m/s, turning at ``turn_deg_s`` at most, its turns eased over
    ``turn_ease_s`` (:class:`~genie_gl.motion.follow.Motion`)."""
    return Motion(
        speed_mps=SPEED_MPS,
        height_m=1.7,
        max_yaw_rate_rad_s=float(np.radians(turn_deg_s)),
        max_accel_mps2=1.5,
        turn_ease_s=turn_ease_s,
    )


def own_time_world(s, path) -> np.ndarray:
    """(n, 3) scan ``s``'s raw points moved by the head's true pose on ``path`` at their own
    times: where in the world they were cast to."""
    poses = path.at(np.minimum(s.start_s + s.time_s, path.end_s))
    return np.einsum("nij,nj->ni", poses[:, :3, :3], s.sensor_xyz) + poses[:, :3, 3]


def at_scan_end(scans, path, period_s: float) -> list[np.ndarray]:
    """Each scan's raw points moved by the head's true pose at their own times into the head's
    frame at the scan's end (a perfect deskew)."""
    out = []
    for s in scans:
        end = np.linalg.inv(path.at(np.minimum(np.array([s.start_s + period_s]), path.end_s))[0])
        out.append(own_time_world(s, path) @ end[:3, :3].T + end[:3, 3])
    return out


def odometry(
    scans,
    mode: str,
    *,
    max_range: float,
    voxel_m: float,
    rng: np.random.Generator,
    deskewed: list[np.ndarray] | None = None,
) -> np.ndarray:
    """(n, 4, 4) KISS-ICP's pose of each scan (the first the identity); ``deskewed``: the
    scans' points of the ``true poses`` mode (:func:`at_scan_end`)."""
    from kiss_icp.config import KISSConfig
    from kiss_icp.kiss_icp import KissICP

    config = KISSConfig()
    config.data.deskew = mode in ("deskew on", "time shuffled")
    config.data.max_range = max_range
    config.mapping.voxel_size = voxel_m
    odo = KissICP(config)
    out = []
    for i, s in enumerate(scans):
        t = s.time_s.copy()
        if mode == "time shuffled":
            t = rng.permutation(t)
        xyz = deskewed[i] if mode == "true poses" else s.sensor_xyz
        odo.register_frame(np.ascontiguousarray(xyz, dtype=np.float64), t)
        out.append(np.array(odo.last_pose))
    return np.stack(out)


def ate(gt: np.ndarray, est: np.ndarray, times: np.ndarray) -> dict:
    """evo's absolute trajectory error (translation) of ``est`` against ``gt`` ((n, 4, 4) each,
    starting together), and its relative pose error from one scan to the next (translation,
    m, and rotation, deg): the drift a scene lets KISS-ICP gather aside, what each scan's
    registration gets wrong, where a skewed scan shows first."""
    from evo.core import metrics
    from evo.core.trajectory import PoseTrajectory3D

    ref = PoseTrajectory3D(poses_se3=list(gt), timestamps=times)
    mine = PoseTrajectory3D(poses_se3=list(est), timestamps=times)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((ref, mine))
    out = {
        "ate_rmse_m": float(ape.get_statistic(metrics.StatisticsType.rmse)),
        "ate_max_m": float(ape.get_statistic(metrics.StatisticsType.max)),
        "end_error_m": float(np.linalg.norm(gt[-1][:3, 3] - est[-1][:3, 3])),
    }
    for key, relation in (
        ("rpe_t_rmse_m", metrics.PoseRelation.translation_part),
        ("rpe_r_rmse_deg", metrics.PoseRelation.rotation_angle_deg),
    ):
        rpe = metrics.RPE(relation, delta=1, delta_unit=metrics.Unit.frames, all_pairs=False)
        rpe.process_data((ref, mine))
        out[key] = float(rpe.get_statistic(metrics.StatisticsType.rmse))
    return out


def one_walk(args: argparse.Namespace, seed: int) -> dict:
    """The four modes' ATE on the walk of ``seed`` (printed as they come)."""
    layout = generate_layout(args.strategy, seed=seed)
    scene = build_scene(layout, seed=seed)
    path = make_trajectory(
        layout,
        scene,
        "random",
        seed=seed,
        motion=fast_walk(args.turn_deg_s, args.turn_ease_s),
        duration_s=args.duration_s,
    )
    head = replace(load_scanner("velodyne_vlp16"), effects=())
    scans = scan(scene, ScannerRig.single(head), path, seed=seed)
    # ground truth: the head at each scan's end, relative to the first scan's end
    ends = np.array([s.start_s + head.scan_period_s for s in scans])
    gt_world = path.at(np.minimum(ends, path.end_s))
    gt = np.linalg.inv(gt_world[0]) @ gt_world
    # raw points moved by the true pose at their own time: on the surfaces they were cast to
    worst = 0.0
    for s in scans:
        moved = own_time_world(s, path)
        worst = max(worst, float(np.linalg.norm(moved - s.world_xyz, axis=1).max(initial=0.0)))
    length = float(np.linalg.norm(np.diff(path.positions, axis=0), axis=1).sum())
    yaw = np.unwrap(np.arctan2(gt_world[:, 1, 0], gt_world[:, 0, 0]))
    turned = float(np.degrees(np.abs(np.diff(yaw)).sum()))
    print(
        f"seed {seed}: {len(scans)} scans over {path.duration_s:.1f} s, {length:.1f} m, turning "
        f"{turned:.0f} deg; raw points moved by their own time's pose lie {1000 * worst:.3f} mm "
        "(max) from their surface hits",
        flush=True,
    )
    deskewed = at_scan_end(scans, path, head.scan_period_s)
    rows: dict = {}
    for mode in MODES:
        rng = np.random.default_rng(np.random.SeedSequence([seed, MODES.index(mode)]))
        est = odometry(
            scans,
            mode,
            max_range=args.max_range,
            voxel_m=args.voxel_m,
            rng=rng,
            deskewed=deskewed,
        )
        rows[mode] = ate(gt, est, ends)
        row = rows[mode]
        print(
            f"  {mode:>14}: evo ATE RMSE {100 * row['ate_rmse_m']:6.2f} cm (max "
            f"{100 * row['ate_max_m']:6.2f} cm), end point {100 * row['end_error_m']:6.2f} cm; "
            f"RPE a scan {1000 * row['rpe_t_rmse_m']:5.1f} mm, {row['rpe_r_rmse_deg']:5.2f} deg",
            flush=True,
        )
    return {
        "seed": seed,
        "scans": len(scans),
        "duration_s": path.duration_s,
        "length_m": length,
        "turned_deg": turned,
        "own_time_pose_max_error_m": worst,
        "modes": rows,
    }


FIGURES = ("ate_rmse_m", "rpe_t_rmse_m", "rpe_r_rmse_deg")  # summarised over the walks


def summary(walks: list[dict]) -> dict:
    """Per mode and figure of :data:`FIGURES`, over the walks: the mean, the least, the
    greatest, and on how many walks the mode beats ``deskew off``."""
    out: dict = {}
    for mode in MODES:
        out[mode] = {}
        for key in FIGURES:
            e = np.array([w["modes"][mode][key] for w in walks])
            off = np.array([w["modes"]["deskew off"][key] for w in walks])
            out[mode][key] = {
                "mean": float(e.mean()),
                "min": float(e.min()),
                "max": float(e.max()),
                "walks_better_than_off": int((e < off).sum()),
            }
    return out


def run(args: argparse.Namespace) -> int:
    result = {
        "strategy": args.strategy,
        "seeds": list(args.seeds),
        "motion": {
            "speed_mps": SPEED_MPS,
            "max_yaw_rate_deg_s": args.turn_deg_s,
            "turn_ease_s": args.turn_ease_s,
        },
        "duration_s": args.duration_s,
        "max_range_m": args.max_range,
        "voxel_m": args.voxel_m,
        "walks": [],
        "load_avg_1_5_15": os.getloadavg(),
    }
    for seed in args.seeds:  # each walk's figures written as soon as they are known
        result["walks"].append(one_walk(args, seed))
        result["summary"] = summary(result["walks"])
        atomic_write_text(Path(args.out) / "deskew.json", json.dumps(result, indent=1))
    n = len(result["walks"])
    print(f"over {n} walks: mean (least-greatest), walks better than deskew off")
    for mode, row in result["summary"].items():
        a, t, r = (row[key] for key in FIGURES)
        print(
            f"  {mode:>14}: ATE RMSE {100 * a['mean']:6.2f} cm ({100 * a['min']:.2f}-"
            f"{100 * a['max']:.2f}), {a['walks_better_than_off']} of {n}; RPE a scan "
            f"{1000 * t['mean']:5.1f} mm ({1000 * t['min']:.1f}-{1000 * t['max']:.1f}), "
            f"{t['walks_better_than_off']} of {n}; {r['mean']:.2f} deg ({r['min']:.2f}-"
            f"{r['max']:.2f}), {r['walks_better_than_off']} of {n}",
            flush=True,
        )
    return 0
