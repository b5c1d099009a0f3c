"""``genie bench NAME``: the benchmarks of :mod:`genie_gl.bench`, one module each with
``run(args) -> int``, listed here with their options (so that ``genie bench NAME --help``
answers without importing the benchmark)."""

from __future__ import annotations

import argparse
import importlib
import os
from collections.abc import Callable

from . import announce_compilation, count, counts, names, positive, seed, seeds

#: the scenes of ``genie bench render`` (genie_gl.bench.scenes.SIZES) and the tools it times
RENDER_SCENES = ("100k", "1M", "10M", "hall", "generated")
RENDER_TOOLS = ("genie-gl", "genie-gl-exact", "genie-gl-gl", "Open3D", "pyrender")
# : ``genie bench odometry``'s defaults (genie_gl.bench.odometry: RATE_HZ, SCAN_POINTS, MAX_RANGE_M,
# VOXEL_M)
ODOMETRY = {"rate_hz": 20.0, "scan_points": 100_000, "max_range": 30.0, "voxel_m": 0.1}


def _render(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--scenes",
        type=names(RENDER_SCENES),
        default="100k,1M,hall",
        help=f"scenes to run, from {', '.join(RENDER_SCENES)}",
    )
    p.add_argument(
        "--repeats",
        type=count(1, 1000),
        default=2,
        help="fresh processes per tool and scene (turns)",
    )
    p.add_argument(
        "--tools",
        type=names(RENDER_TOOLS),
        default="genie-gl,genie-gl-gl,Open3D,pyrender",
        help="tools to time: genie-gl is the default path (the CPU raster without a hardware GPU), "
        "genie-gl-exact the CPU raster, genie-gl-gl the GL raster",
    )
    p.add_argument(
        "--whole-machine",
        action="store_true",
        help="also frames/s of P = cores processes per tool at once",
    )
    p.add_argument(
        "--frames",
        type=count(1, 100_000),
        default=40,
        help="frames per process in the whole-machine run",
    )


def _layout(p: argparse.ArgumentParser) -> None:
    p.add_argument("--repeats", type=count(1, 1000), default=3)


def _accuracy(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--scene",
        default=None,
        help="USD stage, or layout / strategy JSON (default: the built-in analytic case)",
    )
    p.add_argument(
        "--sensor",
        default=None,
        help="sensor profile or calibration file (default: the built-in "
        "rational-lens stereo sensor without --scene, ideal_pinhole with one)",
    )
    p.add_argument(
        "--seed", type=seed, default=0, help="seed of the layout, scene, placement and noise"
    )
    views = p.add_mutually_exclusive_group()
    views.add_argument(
        "--cameras",
        type=count(1, 1000),
        default=3,
        help="cameras placed over the scene (default 3)",
    )
    views.add_argument(
        "--poses", default=None, help="JSON list of 4x4 world_from_camera, or .npy (N, 4, 4)"
    )
    p.add_argument(
        "--path",
        default=None,
        help="with a strategy --scene: the --cameras frames along a trajectory "
        "(aisles, random or a waypoints file) instead of standing cameras",
    )
    p.add_argument(
        "--repeats",
        type=count(1, 1000),
        default=5,
        help="timed passes per row after one warm-up (default 5)",
    )
    p.add_argument(
        "--budget-mm", type=positive(1e6), default=None, help="depth error budget (p99, mm)"
    )
    p.add_argument(
        "--budget-px",
        type=positive(1e6),
        default=None,
        help="silhouette budget (mean edge error, px)",
    )
    p.add_argument(
        "--knobs", default=None, help="comma-separated subset of knobs to run (default: all)"
    )
    p.add_argument(
        "--no-cache",
        action="store_true",
        help="render the exact reference again (default: reuse OUT/cache/reference-*.npz of the "
        "same inputs)",
    )


def _pipeline(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--scenes",
        type=count(1, 10_000),
        default=6,
        help="scenes per run (enough that each worker makes several)",
    )
    p.add_argument("--cameras", type=count(1, 10_000), default=40)
    p.add_argument("--sensor", default="ideal_pinhole")
    p.add_argument(
        "--workers", type=counts(1, 4096), default="1,2", help="worker counts to compare, e.g. 1,2"
    )
    p.add_argument("--repeats", type=count(1, 1000), default=2, help="runs per worker count")
    p.add_argument("--unprojection-only", action="store_true", help="only the unprojection figures")
    p.add_argument("--dataset-only", action="store_true", help="only the dataset runs")
    p.add_argument(
        "--raster",
        choices=("cpu", "gl"),
        default=None,
        help="the dataset runs' raster (default: genie dataset's, the CPU raster without a "
        "hardware GPU)",
    )


