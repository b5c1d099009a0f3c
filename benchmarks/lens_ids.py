"""Lens resampling against Open3D's ray caster, and what each mode costs.

For four lens models (the OpenCV tutorial's k1 = -0.42 plumb-bob, a rational lens, a
Kannala-Brandt fisheye, an omnidirectional lens), on the ``storage_area`` layout (seed 0) seen
from its first two content poses: the share of pixels whose instance equals the one Open3D's
``RaycastingScene.cast_rays`` hits along the same ray (``Camera.directions``), in every mode;
then the ms per frame of each mode, the modes taking turns in one process (median of 10);
``resampling``: the CPU ms of the resampling alone (the views rendered once, first pose;
median of 6 after a warm-up). ``--raster gl`` (the default here) resamples pinhole views in
every mode; with ``--raster cpu`` the exact mode is the CPU raster drawing each pixel's own
ray (the other modes still resample its pinhole views)::

    python -m benchmarks lens_ids [agreement|cost|both|resampling] [--raster gl|cpu]
"""

from __future__ import annotations

import time

import numpy as np

import genie_gl as gg
from genie_gl.bench.accuracy_case import content_poses
from genie_gl.render import Renderer
from genie_gl.lens.distortion import lens_views, render_through_lens, resample_views

from .common import benchmark_scene, header, parser

K = np.array([[535.9, 0, 342.3], [0, 535.9, 235.6], [0, 0, 1.0]])
LENSES = {
    "plumb-bob (k1 -0.42)": gg.Sensor(640, 480, K, [-0.42, 0.2, 0.001, -0.0003, -0.05]),
    "rational": gg.Sensor(640, 480, K, [0.1, -0.05, 0.001, -0.002, 0.01, 0.02, 0.0, 0.0]),
    "fisheye": gg.Sensor(
        640,
        480,
        np.array([[230.0, 0, 320], [0, 230, 240], [0, 0, 1]]),
        [0.05, -0.01, 0.002, -0.0005],
        model="fisheye",
    ),
    "omnidirectional": gg.Sensor(
        640,
        480,
        np.array([[300.0, 0, 320], [0, 300, 240], [0, 0, 1]]),
        [0.9, -0.1, 0.02, 0.001, -0.001],
        model="omni",
    ),
}
MODES = ("nearest", "bilinear", "plane", "exact")


def caster(scene):
    import open3d as o3d

    rc, ids = o3d.t.geometry.RaycastingScene(), {}
    for inst in scene.instances:
        m = scene.meshes[inst.mesh]
        v = (
            np.asarray(m.vertices, np.float64) @ inst.world_from_model[:3, :3].T
            + inst.world_from_model[:3, 3]
        )
        ids[
            rc.add_triangles(
                o3d.core.Tensor(v.astype(np.float32)),
                o3d.core.Tensor(np.asarray(m.faces, np.uint32)),
            )
        ] = inst.instance
    return rc, ids


def cast(rc, ids, sensor, pose):
    import open3d as o3d

    d = sensor.directions().reshape(-1, 3)
    ok = np.isfinite(d[:, 0])
    dw = np.where(ok[:, None], d, 0.0) @ pose[:3, :3].T
    hit = rc.cast_rays(
        o3d.core.Tensor(np.c_[np.broadcast_to(pose[:3, 3], dw.shape), dw].astype(np.float32))
    )
    t = hit["t_hit"].numpy()
    inst = np.array([ids.get(int(g), 0) for g in hit["geometry_ids"].numpy()], np.uint32)
    z = t * d[:, 2]
    seen = ok & np.isfinite(t) & (z >= sensor.near_m) & (z <= sensor.far_m)
    return np.where(seen, inst, 0).reshape(sensor.height, sensor.width)


