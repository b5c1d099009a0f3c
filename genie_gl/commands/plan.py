"""``genie plan --scene SCENE.usda --sensor PROFILE [--cameras K | --poses FILE] [--json]``.

Prints, before anything is rendered, what a capture of the scene would do: per effect how
many frames run it, skip it (and why) or decide on the rendered frame; frames with nothing in
range; the instances culled; the predicted time of the capture and of a dataset run of
``--scenes`` such scenes.
"""

from __future__ import annotations

import argparse
import json
import sys

from ..errors import ConfigError
from ..limits import MAX_CAMERAS
from . import announce_compilation, count, positive, seed, stages


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scene", required=True, help="USD scene (.usda/.usdc/.usd)")
    p.add_argument("--sensor", default="ideal_pinhole", help="sensor profile name or path")
    g = p.add_mutually_exclusive_group()
    g.add_argument(
        "--cameras",
        type=count(1, MAX_CAMERAS),
        default=None,
        help="cameras placed inside the scene (default 8)",
    )
    g.add_argument(
        "--poses", help="poses file: .npy (K, 4, 4) or .json [[4x4], ...] world_from_camera"
    )
    p.add_argument(
        "--mount",
        type=positive(1e4),
        default=None,
        metavar="M",
        help="camera height above the floor (m); default: chosen for the sensor's range",
    )
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument(
        "--scenes",
        type=count(1, 1_000_000),
        default=1,
        help="scenes of a dataset run, for the predicted time",
    )
    p.add_argument("--json", action="store_true", help="print the whole plan as JSON")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument(
        "--rig",
        default=None,
        help="plan a rig's recording along a trajectory (a rig file or shipped name)",
    )
    p.add_argument(
        "--path", default=None, help="with --rig: aisles (default), random, or a waypoints file"
    )
    p.add_argument(
        "--duration-s",
        type=positive(3600),
        default=None,
        help="with --rig: seconds of the trajectory (default 20)",
    )
    p.add_argument(
        "--registration",
        choices=("mobile", "none"),
        default=None,
        help="with --rig: predict a mobile-scan map's registration error per frame",
    )


def scene_layout(scene):
    """A layout of one floor region over the scene's footprint (a scene without its layout)."""
    from ..layout.model import Layout, Region, RegionType

    lo, hi = scene.bounds()
    w, h = float(hi[0] - lo[0]), float(hi[1] - lo[1])
    floor = Region(float(lo[0]), float(lo[1]), w, h, type="floor")
    return Layout.from_regions(
        [floor], {"floor": RegionType("floor")}, (float(lo[0]), float(lo[1]), w, h)
    )


def run_recording(args: argparse.Namespace) -> int:
    from ..capture.trajectory import plan_recording
    from ..scene.usd import read_usd
    from ..motion.paths import make_trajectory, path_kind
    from ..motion.registration import registration_of
    from ..motion.rig import load_rig

    rig = load_rig(args.rig)
    path = args.path or "aisles"
    kind = path_kind(path)
    scene = read_usd(args.scene)
    tr = make_trajectory(
        scene_layout(scene),
        scene,
        kind,
        seed=args.seed,
        duration_s=args.duration_s or 20.0,
        waypoints=path if kind == "waypoints" else None,
    )
    p = plan_recording(scene, rig, tr, registration=registration_of(args.registration or "none"))
    print(json.dumps(p.to_dict(), indent=1) if args.json else p.summary())
    for name, sp in p.plans.items():
        warn_empty(sp, f"plan [{name}]")
    return 0


def scene_sensor_poses(args: argparse.Namespace, step=lambda name: None):
    from ..validation.arguments import read_poses
    from ..scene.usd import read_usd
    from ..effects.profile import load_sensor
    from ..placement.genetic import scene_poses

    sensor = load_sensor(args.sensor)
    given = read_poses(args.poses) if getattr(args, "poses", None) else None
    step("read scene")
    scene = read_usd(args.scene)
    step(f"place {args.cameras} cameras" if given is None else "read poses")
    poses = (
        given
        if given is not None
        else scene_poses(scene, sensor, args.cameras, args.seed, mount_height_m=args.mount)
    )
    return scene, sensor, poses


def warn_empty(plan, command: str) -> None:
    for f in plan.frames:
        if f.empty:
            print(
                f"genie {command}: warning: frame {f.index}: {f.reason} (its cloud will be empty)",
                file=sys.stderr,
            )


# options of one kind of plan that the other does not use: given to it, refused (never ignored)
STANDING = (("cameras", "--cameras"), ("poses", "--poses"), ("mount", "--mount"))
MOVING = (("path", "--path"), ("duration_s", "--duration-s"), ("registration", "--registration"))


def check_kind(args: argparse.Namespace) -> None:
    """A plan of standing cameras or (``--rig``) of a recording: refuse the other's options."""
    moving = bool(getattr(args, "rig", None))
    for key, option in STANDING if moving else MOVING:
        if getattr(args, key, None) is not None:
            raise ConfigError(
                f"{option} {getattr(args, key)}: "
                + (
                    "a plan with --rig places no standing cameras (the trajectory carries the "
                    "rig); drop it"
                    if moving
                    else "is for a rig's recording; give --rig RIG too, or drop it"
                )
            )


def run(args: argparse.Namespace) -> int:
    check_kind(args)
    if getattr(args, "rig", None):
        return run_recording(args)
    if args.cameras is None:
        args.cameras = 8
    from ..capture import plan as make_plan

    announce_compilation("plan")
    with stages(
        ["read scene", "place cameras", "plan"],
        title="genie plan",
        enabled=not getattr(args, "no_progress", False),
    ) as step:
        scene, sensor, poses = scene_sensor_poses(args, step)
        step(f"plan {len(poses)} frames over {len(scene.instances):,} instances")
        p = make_plan(scene, sensor, poses)
    if args.json:
        out = p.to_dict()
        out["predicted_dataset_s"] = round(p.predicted_s * max(1, args.scenes), 3)
        print(json.dumps(out, indent=1))
    else:
        print(p.summary())
        for f in p.frames:
            culled = (
                f"{len(f.culled_range)} culled by range"
                if len(f.culled_range)
                else "none culled by range"
            )
            print(
                f"  frame {f.index}: {len(f.drawn)} drawn, {culled}, far plane {f.far_m:.2f} m, "
                f"~{f.cost_ms:.0f} ms" + (f" — {f.reason}" if f.empty else "")
            )
        print(
            f"predicted: {p.predicted_s:.2f} s for this capture; "
            f"{p.predicted_s * max(1, args.scenes):.1f} s "
            f"of capture for {max(1, args.scenes)} scene(s) of {len(poses)} cameras"
        )
    warn_empty(p, "plan")
    return 0
