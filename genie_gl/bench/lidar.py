"""``genie bench lidar``: beams per second of the scanners against Open3D on the same beams,
their agreement, and a walk of the two-head wearable in points per second.

1. For each scanner (``--scanners``) on each benchmark scene (``--scenes``, from
   :mod:`.scenes`): one revolution's beams from a head 1.8 m above the scene's middle, cast
   by genie-gl's exact engine (:func:`genie_gl.capture.scan.cast_beams`) and by Open3D's
   ``RaycastingScene.cast_rays`` on the same beams, in turns (``--repeats``, best of each),
   after each has built its scene once (build times reported apart). Beams per second, the
   ratio, and the agreement: hits, instance ids equal, range p99 relative difference.
2. The wearable (``--rig``, default ``navvis_wearable``) walking ``--walk`` seconds of the
   ``person`` motion through a scene of the ``assembly_line`` strategy with its profiles'
   effects, its scans made by ``--workers`` processes (default: the machine's cores): seconds
   per second of walk and points per second (beside HELIOS++'s published
   ~23 k points/s user run, and the VLP-16's 289,344 beams/s per head); then the same walk
   without ``beam_divergence`` (one ray a beam instead of its footprint's 7), what the
   footprint costs.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

from dataclasses import replace

import numpy as np

from ..capture.scan import cast_beams
from ..capture.scanning import scan
from ..layout import generate_layout
from ..outputs import atomic_write_text
from ..scene import build_scene
from ..sensors.beams import scan_beams
from ..motion.paths import make_trajectory
from ..effects.scanner_profile import load_scanner
from ..motion.scanner_rig import load_scanner_rig
from .scenes import bench_spec, to_scene

HELIOS_PTS_S = 23_000  # HELIOS++ user run, points/s (as the issue cites it)
HEAD_HEIGHT_M = 1.8


def open3d_caster(scene, origin=(0.0, 0.0, 0.0)):
    """Open3D's ray caster of ``scene`` (float32 triangles, one geometry per instance,
    placed in float64 and stored relative to ``origin``, the head's position, so float32
    loses the least near the head), the instance id of each geometry id, and ``origin``."""
    import open3d as o3d

    origin = np.asarray(origin, np.float64)
    rc = o3d.t.geometry.RaycastingScene()
    ids = {}
    for inst in scene.instances:
        m = scene.meshes[inst.mesh]
        v = np.asarray(m.vertices, np.float64) @ inst.world_from_model[:3, :3].T + (
            inst.world_from_model[:3, 3] - origin
        )
        g = rc.add_triangles(
            o3d.core.Tensor(v.astype(np.float32)), o3d.core.Tensor(np.asarray(m.faces, np.uint32))
        )
        ids[g] = inst.instance
    return rc, ids, origin


def open3d_cast(
    caster, origins: np.ndarray, directions: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(distance (0: none), instance) along each ray, by Open3D."""
    import open3d as o3d

    rc, ids, origin = caster
    rays = np.c_[origins - origin, directions].astype(np.float32)
    out = rc.cast_rays(o3d.core.Tensor(rays))
    t = out["t_hit"].numpy().astype(np.float64)
    g = out["geometry_ids"].numpy()
    lut = np.zeros(max(ids) + 2, np.uint32)
    for k, v in ids.items():
        lut[k] = v
    hit = np.isfinite(t)
    inst = np.where(hit, lut[np.minimum(g, len(lut) - 1)], 0).astype(np.uint32)
    return np.where(hit, t, 0.0), inst


def agreement(ours, theirs) -> dict:
    """Hits, ids and ranges of our cast against Open3D's on the same rays."""
    d, inst = theirs
    both = ours.hit & (d > 0)
    rel = np.abs(ours.distance[both] - d[both]) / d[both]
    return {
        "rays": int(len(d)),
        "hit_agree": float(np.mean(ours.hit == (d > 0))),
        "id_agree": float(np.mean(np.where(ours.hit, ours.instance, 0) == inst)),
        "range_rel_p99": float(np.quantile(rel, 0.99)) if rel.size else 0.0,
        "range_rel_max": float(rel.max()) if rel.size else 0.0,
    }


def scene_beams(scene, scanner):
    """One revolution of ``scanner`` (no effects) 1.8 m above the middle of ``scene``."""
    lo, hi = scene.bounds()
    pose = np.eye(4)
    pose[:3, 3] = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, HEAD_HEIGHT_M]
    return scan_beams(scanner, pose, 0.0)