def resampling(r, sensor, pose) -> dict[str, float]:
    """CPU ms of resample_views per mode, on views rendered once."""
    views = lens_views(sensor)
    posed = []
    for m in views:
        p = pose.copy()
        p[:3, :3] = pose[:3, :3] @ m.rotation
        posed.append((m.render_sensor, p))
    with_triangles = [r.render(v, p, triangles=True) for v, p in posed]
    with_normals = [r.render(v, p, normals=True) for v, p in posed]
    cpu = {m: [] for m in MODES}
    for k in range(7):
        for m in MODES:
            frames = with_triangles if m == "exact" else with_normals
            t0 = time.process_time()
            resample_views(frames, sensor, views, pose, resample=m)
            cpu[m].append(1e3 * (time.process_time() - t0))
    return {m: float(np.median(cpu[m][1:])) for m in MODES}


def run(
    what: str = "both",
    scene_name: str = "storage_area",
    poses: int = 2,
    lenses=None,
    rounds: int = 5,
    raster: str = "gl",
) -> dict[str, dict]:
    """Per lens: ``agreement`` {mode: (share of pixels whose id is Open3D's, wrong pixels)},
    ``ms`` {mode: median ms a frame}, ``resampling_ms`` {mode: median CPU ms}, as ``what`` asks.
    ``scene_name``: a shipped strategy (seed 0) or a benchmark scene; ``raster``: the
    renderer's raster."""
    if scene_name in ("100k", "1M", "10M", "hall", "generated"):
        scene = benchmark_scene(scene_name)[1]
    else:
        scene = gg.build_scene(gg.generate_layout(scene_name, seed=0), seed=0)
    views = content_poses(scene, poses)
    chosen = {k: v for k, v in LENSES.items() if lenses is None or k in lenses}
    out: dict[str, dict] = {name: {} for name in chosen}
    if what == "resampling":
        with Renderer(scene, raster=raster) as r:
            for name, s in chosen.items():
                out[name]["resampling_ms"] = resampling(r, s, views[0])
        return out
    rc, ids = caster(scene) if what in ("agreement", "both") else (None, None)
    with Renderer(scene, raster=raster) as r:
        for name, s in chosen.items():
            if rc is not None:
                truth = [cast(rc, ids, s, p) for p in views]
                agree = {}
                for m in MODES:
                    wrong = sum(
                        int((render_through_lens(r.render, s, p, resample=m).instance != t).sum())
                        for p, t in zip(views, truth)
                    )
                    agree[m] = (1 - wrong / (len(views) * s.width * s.height), wrong)
                out[name]["agreement"] = agree
            if what in ("cost", "both"):
                for m in MODES:
                    render_through_lens(
                        r.render, s, views[0], resample=m
                    )  # warm-up: compile, buffers
                ms: dict[str, list[float]] = {m: [] for m in MODES}
                for k in range(rounds):
                    for j in range(len(MODES)):
                        m = MODES[(j + k) % len(MODES)]
                        for p in views:
                            t0 = time.perf_counter()
                            render_through_lens(r.render, s, p, resample=m)
                            ms[m].append(1e3 * (time.perf_counter() - t0))
                out[name]["ms"] = {m: float(np.median(v)) for m, v in ms.items()}
    return out


def main(argv: list[str]) -> None:
    p = parser("lens_ids", __doc__)
    p.add_argument(
        "what", nargs="?", default="both", choices=("agreement", "cost", "both", "resampling")
    )
    p.add_argument(
        "--scene", default="storage_area", help="a shipped strategy or a benchmark scene"
    )
    p.add_argument("--poses", type=int, default=2)
    p.add_argument("--raster", default="gl", choices=("gl", "cpu"))
    a = p.parse_args(argv)
    print(header() + f", raster {a.raster}")
    for name, r in run(a.what, a.scene, a.poses, raster=a.raster).items():
        if "resampling_ms" in r:
            print(f"| {name} | " + " | ".join(f"{r['resampling_ms'][m]:.1f}" for m in MODES) + " |")
        if "agreement" in r:
            print(
                f"| {name} | "
                + " | ".join(
                    f"{m} {100 * share:.4f} % ({wrong} px)"
                    for m, (share, wrong) in r["agreement"].items()
                )
                + " |"
            )
        if "ms" in r:
            med = r["ms"]
            print(
                f"| {name} | "
                + " | ".join(f"{med[m]:.0f}" for m in MODES)
                + f" | {med['exact'] / med['nearest']:.2f} |"
            )
