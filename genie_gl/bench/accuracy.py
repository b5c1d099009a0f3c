"""``genie bench accuracy``: what accuracy costs in time. For each effect and knob, the time
per frame beside the depth error against analytic truth (a tilted wall), and a plot."""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--repeats", type=int, default=5)


def _wall():
    from ..scene.model import Mesh, Scene

    n = np.array([np.sin(0.5), 0.0, -np.cos(0.5)])
    p0 = np.array([0.0, 0.0, 2.5])
    a = np.cross(n, [0, 1, 0])
    a /= np.linalg.norm(a)
    b = np.cross(n, a)
    corners = [p0 + 6 * (sa * a + sb * b) for sa, sb in [(-1, -1), (1, -1), (1, 1), (-1, 1)]]
    s = Scene()
    s.add(Mesh(np.array(corners), np.array([[0, 1, 2], [0, 2, 3]])), semantic=1)
    return s, n, p0


def _truth(sensor, n, p0):
    from ..cloud.unproject import ray_table

    t = ray_table(sensor)
    d = np.stack([t[0], t[1], np.ones_like(t[0])], 1).astype(np.float64)
    return ((n @ p0) / (d @ n)).reshape(sensor.height, sensor.width)


def run(args: argparse.Namespace) -> int:
    from ..render import Renderer
    from ..sensors.camera import Sensor
    from ..sensors.effects import DepthNoise
    from ..sensors.simulate import simulate

    scene, n, p0 = _wall()
    rows = []
    base = Sensor.pinhole(640, 480, 525.0)
    cases = [("ideal 320x240", Sensor.pinhole(320, 240, 262.5), None),
             ("ideal 640x480", base, None),
             ("ideal 1280x960", Sensor.pinhole(1280, 960, 1050.0), None),
             ("distortion (rational, Azure-like)", Sensor(640, 480, base.K, [0.5, 0.2, 0, 0, 0.01, 0.6, 0.3, 0.05]), None),
             ("noise kinect_nguyen2012", base, DepthNoise(model="kinect_nguyen2012")),
             ("noise stereo D435 (+1/32 px steps)", base, DepthNoise(model="stereo", subpixel_step=1 / 32)),
             ("noise tof_linear", base, DepthNoise(model="tof_linear"))]
    with Renderer(scene) as r:
        for name, sensor, eff in cases:
            s = sensor if eff is None else Sensor(sensor.width, sensor.height, sensor.K, sensor.dist, effects=(eff,))
            ts = []
            for k in range(args.repeats):
                t = time.perf_counter()
                f = simulate(s, np.eye(4), render=r.render, rng=np.random.default_rng(k))
                ts.append(1e3 * (time.perf_counter() - t))
            truth = _truth(s, n, p0)
            hit = f.depth > 0
            err = np.abs(f.depth[hit] - truth[hit])
            rows.append({"case": name, "ms": float(np.median(ts)), "median_err_mm": 1e3 * float(np.median(err)),
                         "p99_err_mm": 1e3 * float(np.percentile(err, 99)), "valid": float(hit.mean())})
    print(f"{'case':<38}{'ms/frame':>10}{'median |dz| mm':>16}{'p99 mm':>10}")
    for row in rows:
        print(f"{row['case']:<38}{row['ms']:>10.1f}{row['median_err_mm']:>16.4f}{row['p99_err_mm']:>10.3f}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "accuracy.json").write_text(json.dumps(rows, indent=1))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for row in rows:
        ax.scatter(row["ms"], max(row["median_err_mm"], 1e-6), label=row["case"])
    ax.set_yscale("log")
    ax.set_xlabel("ms per frame")
    ax.set_ylabel("median |depth error| (mm)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "accuracy.png", dpi=100)
    print(f"wrote {out / 'accuracy.json'} and {out / 'accuracy.png'}")
    return 0
