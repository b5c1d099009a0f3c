"""``genie capture SCENE.usda --sensor PROFILE --cameras K --out DIR --format FMT``.

Renders a USD scene (any stage) from K cameras placed inside it (mounted for the sensor's
range, :func:`genie_gl.placement.genetic.scene_poses`) or from ``--poses FILE``, following the
plan (:mod:`genie_gl.capture.planner`); warns about frames with nothing in range; merges the frames
into
one labelled cloud and exports it. The manifest sums, per effect, the frames it ran on, its
milliseconds and the pixels it changed.
"""

from __future__ import annotations

import argparse

from ..errors import ConfigError, did_you_mean
from ..limits import MAX_CAMERAS, check_disk, check_frames
from . import announce_compilation, count, positive, seed, stages
from .plan import warn_empty


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", help="USD scene (.usda/.usdc/.usd)")
    p.add_argument("--sensor", default="ideal_pinhole", help="sensor profile name or path")
    p.add_argument("--cameras", type=count(1, MAX_CAMERAS), default=8)
    p.add_argument("--out", required=True)
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--format", default="ply")
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument(
        "--mount",
        "--height",
        dest="height",
        type=positive(1e4),
        default=None,
        metavar="M",
        help="camera height above the scene's floor (m); default: chosen for the sensor's range",
    )
    p.add_argument(
        "--poses", help="poses file: .npy (K, 4, 4) or .json [[4x4], ...] (instead of --cameras)"
    )
    p.add_argument(
        "--raster",
        choices=("cpu", "gl"),
        default=None,
        help="which rasteriser draws: cpu (exact, float64, no GL) or gl (OpenGL); default: cpu "
        "without a hardware GPU, else gl",
    )


def run(args: argparse.Namespace) -> int:
    from ..capture import capture, effect_totals
    from ..capture import plan as make_plan
    from ..validation.arguments import read_poses
    from ..cloud import to_cloud
    from ..export import FORMATS, get_format
    from ..outputs import claim_folder
    from ..render.rasters import resolve_raster
    from ..scene.usd import read_usd
    from ..effects.profile import load_sensor
    from ..placement.genetic import scene_poses, sensor_range

    if args.format not in FORMATS:
        raise ConfigError(
            f"--format {args.format!r}: unknown; expected one of {', '.join(FORMATS)}"
            f"{did_you_mean(args.format, FORMATS)}"
        )
    sensor = load_sensor(args.sensor)
    given = read_poses(args.poses) if args.poses else None
    n = len(given) if given is not None else args.cameras
    check_frames(
        n, sensor.width, sensor.height, f"--sensor {args.sensor}, {n} cameras"
    )  # before any work
    fmt = get_format(args.format)
    folder = claim_folder(args.out, "capture", fmt.cloud_outputs("cloud"))  # before any work
    with folder.abandoning():  # a failed run leaves nothing it wrote
        check_disk(
            n * sensor.width * sensor.height * fmt.bytes_per_point,
            args.out,
            f"--out {args.out}",
            fix="use fewer --cameras or a smaller sensor, or free space",
            option=None,
        )
        with stages(
            ["read scene", "plan", "render", "cloud", "export"],
            title="genie capture",
            enabled=not args.no_progress,
        ) as step:
            step("read scene")
            scene = read_usd(args.scene)
            step("place cameras and plan")
            poses = (
                given
                if given is not None
                else scene_poses(scene, sensor, args.cameras, args.seed, mount_height_m=args.height)
            )
            plan = make_plan(scene, sensor, poses)
            warn_empty(plan, "capture")
            announce_compilation("capture")
            step(f"render {len(poses)} cameras")
            raster = resolve_raster(
                args.raster or (sensor.accuracy.raster if sensor.accuracy else None), "--raster"
            )
            frames = capture(
                scene, sensor, poses, seed=args.seed, workers=None, plan=plan, raster=raster
            )
            step("cloud")
            cloud = to_cloud(frames)
            if not len(cloud):
                lo, hi = sensor_range(sensor) or (
                    sensor.near_m,
                    sensor.far_m,
                )  # the profile's range, not the clip's
                lo, hi = max(lo, sensor.near_m), min(hi, sensor.far_m)
                raise ConfigError(
                    f"{args.scene}: no point captured: none of the {len(frames)} cameras of "
                    f"sensor {args.sensor} ({sensor.width}x{sensor.height} px, range "
                    f"{lo:g}-{hi:g} m) saw a surface; check --mount, --poses and the sensor"
                )
            step("export")
            folder.reserve()
            path = fmt.write_cloud(cloud, folder.path, name="cloud")
        folder.finish(
            {
                "scene": args.scene,
                "sensor": args.sensor,
                "cameras": len(poses),
                "seed": args.seed,
                "format": args.format,
                "raster": raster,
                "points": len(cloud),
                "effects": effect_totals(frames),
                "empty_frames": plan.empty_frames,
            }
        )
    print(f"capture: {len(frames)} frames, {len(cloud):,} points -> {path}")
    return 0
