"""Where ``genie bench accuracy`` runs: the scene, the sensor and the views (a :class:`Case`).

``--scene`` omitted: the built-in analytic scene (:mod:`.analytic`) from the identity pose. A
USD stage (ours or foreign, read with :func:`genie_gl.scene.usd.read_usd`): views aimed at its
labelled objects (:func:`content_poses`). A layout JSON, or a strategy JSON generated with
``--seed``: the scene built with ``--seed`` and cameras placed over the layout. ``--poses``
replaces the views with a file's.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from ..validation.arguments import read_poses
from ..errors import ConfigError
from ..layout import Layout, generate_layout
from ..resources import resolve
from ..scene import build_scene, usd
from ..effects.profile import load_sensor
from ..placement.genetic import place_sensors
from ..sensors.pose import look_at
from ..motion.paths import make_trajectory, path_kind
from ..motion.rig import body_from_sensor
from . import analytic
from .knobs import Case


def content_poses(
    scene, n: int, *, distance_m: float = 4.0, height_m: float = 3.0
) -> list[np.ndarray]:
    """``n`` views of a scene with no layout, aimed at its objects: the centres of labelled
    instances (semantic > 0; all when none is) spread by farthest-point sampling from the one
    nearest the middle, each seen from ``distance_m`` further out and ``height_m`` above it."""
    inst = [i for i in scene.instances if i.semantic > 0] or list(scene.instances)
    if not inst:
        raise ConfigError("--scene: the stage has no geometry to look at")
    centres = []
    for i in inst:
        b = scene.meshes[i.mesh].bounds
        c = (b[0] + b[1]) / 2 if np.all(np.isfinite(b)) else np.zeros(3)
        centres.append(i.world_from_model[:3, :3] @ c + i.world_from_model[:3, 3])
    centres = np.array(centres)
    lo, hi = scene.bounds()
    mid = (lo + hi) / 2
    chosen = [int(np.argmin(np.linalg.norm(centres[:, :2] - mid[:2], axis=1)))]
    dist = np.linalg.norm(centres - centres[chosen[0]], axis=1)
    while len(chosen) < min(n, len(centres)):
        chosen.append(int(np.argmax(dist)))
        dist = np.minimum(dist, np.linalg.norm(centres - centres[chosen[-1]], axis=1))
    poses = []
    for k in range(n):
        t = centres[chosen[k % len(chosen)]]
        out = t[:2] - mid[:2]
        angle = np.arctan2(out[1], out[0]) if np.linalg.norm(out) > 1e-6 else 0.0
        angle += 2 * np.pi * (k // len(chosen)) / max(1, -(-n // len(chosen)))
        eye = [
            t[0] + distance_m * np.cos(angle),
            t[1] + distance_m * np.sin(angle),
            lo[2] + height_m + t[2] - lo[2],
        ]
        poses.append(look_at(eye, t))
    return poses


def check_path(args: argparse.Namespace) -> None:
    """``--path``: with a strategy or layout ``--scene`` only, and no ``--poses`` (checked
    before the output folder is claimed or any scene is read)."""
    if not getattr(args, "path", None):
        return
    if args.scene is None or str(args.scene).lower().endswith((".usd", ".usda", ".usdc", ".usdz")):
        raise ConfigError(
            f"--path {args.path}: frames along a trajectory need a strategy or layout --scene (its "
            "free floor); give one, or drop --path"
        )
    if args.poses:
        raise ConfigError(
            f"--path {args.path}: the trajectory gives the poses; drop --poses {args.poses}"
        )
    path_kind(args.path)


def make_case(args: argparse.Namespace) -> Case:
    """The scene, sensor and poses the rows run on."""
    if args.cameras is not None and args.cameras < 1:
        raise ConfigError(f"--cameras: expected >= 1, got {args.cameras}")
    if args.repeats < 1:
        raise ConfigError(f"--repeats: expected >= 1, got {args.repeats}")
    check_path(args)
    if args.scene is None:
        sensor = analytic.sensor() if args.sensor is None else load_sensor(args.sensor)
        poses = read_poses(args.poses) if args.poses else [np.eye(4)]
        return Case(
            "builtin",
            "built-in analytic scene (wall, floor, box, sphere)",
            sensor,
            poses,
            lambda t: analytic.scene(analytic.DEFAULT_SEGMENTS if t is None else t),
            tessellation_supported=True,
        )
    sensor = load_sensor(args.sensor or "ideal_pinhole")
    path = Path(args.scene)
    if not path.exists():
        path = Path(resolve(args.scene, "layouts", (".json",)))
    if path.suffix.lower() in (".usd", ".usda", ".usdc", ".usdz"):
        supported = True  # read_usd tessellates implicit gprims with segments=

        def usd_scene(t: int | None):
            return (
                usd.read_usd(path, segments=t)
                if (supported and t is not None)
                else usd.read_usd(path)
            )

        scene0 = usd_scene(None)
        poses = read_poses(args.poses) if args.poses else content_poses(scene0, args.cameras)
        return Case(
            "usd",
            str(path),
            sensor,
            poses,
            _cached(usd_scene, scene0),
            tessellation_supported=supported,
        )
    if path.suffix.lower() != ".json":
        raise ConfigError(
            f"--scene {path}: expected a USD stage (.usd/.usda/.usdc) or a layout / strategy JSON"
        )
    data = json.loads(path.read_text())
    layout = (
        Layout.from_json(path)
        if isinstance(data, dict) and "nodes" in data
        else generate_layout(path, seed=args.seed)
    )
    supported = True  # build_scene tessellates curved assets with segments=

    def built(t: int | None):
        if supported and t is not None:
            return build_scene(layout, seed=args.seed, segments=t)
        return build_scene(layout, seed=args.seed)

    if getattr(
        args, "path", None
    ):  # the sensor carried along a trajectory: n frames evenly in time
        poses = path_poses(layout, built(None), sensor, args.path, args.cameras, seed=args.seed)
    else:
        poses = (
            read_poses(args.poses)
            if args.poses
            else place_sensors(layout, sensor, n=args.cameras, seed=args.seed)
        )
    return Case(
        "strategy",
        str(path),
        sensor,
        poses,
        _cached(built, built(None)),
        layout=layout,
        tessellation_supported=supported,
    )


def path_poses(layout, scene, sensor, path: str, n: int, *, seed: int) -> list[np.ndarray]:
    """``n`` poses of ``sensor`` carried (level, tilted 10° down) along a trajectory of kind
    ``path`` (aisles, random or a waypoints file) on the scene's free floor, evenly in time."""
    kind = path_kind(path)
    tr = make_trajectory(
        layout, scene, kind, seed=seed, waypoints=path if kind == "waypoints" else None
    )
    body = tr.at(np.linspace(tr.start_s, tr.end_s, max(1, n)))
    return list(body @ body_from_sensor(pitch_rad=float(np.radians(10.0))))


def _cached(fn, first):
    memo = {None: first}

    def get(t):
        if t not in memo:
            memo[t] = fn(t)
        return memo[t]

    return get