def _stability(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--case",
        action="append",
        help="run only this case (repeatable; an unknown name lists them)",
    )


def _planning(p: argparse.ArgumentParser) -> None:
    p.add_argument("--cameras", type=count(1, 1000), default=4)
    p.add_argument("--rounds", type=count(1, 1000), default=3)


def _sequence(p: argparse.ArgumentParser) -> None:
    p.add_argument("--strategy", default="storage_area")
    p.add_argument("--rig", default="d435_quad")
    p.add_argument(
        "--duration-s", type=positive(3600), default=4.0, help="seconds of the trajectory"
    )
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument(
        "--repeat",
        type=count(1, 1000),
        default=2,
        help="alternate the two runs this many times; best of each",
    )


def _odometry(p: argparse.ArgumentParser) -> None:
    p.add_argument("--strategy", default="storage_area")
    p.add_argument("--rig", default="panorama_cube")
    p.add_argument("--path", default="aisles", choices=("aisles", "random"))
    p.add_argument(
        "--duration-s", type=positive(3600), default=10.0, help="seconds of the trajectory"
    )
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument(
        "--rate-hz",
        type=positive(1000.0),
        default=ODOMETRY["rate_hz"],
        help="every rig sensor's frame rate (panorama_cube's own: 5)",
    )
    p.add_argument(
        "--sequence",
        default=None,
        help="a SemanticKITTI sequence folder to run on instead of recording one",
    )
    p.add_argument(
        "--scan-points",
        type=count(0, 10**8),
        default=ODOMETRY["scan_points"],
        help="points drawn at random from each scan before KISS-ICP sees it (0: every point)",
    )
    p.add_argument(
        "--max-range",
        type=positive(1000.0),
        default=ODOMETRY["max_range"],
        help="KISS-ICP's max_range (m)",
    )
    p.add_argument(
        "--voxel-m",
        type=positive(10.0),
        default=ODOMETRY["voxel_m"],
        help="KISS-ICP's map voxel size (m)",
    )


def _lidar(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--scenes", type=names(RENDER_SCENES), default="1M,10M", help="benchmark scenes to cast on"
    )
    p.add_argument(
        "--scanners",
        default="velodyne_vlp16,ouster_os1_128",
        help="scanner profiles, comma-separated",
    )
    p.add_argument(
        "--repeats", type=count(1, 1000), default=3, help="casts per tool, in turns (best kept)"
    )
    p.add_argument("--rig", default="navvis_wearable", help="scanner rig of the walk")
    p.add_argument(
        "--walk", type=float, default=10.0, help="seconds of the wearable's walk (0: none)"
    )
    p.add_argument(
        "--workers",
        type=count(1, 4096),
        default=os.cpu_count() or 1,
        help="processes making the walk's scans (default: the machine's cores)",
    )
    p.add_argument("--seed", type=seed, default=0)


def _deskew(p: argparse.ArgumentParser) -> None:
    p.add_argument("--strategy", default="assembly_line", help="layout strategy of the scene")
    p.add_argument(
        "--duration-s", type=positive(3600), default=10.0, help="seconds of each fast walk"
    )
    p.add_argument("--max-range", type=positive(1e4), default=30.0, help="KISS-ICP's max range (m)")
    p.add_argument("--voxel-m", type=positive(100), default=0.1, help="KISS-ICP's map voxel (m)")
    p.add_argument(
        "--turn-deg-s", type=positive(720), default=60.0, help="the walk's fastest turn (deg/s)"
    )
    p.add_argument(
        "--turn-ease-s",
        type=positive(10.0, zero=True),
        default=0.4,
        help="seconds over which a turn's rate builds up and dies away (0: at once)",
    )
    p.add_argument(
        "--seeds",
        type=seeds,
        default="0,1,2,3",
        help="one walk, in its own scene, per seed",
    )