def cast_row(scene, scene_name: str, scanner, repeats: int) -> dict:
    beams = scene_beams(scene, scanner)
    t = time.perf_counter()
    ours = cast_beams(scene, beams.origins, beams.directions)  # builds the engine's hierarchy
    build_ours = time.perf_counter() - t
    t = time.perf_counter()
    caster = open3d_caster(scene, beams.origins[0])
    theirs = open3d_cast(caster, beams.origins, beams.directions)
    build_o3d = time.perf_counter() - t
    best_ours = best_o3d = np.inf
    for _ in range(repeats):  # in turns, so both see the same load
        t = time.perf_counter()
        ours = cast_beams(scene, beams.origins, beams.directions)
        best_ours = min(best_ours, time.perf_counter() - t)
        t = time.perf_counter()
        theirs = open3d_cast(caster, beams.origins, beams.directions)
        best_o3d = min(best_o3d, time.perf_counter() - t)
    n = len(beams)
    return {
        "scene": scene_name,
        "scanner": scanner.name,
        "beams": n,
        "genie_gl_s": best_ours,
        "open3d_s": best_o3d,
        "genie_gl_beams_s": n / best_ours,
        "open3d_beams_s": n / best_o3d,
        "ratio": best_o3d / best_ours,
        "first_cast_s": {"genie_gl": build_ours, "open3d_build_and_cast": build_o3d},
        "agreement": agreement(ours, theirs),
    }


def without_footprint(rig):
    """``rig`` with each head's ``beam_divergence`` left out (one ray per beam)."""
    heads = tuple(
        replace(
            h,
            scanner=replace(
                h.scanner, effects=tuple(e for e in h.scanner.effects if not e.casts_subrays)
            ),
        )
        for h in rig.heads
    )
    return replace(rig, heads=heads)


def walk_row(
    rig_name: str, seconds: float, seed: int, footprint: bool = True, workers: int = 1
) -> dict:
    rig = load_scanner_rig(rig_name)
    rig = rig if footprint else without_footprint(rig)
    layout = generate_layout("assembly_line", seed=seed)
    scene = build_scene(layout, seed=seed)
    path = make_trajectory(layout, scene, "aisles", seed=seed, motion="person", duration_s=seconds)
    scan(scene, rig, path, seed=seed, scans=1)  # warm: the engine's hierarchy and compiled kernels
    t = time.perf_counter()
    scans = scan(scene, rig, path, seed=seed, workers=workers)
    wall = time.perf_counter() - t
    points = int(sum(len(s) for s in scans))
    walk = path.duration_s
    return {
        "rig": rig.name,
        "footprint": footprint,
        "workers": workers,
        "heads": len(rig.heads),
        "walk_s": walk,
        "scans": len(scans),
        "points": points,
        "wall_s": wall,
        "s_per_s_of_walk": wall / walk,
        "points_per_s_made": points / wall,
        "points_per_s_of_walk": points / walk,
        "helios_pts_s": HELIOS_PTS_S,
        "vs_helios": points / wall / HELIOS_PTS_S,
    }


def run(args: argparse.Namespace) -> int:
    out = Path(args.out)
    load = os.getloadavg()
    rows = []
    for name in args.scenes:
        scene = to_scene(bench_spec(name, seed=args.seed))
        for profile in args.scanners.split(","):
            row = cast_row(scene, name, load_scanner(profile), args.repeats)
            rows.append(row)
            a = row["agreement"]
            print(
                f"{name:>4} {row['scanner']:<16} {row['beams']:>8,} beams  genie-gl "
                f"{row['genie_gl_beams_s']:>12,.0f}/s"
                f"  Open3D {row['open3d_beams_s']:>12,.0f}/s  x{row['ratio']:.2f}  ids "
                f"{a['id_agree']:.5%}"
                f"  range p99 {a['range_rel_p99']:.1e}"
            )
    walks = (
        [
            walk_row(args.rig, args.walk, args.seed, footprint, args.workers)
            for footprint in (True, False)
        ]
        if args.walk > 0
        else []
    )
    for walk in walks:
        print(
            f"walk {walk['rig']} ("
            + ("the profiles' effects" if walk["footprint"] else "no beam_divergence: a ray a beam")
            + f", {walk['workers']} worker(s)): {walk['walk_s']:.1f} s, {walk['scans']} scans, "
            f"{walk['points']:,} points in "
            f"{walk['wall_s']:.1f} s ({walk['s_per_s_of_walk']:.2f} s per s of walk; "
            f"{walk['points_per_s_made']:,.0f} points/s made, HELIOS++ ~{HELIOS_PTS_S:,}/s)"
        )
    result = {
        "load_avg_1_5_15": load,
        "cpus": os.cpu_count(),
        "casts": rows,
        "walk": walks[0] if walks else None,
        "walk_beams_only": walks[1] if walks else None,
        "command": "genie bench lidar "
        + " ".join(
            f"--{k.replace('_', '-')} {v}"
            for k, v in (
                ("scenes", ",".join(args.scenes)),
                ("scanners", args.scanners),
                ("repeats", args.repeats),
                ("rig", args.rig),
                ("walk", args.walk),
                ("workers", args.workers),
                ("seed", args.seed),
            )
        ),
    }
    atomic_write_text(out / "lidar.json", json.dumps(result, indent=1))
    return 0
