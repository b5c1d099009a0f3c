"""``genie bench pipeline``: seconds per scene end to end at the paper's setup (40 cameras,
640 x 480, the assembly line strategy), the share of each stage, scenes/s against worker
count, and unprojection against a plain numpy version on synthetic and rendered frames.
``--unprojection-only`` skips the dataset runs."""
from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scenes", type=int, default=2)
    p.add_argument("--cameras", type=int, default=40)
    p.add_argument("--sensor", default="ideal_pinhole")
    p.add_argument("--workers", default="1,2")
    p.add_argument("--unprojection-only", action="store_true", help="only the unprojection figures")


def _frames() -> list[tuple[str, list]]:
    """Frames to unproject: a synthetic worst case (10 % of pixels without a return, scattered
    at random, so no run is long) and rendered frames of the assembly line through three
    sensors (a pinhole seeing everything; a D435 with range limits and dropout; an Azure
    Kinect NFOV, whose octagonal field of view leaves the corners empty)."""
    import genie_gl as gg
    from ..frame import Frame
    from ..resources import resolve

    rng = np.random.default_rng(0)
    s = gg.Sensor.pinhole(640, 480, 525.0)
    depth = rng.uniform(1, 10, (480, 640)).astype(np.float32)
    depth[rng.random((480, 640)) < 0.1] = 0
    ids = rng.integers(1, 50, (480, 640))
    out = [("random holes 10%", [Frame(depth, ids.astype(np.uint32), ids.astype(np.uint16), None, s, np.eye(4))])]
    layout = gg.generate_layout(resolve("assembly_line", "layouts", (".json",)), seed=0)
    scene = gg.build_scene(layout, seed=0)
    for label, sensor in (("pinhole", s), ("D435", gg.load_sensor(resolve("realsense_d435", "sensors", (".yaml",)))),
                          ("Azure NFOV", gg.load_sensor(resolve("azure_kinect_nfov", "sensors", (".yaml",))))):
        poses = gg.place_sensors(layout, sensor, n=4, seed=0)
        frames = gg.capture(scene, sensor, poses, seed=0, depth_only=True)
        frames.sort(key=lambda f: -np.count_nonzero(f.depth))  # first, the camera that sees most
        out.append((f"assembly line, {label}", frames))
    return out


def _numpy_unproject(depth, tx, ty, M, semantic, instance):
    """A plain numpy unprojection with per-camera ray tables: mask, gather, transform."""
    m = depth > 0
    d = depth[m]
    x, y = tx[m] * d, ty[m] * d
    xyz = np.empty((len(d), 3), np.float32)
    for r in range(3):
        xyz[:, r] = M[r, 0] * x + M[r, 1] * y + M[r, 2] * d + M[r, 3]
    return xyz, semantic[m], instance[m]


def unprojection(repeats: int = 12, block: int = 5) -> list[dict]:
    """ms per frame: genie-gl's kernel writing into a merged cloud's arrays (as ``to_cloud``
    does), a plain numpy version with a per-camera ray table, and a bare copy of the three
    buffers (the floor: moving the input bytes once). Methods take turns in blocks of
    ``block`` calls (the first of each block not counted), so a drifting machine hits all
    alike and each is timed with warm caches; the median is quoted. The last column, "in
    to_cloud", is the whole merge of the sensor's frames per frame, fresh output arrays (and
    their page faults) included."""
    from ..cloud import to_cloud
    from ..cloud.kernels import count_valid
    from ..cloud.unproject import ray_table, unproject_into

    rows = []
    for name, frames in _frames():
        f = frames[0]
        H, W = f.depth.shape
        tx, ty = (t.reshape(H, W) for t in ray_table(f.sensor))
        M = f.world_from_camera[:3].astype(np.float32)
        n = count_valid(f.depth)
        bufs = np.empty((n + 2, 3), np.float32), np.empty(n + 1, np.uint16), np.empty(n + 1, np.uint32)
        ref = _numpy_unproject(f.depth, tx, ty, M, f.semantic, f.instance)
        assert unproject_into(f, np.zeros(3), *bufs) == n and np.abs(bufs[0][:n] - ref[0]).max() < 1e-3
        fns = {"genie-gl": lambda: unproject_into(f, np.zeros(3), *bufs, n=n),
               "plain numpy": lambda: _numpy_unproject(f.depth, tx, ty, M, f.semantic, f.instance),
               "bare copy": lambda: (f.depth.copy(), f.instance.copy(), f.semantic.copy()),
               "in to_cloud": lambda: to_cloud(frames)}
        ts: dict[str, list[float]] = {k: [] for k in fns}
        for _ in range(repeats):
            for k, fn in fns.items():
                for b in range(block):
                    t = time.perf_counter()
                    fn()
                    if b:
                        per = len(frames) if k == "in to_cloud" else 1
                        ts[k].append(1e3 * (time.perf_counter() - t) / per)
        row = {"frame": name, "size": f"{W}x{H}", "valid_share": n / (W * H)}
        row.update({f"{k} ms": float(np.median(v)) for k, v in ts.items()})
        rows.append(row)
    return rows


def run(args: argparse.Namespace) -> int:
    from ..dataset import DatasetConfig, run_dataset

    results: dict = {"cameras": args.cameras, "sensor": args.sensor, "runs": []}
    for w in [] if args.unprojection_only else [int(x) for x in args.workers.split(",")]:
        tmp = Path(tempfile.mkdtemp(prefix="genie-bench-"))
        cfg = DatasetConfig(strategy="assembly_line", scenes=args.scenes, cameras=args.cameras, sensor=args.sensor,
                            out=str(tmp), workers=w, previews=0)  # the paper's chunks: the defaults
        t = time.perf_counter()
        m = run_dataset(cfg, progress=False)
        wall = time.perf_counter() - t
        shutil.rmtree(tmp, ignore_errors=True)
        stages = m["stage_s_total"]
        total = sum(stages.values())
        results["runs"].append({"workers": w, "wall_s": wall, "scenes_per_s": args.scenes / wall,
                                "s_per_scene_cpu": total / args.scenes, "stage_share": {k: v / total for k, v in stages.items()}})
        print(f"workers {w}: {wall:.1f} s for {args.scenes} scenes -> {args.scenes / wall:.2f} scenes/s; "
              f"{total / args.scenes:.2f} s of stage time per scene")
        print("   share: " + ", ".join(f"{k} {100 * v / total:.0f}%" for k, v in stages.items()))
    u = unprojection()
    results["unprojection_ms_per_frame"] = u
    print("unprojection, ms per frame (median; methods take turns in blocks):")
    print(f"   {'frame':28s} {'size':>8s} {'valid':>6s} {'genie-gl':>9s} {'numpy':>7s} {'copy':>6s} {'vs numpy':>9s}"
          f" {'in to_cloud':>12s}")
    for r in u:
        print(f"   {r['frame']:28s} {r['size']:>8s} {100 * r['valid_share']:5.0f}% {r['genie-gl ms']:9.2f} "
              f"{r['plain numpy ms']:7.2f} {r['bare copy ms']:6.2f} {r['plain numpy ms'] / r['genie-gl ms']:8.1f}x"
              f" {r['in to_cloud ms']:12.2f}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "pipeline.json").write_text(json.dumps(results, indent=1))
    print(f"wrote {out / 'pipeline.json'}")
    return 0
