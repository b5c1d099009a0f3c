"""``genie bench pipeline``: seconds per scene end to end at the paper's setup (40 cameras,
640 x 480, the assembly line strategy), the share of each stage, scenes/s against worker
count, and unprojection against a plain numpy version."""
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


def unprojection(repeats: int = 30) -> dict:
    """ms per 640x480 frame (10 % of pixels without a return): genie-gl's fused kernel writing
    into a merged cloud (as ``to_cloud`` does) and ``unproject`` (which also allocates its
    arrays), a plain numpy version with a per-camera ray table, and a bare copy of the three
    buffers (the floor: moving the bytes once)."""
    from ..cloud.unproject import ray_table, unproject, unproject_into
    from ..frame import Frame
    from ..sensors.camera import Sensor

    s = Sensor.pinhole(640, 480, 525.0)
    rng = np.random.default_rng(0)
    depth = rng.uniform(1, 10, (480, 640)).astype(np.float32)
    depth[rng.random((480, 640)) < 0.1] = 0
    pose = np.eye(4)
    f = Frame(depth, np.ones((480, 640), np.uint32), np.ones((480, 640), np.uint16), None, s, pose)

    table = ray_table(s)

    def naive():
        m = depth.ravel() > 0
        d = depth.ravel()[m]
        pts = (table[:, m] * d).T
        pts = np.c_[pts, d] @ pose[:3, :3].T.astype(np.float32) + pose[:3, 3].astype(np.float32)
        return pts, f.semantic.ravel()[m], f.instance.ravel()[m]

    n = int(np.count_nonzero(depth))
    bufs = np.empty((n + 1, 3), np.float32), np.empty(n + 1, np.uint16), np.empty(n + 1, np.uint32)

    def copy():
        return depth.copy(), f.instance.copy(), f.semantic.copy()

    out = {}
    unproject(f)
    for name, fn in (("genie-gl into merged cloud", lambda: unproject_into(f, np.zeros(3), *bufs)),
                     ("genie-gl unproject()", lambda: unproject(f)), ("plain numpy", naive), ("bare copy", copy)):
        ts = []
        for _ in range(repeats):
            t = time.perf_counter()
            fn()
            ts.append(1e3 * (time.perf_counter() - t))
        out[name] = float(np.median(ts))
    return out


def run(args: argparse.Namespace) -> int:
    from ..dataset import run_dataset

    results: dict = {"cameras": args.cameras, "sensor": args.sensor, "runs": []}
    for w in [int(x) for x in args.workers.split(",")]:
        tmp = Path(tempfile.mkdtemp(prefix="genie-bench-"))
        cfg = {"strategy": "assembly_line", "scenes": args.scenes, "cameras": args.cameras, "sensor": args.sensor,
               "format": "semantickitti", "out": str(tmp), "workers": w, "seed": 0, "points": 25000,
               "chunk_m": 12.0, "min_points": 2000, "min_labelled_share": 0.05, "previews": 0,
               "executor": "process", "address": None}
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
    print("unprojection, ms per 640x480 frame: " + ", ".join(f"{k} {v:.2f}" for k, v in u.items()))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "pipeline.json").write_text(json.dumps(results, indent=1))
    print(f"wrote {out / 'pipeline.json'}")
    return 0
