"""``genie dataset STRATEGY --scenes N --cameras K --sensor S --format F --out DIR``."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from ..limits import MAX_REGIONS
from . import announce_compilation


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("strategy", help="strategy JSON file, or a shipped name (assembly_line, ...)")
    p.add_argument("--scenes", type=int, default=3)
    p.add_argument(
        "--cameras", type=int, default=None, help="standing cameras per scene (default 8)"
    )
    p.add_argument(
        "--sensor", default="realsense_d435", help="sensor profile: a file, or a shipped name"
    )
    p.add_argument(
        "--format",
        default="semantickitti",
        help="a format of genie_gl.export (default semantickitti; an unknown name lists them)",
    )
    p.add_argument("--out", required=True)
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    p.add_argument("--seed", type=int, default=0, help="dataset seed, >= 0")
    p.add_argument("--points", type=int, default=25000, help="points per chunk (the paper: 25 000)")
    p.add_argument("--chunk-m", type=float, default=12.0, help="chunk size in metres")
    p.add_argument("--min-points", type=int, default=2000)
    p.add_argument("--min-labelled-share", type=float, default=0.05)
    p.add_argument("--previews", type=int, default=3, help="scenes that get preview pictures")
    p.add_argument(
        "--mount",
        type=float,
        default=None,
        metavar="M",
        help="camera height above the floor (m); default: chosen for the sensor's range",
    )
    p.add_argument(
        "--split",
        default="0.8,0.1,0.1",
        help="SemanticKITTI train,valid,test shares of the sequences (deterministic, in order)",
    )
    p.add_argument("--executor", choices=("process", "ray"), default="process")
    p.add_argument("--address", default=None, help="Ray cluster address (with --executor ray)")
    p.add_argument(
        "--max-nodes",
        type=int,
        default=MAX_REGIONS,
        help="limit on a layout's regions (see README: limits)",
    )
    p.add_argument(
        "--max-memory-gb",
        type=float,
        default=None,
        help="memory limit (default: 80%% of what is free)",
    )
    p.add_argument(
        "--max-disk-gb",
        type=float,
        default=None,
        help="disk limit (default: the free space of --out)",
    )
    p.add_argument(
        "--class-balance",
        default=None,
        metavar="paper|FILE",
        help="sub-sample chunks and points towards a class distribution: 'paper' (Table 3's "
        "synthetic column), 'paper-real' (its real column) or a JSON file {class: share}",
    )
    p.add_argument(
        "--points-budget",
        type=int,
        default=None,
        metavar="N",
        help="at most N points in the dataset",
    )
    p.add_argument(
        "--verify", action="store_true", help="check finished scenes' file hashes, not only sizes"
    )
    p.add_argument("--no-progress", action="store_true")
    p.add_argument(
        "--capture",
        default=None,
        metavar="MODE",
        help="the capture mode: static (standing cameras placed for coverage; the default), "
        "trajectory "
        "(a rig's recording along a trajectory), mobile-map (a mobile-scan map fused from it), "
        "scans (a "
        "scanner rig's raw scans along a trajectory) or scan-map (a map fused from them)",
    )
    p.add_argument(
        "--rig",
        default=None,
        help="trajectory/mobile-map: a rig file or shipped name (d435_quad, "
        "panorama_cube); default: --sensor alone at 10 Hz; scans/scan-map: "
        "a scanner rig (navvis_wearable, forklift_vlp16)",
    )
    p.add_argument(
        "--path",
        default=None,
        help="trajectory: aisles, random, or a waypoints file ('x y' per line)",
    )
    p.add_argument(
        "--motion",
        choices=("person", "robot"),
        default=None,
        help="trajectory: speed, height, turning rate and clearance of the body",
    )
    p.add_argument(
        "--duration-s",
        type=float,
        default=None,
        help="trajectory: seconds of it to capture (default 20)",
    )
    p.add_argument(
        "--voxel-m",
        type=float,
        default=None,
        help="mobile-map: the map's voxel (its density; default 0.02)",
    )
    p.add_argument(
        "--registration",
        choices=("mobile", "none"),
        default=None,
        help="mobile-map: a mobile scanner's registration error (drift, pass misalignment) or none",
    )
    p.add_argument(
        "--cloud-stride",
        type=int,
        default=None,
        metavar="K",
        help="rosbag: the points clouds from every K-th pixel row and column (1/K^2 of the points; "
        "the "
        "depth images keep every pixel)",
    )
    p.add_argument(
        "--accuracy",
        default=None,
        metavar="FILE",
        help="accuracy settings: a file with an accuracy: block (genie bench accuracy --budget-mm "
        "writes one)",
    )
    p.add_argument(
        "--raster",
        choices=("cpu", "gl"),
        default=None,
        help="which rasteriser draws: cpu (exact, float64, no GL) or gl (OpenGL); default: cpu "
        "without a hardware GPU, else gl"
        "; a resumed dataset keeps the one its manifest records",
    )


def config_from_args(args: argparse.Namespace):
    """The :class:`~genie_gl.dataset.DatasetConfig` of the options, checked."""
    from ..dataset.config import DatasetConfig, accuracy_option, parse_split

    fields = {
        k: getattr(args, k)
        for k in (
            "strategy",
            "scenes",
            "cameras",
            "sensor",
            "format",
            "out",
            "workers",
            "seed",
            "points",
            "chunk_m",
            "min_points",
            "min_labelled_share",
            "previews",
            "executor",
            "address",
            "max_nodes",
            "max_memory_gb",
            "max_disk_gb",
            "capture",
            "rig",
            "path",
            "motion",
            "duration_s",
            "voxel_m",
            "registration",
            "raster",
            "cloud_stride",
        )
    }
    fields["mount_m"] = args.mount
    for k in (
        "cameras",
        "capture",
        "rig",
        "path",
        "motion",
        "duration_s",
        "voxel_m",
        "registration",
        "cloud_stride",
    ):
        if (
            fields[k] is None
        ):  # not given: the configuration's default (an option given is checked against --capture)
            del fields[k]
    fields["split"] = parse_split(args.split)
    fields["accuracy"] = accuracy_option(
        getattr(args, "accuracy", None)
    )  # read and checked before any work
    fields["class_balance"] = args.class_balance or None  # curation: genie_gl/dataset/curation.py
    fields["points_budget"] = args.points_budget
    return DatasetConfig.parse(fields, "")


def run(args: argparse.Namespace) -> int:
    from ..dataset import run_dataset

    cfg = config_from_args(args)
    m = run_dataset(
        cfg,
        progress=not args.no_progress,
        verify=args.verify,
        on_start=lambda: announce_compilation("dataset"),
    )
    warm = m["runs"][-1].get("warmup_s", []) if m.get("runs") else []
    warm_text = (
        f" (warm-up per worker before its first scene: {', '.join(f'{w:.1f}' for w in warm)} s)"
        if warm
        else ""
    )
    previews = Path(cfg.out) / "previews"
    shown = f" (previews in {previews})" if cfg.previews and previews.is_dir() else ""
    print(
        f"dataset: {m['scenes_made']} scenes made, {m['scenes_skipped']} already there, "
        f"{m['wall_s']:.1f} s{warm_text} -> {cfg.out}{shown}"
    )
    return 0
