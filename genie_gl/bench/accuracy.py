"""``genie bench accuracy``: what accuracy costs in time. For each effect and knob, the time
per frame beside the depth error against analytic truth, and a plot.

Scenes with closed-form depth, all seen from the identity pose: a wall tilted by 0.5 rad at
2.5 m, the same wall at 70° (steep incidence), a box 1 m away before a wall at 2 m (edges,
shadows), and a floor meeting a wall (a concave corner). A ``note`` gives each effect's own
check: shadow strip width against b·f·(1/z_box − 1/z_wall), dropout against the analytic
incidence angle, the multipath bias.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

Z_BOX, Z_WALL, BOX_HALF = 1.0, 2.0, (0.2, 0.3)   # box face at z = 1 m, x ±0.2 m, y ±0.3 m


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--repeats", type=int, default=5)


def _quad(s, p0, a, b, half=6.0, semantic=1):
    from ..scene.model import Mesh

    corners = [p0 + half * (sa * a + sb * b) for sa, sb in [(-1, -1), (1, -1), (1, 1), (-1, 1)]]
    s.add(Mesh(np.array(corners), np.array([[0, 1, 2], [0, 2, 3]])), semantic=semantic)


def _plane(angle: float, dist: float):
    """A wall turned by ``angle`` about y, through (0, 0, dist): scene, unit normal n, point p0."""
    from ..scene.model import Scene

    n = np.array([np.sin(angle), 0.0, -np.cos(angle)])
    p0 = np.array([0.0, 0.0, dist])
    a = np.cross(n, [0, 1, 0])
    a /= np.linalg.norm(a)
    s = Scene()
    _quad(s, p0, a, np.cross(n, a))
    return s, [(n, p0)]


def _box_before_wall():
    import trimesh

    from ..scene.model import Scene

    s = Scene()
    s.add(trimesh.creation.box((6, 6, 0.02)), [0, 0, Z_WALL + 0.01], semantic=0)
    s.add(trimesh.creation.box((2 * BOX_HALF[0], 2 * BOX_HALF[1], 0.2)), [0, 0, Z_BOX + 0.1], semantic=1)
    return s, None


def _corner():
    """A floor 0.6 m below the camera (y down) meeting a wall at z = 2.5 m."""
    from ..scene.model import Scene

    s = Scene()
    floor_n, floor_p = np.array([0.0, -1.0, 0.0]), np.array([0.0, 0.6, 2.5])
    wall_n, wall_p = np.array([0.0, 0.0, -1.0]), np.array([0.0, -2.4, 2.5])
    _quad(s, floor_p + [0, 0, -3.0], np.array([1.0, 0, 0]), np.array([0, 0, 1.0]), half=3.0)
    _quad(s, wall_p, np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), half=3.0)
    return s, [(floor_n, floor_p), (wall_n, wall_p)]


def _rays(sensor) -> np.ndarray:
    from ..cloud.unproject import ray_table

    t = ray_table(sensor)
    return np.stack([t[0], t[1], np.ones_like(t[0])], 1).astype(np.float64)


def _truth(sensor, planes) -> np.ndarray:
    """Depth of the nearest plane in front of every pixel's ray (planes: (normal, point))."""
    d = _rays(sensor)
    if planes is None:  # the box before the wall
        inside = (np.abs(d[:, 0] * Z_BOX) <= BOX_HALF[0]) & (np.abs(d[:, 1] * Z_BOX) <= BOX_HALF[1])
        z = np.where(inside, Z_BOX, Z_WALL)
    else:
        z = np.full(len(d), np.inf)
        for n, p0 in planes:
            with np.errstate(divide="ignore"):
                t = (n @ p0) / (d @ n)
            z = np.where((t > 0) & (t < z), t, z)
    return z.reshape(sensor.height, sensor.width)


def _theta(sensor, n) -> np.ndarray:
    d = _rays(sensor)
    return np.degrees(np.arccos(np.abs(d @ n) / np.linalg.norm(d, axis=1))).reshape(sensor.height, sensor.width)


def _shadow_note(f, ideal, sensor, b):
    """Mean |measured − analytic| hidden strip width (px) over the box's rows."""
    hidden = (ideal.depth > 0) & (f.depth == 0)
    box = ideal.depth == np.float32(Z_BOX)
    rows = np.flatnonzero(box.any(1))[3:-3]
    left = [int(np.flatnonzero(box[v])[0]) for v in rows]
    widths = np.array([hidden[v, max(0, u - 60):u].sum() for v, u in zip(rows, left)])
    analytic = sensor.fx * b * (1 / Z_BOX - 1 / Z_WALL)
    return f"strip {widths.mean():.2f} px vs {analytic:.2f} (max |err| {np.abs(widths - analytic).max():.2f})"


