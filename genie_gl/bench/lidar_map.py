"""``genie bench lidarmap``: a NavVis-class mobile map made by the wearable's scans, cut into
the paper's 25,000-point chunks, its class shares beside Table 3's real column (the paper's
NavVis VLX 2 scans of car assembly lines), and a top view of the map coloured by class."""

from __future__ import annotations

import argparse
import json
import os
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..capture.scanning import scan
from ..capture.trajectory import record
from ..cloud.fusion import fuse
from ..cloud.process import chunks
from ..cloud.scan_map import CHUNK_POINTS, class_shares, scan_map
from ..labels import COLORS_RGB, name
from ..layout import generate_layout
from ..outputs import atomic_write_text
from ..scene import build_scene
from ..motion.paths import make_trajectory
from ..motion.rig import load_rig
from ..motion.scanner_rig import ScannerRig, load_scanner_rig

# Table 3, "# points in real dataset" (3DGENie §4.1.1), classes 0..9 in the label map's order
TABLE3_REAL = (998_260, 14_303, 8_574, 8_933, 14_090, 70_972, 87_646, 1_400, 10_862, 9_955)


def run(args: argparse.Namespace) -> int:
    rig = load_scanner_rig(args.rig)
    if args.ideal:
        rig = ScannerRig(
            rig.name, tuple(replace(h, scanner=replace(h.scanner, effects=())) for h in rig.heads)
        )
    layout = generate_layout(args.strategy, seed=args.seed)
    scene = build_scene(layout, seed=args.seed)
    path = make_trajectory(
        layout, scene, "aisles", seed=args.seed, motion="person", duration_s=args.duration_s
    )
    scans = scan(scene, rig, path, seed=args.seed)
    rng = np.random.default_rng(np.random.SeedSequence([args.seed, 25_000]))
    tiles = scan_map(scans, voxel_m=args.voxel_m, chunk_m=args.chunk_m, rng=rng)
    ours = class_shares([t for _, t in tiles]) if tiles else np.zeros(10)
    real = np.array(TABLE3_REAL, np.float64) / sum(TABLE3_REAL)
    names = [name(k) for k in range(10)]
    depth = _depth_map(args, scene, path) if args.depth_rig else None
    lines = [
        f"{'class':<20}{'LiDAR map':>12}{'Table 3 real':>14}"
        + (f"{'depth rig':>12}" if depth else "")
    ]
    lines += [
        f"{n:<20}{100 * a:>11.2f}%{100 * b:>13.2f}%"
        + (f"{100 * depth[0][k]:>11.2f}%" if depth else "")
        for k, (n, a, b) in enumerate(zip(names, ours, real))
    ]
    print(
        f"{len(scans)} scans over {path.duration_s:.1f} s -> {len(tiles)} chunks of "
        f"{CHUNK_POINTS:,} points"
    )
    print("\n".join(lines))
    out = Path(args.out)
    if tiles:
        _picture(tiles, out / "lidarmap.png")
    atomic_write_text(
        out / "lidarmap.json",
        json.dumps(
            {
                "rig": rig.name,
                "ideal": bool(args.ideal),
                "strategy": args.strategy,
                "seed": args.seed,
                "duration_s": path.duration_s,
                "scans": len(scans),
                "points": int(sum(len(s) for s in scans)),
                "chunks": len(tiles),
                "chunk_points": CHUNK_POINTS,
                "class_share": dict(zip(names, ours.tolist())),
                "table3_real_share": dict(zip(names, real.tolist())),
                **(
                    {
                        "depth_rig": args.depth_rig,
                        "depth_rig_chunks": depth[1],
                        "depth_rig_frames": depth[2],
                        "depth_rig_share": dict(zip(names, depth[0].tolist())),
                    }
                    if depth
                    else {}
                ),
                "load_avg_1_5_15": os.getloadavg(),
            },
            indent=1,
        ),
    )
    return 0


def _depth_map(args, scene, path) -> tuple[np.ndarray, int, int]:
    """A camera rig's depth frames along ``path``, fused at ``--voxel-m`` and cut into the same
    chunks as the scans' map: (class shares (10,), chunks, frames)."""

    b = scene.bounds()
    b[0] -= 0.5
    b[1] += 0.5
    frames = [0]

    def stream():
        for _, frame in record(
            scene, load_rig(args.depth_rig), path, seed=args.seed, depth_only=True
        ):
            frames[0] += 1
            yield frame

    cloud = fuse(stream(), bounds=b, voxel_m=args.voxel_m)
    rng = np.random.default_rng(np.random.SeedSequence([args.seed, 25_000, 1]))
    tiles = chunks(cloud, args.chunk_m, min_points=CHUNK_POINTS, max_points=CHUNK_POINTS, rng=rng)
    return (class_shares([t for _, t in tiles]) if tiles else np.zeros(10)), len(tiles), frames[0]


def _picture(tiles, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    xyz = np.concatenate([t.world_xyz for _, t in tiles])
    sem = np.concatenate([t.semantic for _, t in tiles])
    fig, ax = plt.subplots(figsize=(9, 9), dpi=110)
    rgb = (
        np.array([COLORS_RGB.get(int(k), (128, 128, 128)) for k in range(10)], np.float64)[
            np.minimum(sem, 9)
        ]
        / 255
    )
    order = np.argsort(xyz[:, 2])  # the top of each place drawn last
    ax.scatter(xyz[order, 0], xyz[order, 1], c=rgb[order], s=0.2, linewidths=0)
    ax.set_aspect("equal")
    ax.set_title(
        f"LiDAR mobile map: {len(tiles)} chunks of {CHUNK_POINTS:,} points, coloured by class"
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
