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
    """ms per 640x480 frame: genie-gl (cached ray table, gather of valid pixels) vs plain numpy
    (meshgrid rays rebuilt per frame, full-frame arithmetic, then masking), and a bare copy."""
    from ..cloud.unproject import unproject
    from ..frame import Frame
    from ..sensors.camera import Sensor

    s = Sensor.pinhole(640, 480, 525.0)
    rng = np.random.default_rng(0)
    depth = rng.uniform(1, 10, (480, 640)).astype(np.float32)
    depth[rng.random((480, 640)) < 0.1] = 0
    pose = np.eye(4)
    f = Frame(depth, np.ones((480, 640), np.uint32), np.ones((480, 640), np.uint16), None, s, pose)

    def naive():
        u, v = np.meshgrid(np.arange(640), np.arange(480))
        x = (u - s.cx) / s.fx * depth
        y = (v - s.cy) / s.fy * depth
        pts = np.stack([x, y, depth], -1).reshape(-1, 3) @ pose[:3, :3].T + pose[:3, 3]
        m = depth.ravel() > 0
        return pts[m], f.semantic.ravel()[m], f.instance.ravel()[m]

    def copy():
        return depth.copy(), f.instance.copy(), f.semantic.copy()

    out = {}
    unproject(f)
    for name, fn in (("genie-gl", lambda: unproject(f)), ("plain numpy", naive), ("bare copy", copy)):
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