def run(args: argparse.Namespace) -> int:
    from ..render import Renderer
    from ..sensors.camera import Sensor
    from ..sensors.edges import EdgeDropout, FlyingPixels
    from ..sensors.effects import DepthNoise
    from ..sensors.miscalibration import CalibrationError
    from ..sensors.shadow import StereoShadow
    from ..sensors.simulate import simulate
    from ..sensors.surface import IncidenceDropout, LateralNoise, Multipath

    scenes = {"tilted": _plane(0.5, 2.5), "steep": _plane(np.radians(70.0), 2.5),
              "box": _box_before_wall(), "corner": _corner()}
    base = Sensor.pinhole(640, 480, 525.0)
    B = 0.075
    cases = [("ideal 320x240", "tilted", Sensor.pinhole(320, 240, 262.5), ()),
             ("ideal 640x480", "tilted", base, ()),
             ("ideal 1280x960", "tilted", Sensor.pinhole(1280, 960, 1050.0), ()),
             ("distortion (rational, Azure-like)", "tilted",
              Sensor(640, 480, base.K, [0.5, 0.2, 0, 0, 0.01, 0.6, 0.3, 0.05]), ()),
             ("noise kinect_nguyen2012", "tilted", base, (DepthNoise(model="kinect_nguyen2012"),)),
             ("noise stereo D435 (+1/32 px steps)", "tilted", base,
              (DepthNoise(model="stereo", subpixel=0.08, subpixel_step=1 / 32),)),
             ("noise tof_linear", "tilted", base, (DepthNoise(model="tof_linear"),)),
             ("nguyen2012, wall at 70°, no angle term", "steep", base, (DepthNoise(incidence=False),)),
             ("nguyen2012, wall at 70°, angle term", "steep", base, (DepthNoise(),)),
             ("lateral_noise nguyen2012", "tilted", base, (LateralNoise(),)),
             ("incidence_dropout 30°", "tilted", base, (IncidenceDropout(max_angle_deg=30.0),)),
             ("stereo_shadow b 75 mm (render 1/2)", "box", base, (StereoShadow(baseline_m=B),)),
             ("stereo_shadow b 75 mm (render 1/4)", "box", base, (StereoShadow(baseline_m=B, scale=0.25),)),
             ("flying_pixels p 0.5", "box", base, (FlyingPixels(probability=0.5),)),
             ("edge_dropout span 0.8 m", "box", base, (EdgeDropout(span_m=0.8),)),
             ("multipath 1 cm (floor-wall corner)", "corner", base, (Multipath(bias_m=0.01),)),
             ("calibration_error σf 2 px σc 1 px", "tilted", base, (CalibrationError(2.0, 1.0),))]
    rows = []
    for name, key, sensor, effects in cases:
        scene, planes = scenes[key]
        s = Sensor(sensor.width, sensor.height, sensor.K, sensor.dist, effects=effects)
        with Renderer(scene) as r:
            ts = []
            for k in range(args.repeats):
                t = time.perf_counter()
                f = simulate(s, np.eye(4), render=r.render, rng=np.random.default_rng(k))
                ts.append(1e3 * (time.perf_counter() - t))
            ideal = simulate(Sensor(s.width, s.height, s.K, s.dist), np.eye(4), render=r.render,
                             rng=np.random.default_rng(0))
        truth = _truth(s, planes)
        hit = f.depth > 0
        err = np.abs(f.depth[hit] - truth[hit]) if hit.any() else np.zeros(1)
        note = ""
        if key == "box" and isinstance(effects[0], StereoShadow):
            note = _shadow_note(f, ideal, s, B)
        elif isinstance(effects[:1] and effects[0], IncidenceDropout):
            theta = _theta(s, planes[0][0])
            want = (ideal.depth > 0) & (theta > effects[0].max_angle_deg)
            got = (ideal.depth > 0) & (f.depth == 0)
            note = f"{int((want != got).sum())} of {int(want.sum())} dropped px off the analytic θ mask"
        elif isinstance(effects[:1] and effects[0], DepthNoise):
            eff = effects[0]
            theta = np.radians(_theta(s, planes[0][0])) if eff.needs_normals else None
            model = eff.sigma(truth.astype(np.float64), s.fx, theta, s)
            ratio = np.std((f.depth[hit] - truth[hit]) / model[hit])
            note = f"σ / σ_model = {ratio:.3f}"
        elif isinstance(effects[:1] and effects[0], FlyingPixels):
            mixed = f.depth != ideal.depth
            note = (f"{int(mixed.sum())} of {f.meta['flying_pixels']['edge_pixels']} edge px mixed, "
                    f"max |dz| {1e3 * float(np.abs(f.depth - truth)[mixed].max()):.0f} mm")
        elif isinstance(effects[:1] and effects[0], EdgeDropout):
            note = f"{f.meta['edge_dropout']['dropped']} px dropped along the box outline"
        elif key == "corner":
            corner = (ideal.depth > 0)
            bias = (f.depth.astype(np.float64) - ideal.depth)[corner]
            note = f"bias max {1e3 * bias.max():.2f} mm, {100 * (bias > 0).mean():.1f} % of pixels biased"
        elif isinstance(effects[:1] and effects[0], CalibrationError):
            note = "K' − K = " + ", ".join(f"{d:+.2f}" for d in (np.array(f.meta["calibration_error"]["K_true"])
                                                               - s.K)[[0, 1, 0, 1], [0, 1, 2, 2]])
        rows.append({"case": name, "ms": float(np.median(ts)), "median_err_mm": 1e3 * float(np.median(err)),
                     "p99_err_mm": 1e3 * float(np.percentile(err, 99)), "valid": float(hit.mean()), "note": note})
    print(f"{'case':<42}{'ms/frame':>10}{'median |dz| mm':>16}{'p99 mm':>10}{'valid':>8}  note")
    for row in rows:
        print(f"{row['case']:<42}{row['ms']:>10.1f}{row['median_err_mm']:>16.4f}{row['p99_err_mm']:>10.3f}"
              f"{row['valid']:>8.3f}  {row['note']}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "accuracy.json").write_text(json.dumps(rows, indent=1))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5))
    for row in rows:
        ax.scatter(row["ms"], max(row["median_err_mm"], 1e-6), label=row["case"])
    ax.set_yscale("log")
    ax.set_xlabel("ms per frame")
    ax.set_ylabel("median |depth error| (mm)")
    ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(out / "accuracy.png", dpi=100)
    print(f"wrote {out / 'accuracy.json'} and {out / 'accuracy.png'}")
    return 0