def _lidarmap(p: argparse.ArgumentParser) -> None:
    p.add_argument("--rig", default="navvis_wearable", help="scanner rig walking the aisles")
    p.add_argument("--strategy", default="assembly_line", help="layout strategy of the scene")
    p.add_argument("--duration-s", type=positive(3600), default=20.0, help="seconds of the walk")
    p.add_argument(
        "--voxel-m", type=positive(10), default=0.02, help="the map's voxel before chunking (m)"
    )
    p.add_argument("--chunk-m", type=positive(1000), default=6.0, help="side of a chunk (m)")
    p.add_argument(
        "--ideal", action="store_true", help="the heads without their profiles' effects (faster)"
    )
    p.add_argument(
        "--depth-rig",
        default=None,
        help="also a camera rig's depth map along the same walk, cut the same "
        "way (e.g. d435_quad; its class shares in a column beside)",
    )
    p.add_argument("--seed", type=seed, default=0)


def _cli(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--repeats", type=count(1, 1000), default=15, help="runs of each command line (default 15)"
    )
    p.add_argument(
        "--against",
        default=None,
        metavar="DIR",
        help="also time the package of another checkout (DIR/genie_gl), in turns with this one",
    )


# name -> (one-line help, its options, the files it writes under --out: claimed before it runs,
# so a user's file of the same name is never replaced; anything else it makes there is recorded)
BENCHMARKS: dict[str, tuple[str, Callable[[argparse.ArgumentParser], None], tuple[str, ...]]] = {
    "render": (
        "renderer against pyrender and Open3D (ms/frame, frames/s, ratios)",
        _render,
        ("render.json",),
    ),
    "layout": (
        "layout engine throughput, the paper's Table 7 (nodes/s)",
        _layout,
        ("layout.json", "layout.png"),
    ),
    "accuracy": (
        "what accuracy costs on your scene and sensor: every knob's error vs ms, Pareto plot, "
        "--budget-mm",
        _accuracy,
        ("accuracy.json", "accuracy.md", "accuracy.png", "accuracy.yaml", "cache"),
    ),
    "pipeline": (
        "seconds per scene end to end, share of each stage, scaling with workers",
        _pipeline,
        ("pipeline.json",),
    ),
    "stability": (
        "hard cases against analytic truth: tolerance and worst error per case (exit 1 on a "
        "failure)",
        _stability,
        ("stability.json",),
    ),
    "planning": (
        "a full D435 and Azure frame before and after planning, as multiples of the ideal render",
        _planning,
        ("planning.json",),
    ),
    "sequence": (
        "frames/s along a trajectory against the same number of standing frames",
        _sequence,
        ("sequence.json",),
    ),
    "odometry": (
        "KISS-ICP on a SemanticKITTI sequence of a rig's recording; evo's ATE against its ground "
        "truth",
        _odometry,
        ("odometry.json", "odometry"),
    ),
    "lidar": (
        "scanners' beams/s against Open3D on the same beams, agreement, and a wearable's walk in "
        "points/s",
        _lidar,
        ("lidar.json",),
    ),
    "deskew": (
        "a VLP-16's raw scans of fast walks through KISS-ICP with deskew on, off, time "
        "shuffled and by the true poses (evo ATE)",
        _deskew,
        ("deskew.json",),
    ),
    "lidar_map": (
        "the wearable's LiDAR mobile map in 25,000-point chunks: class shares beside Table 3's "
        "real column",
        _lidarmap,
        ("lidarmap.json", "lidarmap.png"),
    ),
    "cli": (
        "seconds `genie --help` and every subcommand's --help take (median of fresh processes)",
        _cli,
        ("cli.json",),
    ),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="bench", metavar="NAME", required=True)
    for name, (help_text, options, _) in BENCHMARKS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        p.add_argument(
            "--out", default="out/bench", help="folder for the figures (default out/bench)"
        )
        options(p)


def run(args: argparse.Namespace) -> int:
    from ..outputs import claim_folder

    mod = importlib.import_module(f"genie_gl.bench.{args.bench}")
    check = getattr(mod, "check_arguments", None)
    if check is not None:  # a benchmark's own option checks, before its folder is claimed
        check(args)
    folder = claim_folder(args.out, "bench", BENCHMARKS[args.bench][2], reserve=True)
    # a failed run leaves nothing it wrote but its cache (finished references, reused)
    with folder.abandoning(keep=("cache",)):
        announce_compilation(f"bench {args.bench}")
        code = int(mod.run(args) or 0)
        folder.finish({"last": args.bench})
    return code
