"""``genie bench stability``: the hard cases, each against its analytic truth, in one table.

Every case renders a small scene whose answer is known in closed form (a plane's depth along
each ray, a box seen from inside, where OpenCV's own projection puts a point, which id covers
which pixel) and reports the worst error it measured beside the tolerance it must hold. The
test suite runs the same cases (``tests/bench/test_stability.py``); a case over its tolerance
fails the command (exit 1).
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
import trimesh

from ..capture import through_lens
from ..cloud import to_cloud
from ..errors import ConfigError, did_you_mean
from ..layout import generate_layout
from ..scene import build_scene
from ..scene.model import Mesh, Scene
from ..sensors.camera import Sensor
from ..sensors.pose import look_at
from .truth import (  # noqa: F401,E501
    LENSES,
    Row,
    facing_quad,
    interior,
    lens_map_error,
    lens_rows,
    lens_sensor,
    marker_raycast,
    marker_scene,
    marker_truth,
    opencv_project,
    plane_depth,
    quad,
    rel_error,
    renderer,
)

CASES: dict[str, Callable[..., list[Row]]] = {}


def case(fn: Callable[..., list[Row]]) -> Callable[..., list[Row]]:
    CASES[fn.__name__] = fn
    return fn


# -- cases ---------------------------------------------------------------------------------------
@case
def far_near(context=None) -> list[Row]:
    """Far/near ratio 1e7: a plate 2 mm from the lens before a wall 9 km away."""
    s = Sensor.pinhole(128, 96, 110.0, near_m=1e-3, far_m=1e4)
    scene = Scene()
    scene.add(facing_quad(9000.0, -9000, 9000, -9000, 9000), instance=1)
    scene.add(facing_quad(0.002, -0.01, -0.0005, -0.01, 0.01), instance=2)
    with renderer(scene, context) as r:
        f = r.render(s, np.eye(4))
    x = (np.arange(128) - s.cx) / s.fx
    want_id = np.broadcast_to(np.where(x * 0.002 < -0.0005, 2, 1), (96, 128))
    want_z = np.where(want_id == 2, 0.002, 9000.0)
    core = interior(want_id == 2) | interior(want_id == 1)
    wrong = int((f.instance[core] != want_id[core]).sum())
    err = rel_error(f.depth, want_z, core) if wrong == 0 else float("inf")
    return [
        Row("far/near 1e7 (2 mm plate, 9 km wall)", 1e-6, err, "rel depth", f"{wrong} ids wrong")
    ]


def _translated(scene: Scene, shift: np.ndarray) -> Scene:
    out = Scene(meshes=dict(scene.meshes))
    out.instances = [
        replace(i, world_from_model=shift @ i.world_from_model) for i in scene.instances
    ]
    return out


def generated_scene(seed: int = 0) -> tuple[Scene, np.ndarray]:
    """A generated assembly-line scene and a pose looking into it."""
    scene = build_scene(generate_layout("assembly_line", seed=seed), seed=seed)
    lo, hi = scene.bounds()
    c = (lo + hi) / 2
    eye = np.array([lo[0] + 0.15 * (hi[0] - lo[0]), lo[1] + 0.2 * (hi[1] - lo[1]), 3.0])
    return scene, look_at(eye, [c[0], c[1], 0.5])


GRAZING_DEG = 85.0


def translation_rows(offsets=(1e3, 1e5, 1e7), size=(640, 480), context=None) -> list[Row]:
    """The generated scene and its pose, translated: depth and ids against the untranslated
    frame, and the cloud made absolute again. Depth is held to 1e-6 relative on every pixel
    seen at less than 85° incidence; at grazing pixels the error is weighed by cos(incidence)
    (a surface moved by δ along its normal moves its depth by δ / cos: float32 rendering
    rounds each instance's camera-relative position to 1 ulp, and the float64 input of a scene
    1e7 m out is itself only good to 2e-9 m)."""
    scene, pose = generated_scene()
    s = Sensor.pinhole(size[0], size[1], 0.9 * size[0], far_m=1e4)
    rows = []
    with renderer(scene, context) as r:
        f0 = r.render(s, pose, normals=True)
    cos = np.clip(-(f0.normal * s.directions()).sum(-1), 0, 1)
    steep = cos >= np.cos(np.radians(GRAZING_DEG))
    c0 = to_cloud([f0]).world_xyz
    for off in offsets:
        shift = np.eye(4)
        shift[:3, 3] = [off, -off * 0.7, off * 0.01]
        with renderer(_translated(scene, shift), context) as r:
            f1 = r.render(s, shift @ pose)
        both = (f0.depth > 0) & (f1.depth > 0)
        wrong = int((f0.instance != f1.instance).sum()) + int(
            ((f0.depth > 0) != (f1.depth > 0)).sum()
        )
        rel = np.zeros(f0.depth.shape)
        rel[both] = np.abs(f1.depth[both].astype(np.float64) - f0.depth[both]) / f0.depth[both]
        tag = f"translated by {off:.0e} m ({size[0]}x{size[1]} generated scene)"
        note = (
            f"{wrong} ids/returns differ; {int((rel > 0).sum())} of {int(both.sum())} pixels "
            "differ at all"
        )
        rows.append(
            Row(
                f"{tag}: depth, incidence < {GRAZING_DEG:.0f}°",
                1e-6,
                float(rel[both & steep].max()) if wrong == 0 else float("inf"),
                "rel depth",
                note,
            )
        )
        rows.append(
            Row(
                f"{tag}: depth, every pixel, x cos(incidence)",
                1e-6,
                float((rel * cos)[both].max()) if wrong == 0 else float("inf"),
                "rel depth",
                f"worst unweighted {float(rel.max()):.1e}",
            )
        )
        c1 = to_cloud([f1]).world_xyz - shift[:3, 3]
        if len(c0) != len(c1):
            rows.append(Row(f"{tag}: cloud made absolute", 1e-4, float("inf"), "m"))
            continue
        gap = np.abs(c1 - c0).max(1)
        sel = steep[f0.depth > 0]
        rows.append(
            Row(
                f"{tag}: cloud made absolute, incidence < {GRAZING_DEG:.0f}°",
                1e-4,
                float(gap[sel].max()),
                "m",
                f"worst at any incidence {float(gap.max()) * 1e3:.3f} mm",
            )
        )
    return rows


@case
def translation(context=None) -> list[Row]:
    """The same generated scene translated by 1e3, 1e5, 1e7 m: depth, ids and cloud."""
    return translation_rows(context=context)


@case
def grazing(context=None) -> list[Row]:
    """A floor seen at 89.9° incidence at the image centre."""
    s = Sensor.pinhole(128, 96, 110.0, far_m=1e5)
    tilt = np.radians(89.9)
    a = np.pi / 2 - tilt  # camera pitched down by a (x right, y down, z fwd)
    R = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    pose = np.eye(4)
    pose[:3, :3] = R.T  # world_from_camera; world = camera frame at rest
    h = 1.0
    scene = Scene()
    scene.add(quad([[-4e3, h, -10.0], [4e3, h, -10.0], [4e3, h, 2e4], [-4e3, h, 2e4]]), instance=3)
    with renderer(scene, context) as r:
        f = r.render(s, pose)
    n_cam = R @ np.array([0, 1.0, 0])  # plane y = h (world) in the camera frame
    p0_cam = R @ np.array([0, h, 0])
    want = plane_depth(s, n_cam, p0_cam)
    d = np.nan_to_num(s.directions()) @ R  # world rays
    with np.errstate(divide="ignore", invalid="ignore"):
        t = h / d[..., 1]
    inside = (t > 0) & (np.abs(t * d[..., 0]) < 4e3) & (t * d[..., 2] < 2e4) & (want < 1e5)
    core = interior(inside, 2)
    wrong = int((f.instance[core] != 3).sum())
    err = rel_error(f.depth, want, core) if wrong == 0 else float("inf")
    return [
        Row(
            "grazing 89.9° floor",
            1e-5,
            err,
            "rel depth",
            f"{wrong} ids wrong; centre ray at {h / np.cos(tilt):.0f} m",
        )
    ]


@case
def lenses(context=None) -> list[Row]:
    """Every lens: pixel rays and marker centroids against OpenCV, planar depth and cloud."""
    return [r for name in LENSES for r in lens_rows(name, context)]


# -- near, inside, on, empty, broken
# ------------------------------------------------------------------
@case
def near_range(context=None) -> list[Row]:
    """A plate nearer than the minimum range: no return there (not the wall behind it)."""
    rows = []
    for label, s in (
        ("pinhole", Sensor.pinhole(128, 96, 110.0, near_m=0.05)),
        ("k1=-0.5 lens", replace(lens_sensor("k1=-0.5 (barrel)", 128, 96), near_m=0.05)),
    ):
        scene = Scene()
        scene.add(facing_quad(2.0, -5, 5, -5, 5), instance=1)
        scene.add(facing_quad(0.02, -0.1, 0.0, -0.1, 0.1), instance=2)  # the left half, 2 cm away
        with renderer(scene, context) as r:
            f = through_lens(r.render)(s, np.eye(4))
        x = np.nan_to_num(s.rays()[..., 0], nan=np.inf)
        plate = x < 0
        has = np.isfinite(s.directions()).all(-1)
        core = interior(plate & has, 1) | interior(~plate & has, 1)
        want_z = np.where(plate, 0.0, plane_depth(s, np.array([0, 0, 1.0]), np.array([0, 0, 2.0])))
        wrong = int((f.instance[core] != np.where(plate, 0, 1)[core]).sum())
        wrong += int(((f.depth > 0) != (want_z > 0))[core].sum())
        rows.append(
            Row(
                f"surface nearer than the minimum range ({label})",
                0,
                wrong,
                "pixels wrong",
                "2 cm plate, 5 cm minimum range: depth 0 and id 0",
            )
        )
    return rows


@case
def inside_and_on(context=None) -> list[Row]:
    """The camera inside a closed box, and 0.1 mm above a floor (on a surface)."""
    rows = []
    s = Sensor.pinhole(128, 96, 70.0, near_m=0.05)
    scene = Scene()
    scene.add(trimesh.creation.box((4.0, 4.0, 4.0)), instance=7)
    pose = look_at([0.3, -0.2, 0.1], [5.0, 1.0, 0.6])
    with renderer(scene, context) as r:
        f = r.render(s, pose)
    d = np.nan_to_num(s.directions()) @ pose[:3, :3].T
    e = pose[:3, 3]
    with np.errstate(divide="ignore"):
        t = np.where(d > 0, (2.0 - e) / d, (-2.0 - e) / d)
    t = t.min(-1)  # the first wall a ray leaves the box through
    want = t * np.nan_to_num(s.directions())[..., 2]
    ids_ok = f.instance == 7
    rows.append(
        Row(
            "camera inside a closed box",
            1e-5,
            rel_error(f.depth, want, interior(ids_ok, 1)) if ids_ok.all() else float("inf"),
            "rel depth",
            f"{int((~ids_ok).sum())} pixels without the box",
        )
    )
    # 0.1 mm above a floor, looking 5° down at a wall 3 m ahead that reaches 1 m below the
    # floor: the floor under the camera is nearer than the range (no return), and a near
    # plane that clipped it away would show the wall through it
    s = Sensor.pinhole(128, 96, 70.0, near_m=0.05, far_m=1e4)
    scene = Scene()
    scene.add(quad([[-500, -500, 0], [500, -500, 0], [500, 500, 0], [-500, 500, 0]]), instance=4)
    scene.add(quad([[3, -50, -1], [3, 50, -1], [3, 50, 3], [3, -50, 3]]), instance=5)
    h = 1e-4
    pose = look_at([0.0, 0.0, h], [10.0, 0.0, h - 10 * np.tan(np.radians(5))])
    with renderer(scene, context) as r:
        f = r.render(s, pose)
    rays = np.nan_to_num(s.directions())
    d = rays @ pose[:3, :3].T
    with np.errstate(divide="ignore", invalid="ignore"):
        t_floor = np.where(d[..., 2] < 0, -h / d[..., 2], np.inf)
        t_wall = np.where(d[..., 0] > 0, 3.0 / d[..., 0], np.inf)
    floor_first = t_floor < t_wall
    t = np.minimum(t_floor, t_wall)
    z = t * rays[..., 2]
    want = np.where(z >= s.near_m, z, 0.0)
    want_id = np.where(want > 0, np.where(floor_first, 4, 5), 0)
    core = interior(want_id == 5, 1) | interior(want_id == 0, 1) | interior(want_id == 4, 1)
    wrong = int((f.instance != want_id)[core].sum())
    err = rel_error(f.depth, want, core & (want > 0)) if wrong == 0 else float("inf")
    rows.append(
        Row(
            "camera 0.1 mm above a floor (on a surface)",
            1e-5,
            err,
            "rel depth",
            f"{wrong} ids wrong; {int((floor_first & (want == 0)).sum())} floor pixels nearer than "
            "the range",
        )
    )
    return rows


@case
def empty_and_broken(context=None) -> list[Row]:
    """An empty scene; NaN/Inf/zero-area faces beside a good quad; a zero-scale instance."""
    rows = []
    s = Sensor.pinhole(64, 48, 50.0)
    with renderer(Scene(), context) as r:
        f = r.render(s, np.eye(4))
    rows.append(
        Row(
            "empty scene",
            0,
            int((f.depth != 0).sum() + (f.instance != 0).sum()),
            "pixels not empty",
        )
    )
    v = np.array(
        [
            [-1, -1, 2],
            [1, -1, 2],
            [1, 1, 2],
            [-1, 1, 2],
            [np.nan, 0, 2],
            [np.inf, 1, 2],
            [0.5, 0.5, 1.0],
            [0.5, 0.5, 1.0],
        ],
        float,
    )
    faces = np.array([[0, 1, 2], [0, 2, 3], [4, 0, 1], [5, 1, 2], [6, 7, 0], [6, 6, 6]])
    scene = Scene()
    scene.add(Mesh(v, faces), instance=9)
    rep = scene.report()
    with renderer(scene, context) as r:
        f = r.render(s, np.eye(4))
    x, y = s.rays()[..., 0] * 2, s.rays()[..., 1] * 2
    square = interior((np.abs(x) < 1) & (np.abs(y) < 1), 1)
    outside = interior((np.abs(x) > 1) | (np.abs(y) > 1), 1)
    wrong = int((f.instance[square] != 9).sum() + (f.instance[outside] != 0).sum())
    counts = abs(rep["faces_nonfinite"] - 2) + abs(rep["faces_zero_area"] - 2)
    err = (
        rel_error(f.depth, np.full(f.depth.shape, 2.0), square)
        if wrong + counts == 0
        else float("inf")
    )
    rows.append(
        Row(
            "NaN/Inf/zero-area faces skipped and counted",
            1e-6,
            err,
            "rel depth",
            f"report: {rep['faces_nonfinite']} non-finite, {rep['faces_zero_area']} zero-area "
            "faces",
        )
    )
    scene = Scene()
    bad = 0
    try:
        scene.add(facing_quad(2, -1, 1, -1, 1), np.diag([0.0, 1, 1, 1]), name="/World/Hidden")
        bad += 1
    except ConfigError as exc:
        msg = str(exc)
        bad += int("\n" in msg or "/World/Hidden" not in msg or "zero scale" not in msg)
    scene.add(
        facing_quad(2, -1, 1, -1, 1), np.diag([1.0, 1, 0, 1]), name="/World/Flat", degenerate="drop"
    )
    scene.add(facing_quad(2, -1, 1, -1, 1), instance=3)
    bad += abs(scene.report()["dropped_instances"] - 1)
    with renderer(scene, context) as r:
        f = r.render(s, np.eye(4))
    bad += int((f.instance[square] != 3).sum())
    rows.append(
        Row(
            "zero / singular scale: refused naming the prim, or dropped and counted",
            0,
            bad,
            "failures",
        )
    )
    return rows


@case
def many_instances(context=None) -> list[Row]:
    """2^16 + 1 instances, each on its own 2x2 pixel block: every id where it belongs."""
    n = 2**16 + 1
    cols = 257
    rows_ = -(-n // cols)
    W, H = 2 * cols, 2 * rows_
    s = Sensor.pinhole(W, H, 500.0, cx=W / 2 - 0.5, cy=H / 2 - 0.5)
    z = 10.0
    scene = Scene()
    key = scene.add_mesh(facing_quad(z, 0, 1, 0, 1), "cell")
    px = z / s.fx  # one pixel at the plane
    for k in range(n):
        i, j = divmod(k, cols)
        T = np.eye(4)
        T[0, 0] = T[1, 1] = 2 * px
        T[0, 3] = (2 * j - 0.5 - s.cx) * px
        T[1, 3] = (2 * i - 0.5 - s.cy) * px
        scene.add(key, T, instance=k + 1)
    with renderer(scene, context) as r:
        f = r.render(s, np.eye(4))
    ii, jj = np.meshgrid(np.arange(H) // 2, np.arange(W) // 2, indexing="ij")
    want = (ii * cols + jj + 1).astype(np.int64)
    want[want > n] = 0
    wrong = int((f.instance != want).sum())
    cloud = to_cloud([f])
    lost = n - len(np.unique(cloud.instance))
    return [
        Row(
            f"2^16 + 1 = {n} instances",
            0,
            wrong + lost,
            "pixels wrong",
            f"largest id {int(f.instance.max())}, {len(np.unique(cloud.instance))} ids in the "
            "cloud",
        )
    ]


@case
def wide_site(context=None) -> list[Row]:
    """A site 20 km wide: walls seen by cameras at both ends; the merged cloud, made absolute."""
    s = Sensor.pinhole(96, 72, 80.0, far_m=100.0)
    scene = Scene()
    frames_pose, walls = [], []
    for k, x0 in enumerate((0.0, 10_000.0, 20_000.0)):
        wall_x = x0 + 5.0 + 0.123456 * k
        scene.add(
            quad([[wall_x, -20, -20], [wall_x, 20, -20], [wall_x, 20, 20], [wall_x, -20, 20]]),
            instance=k + 1,
        )
        frames_pose.append(look_at([x0, 0.0, 1.0], [x0 + 10.0, 0.3, 1.2]))
        walls.append(wall_x)
    with renderer(scene, context) as r:
        frames = [r.render(s, p) for p in frames_pose]
    rows = []
    for precision, tol in (("float64", 1e-4), ("float32", 2**-24 * 12_000)):
        cloud = to_cloud(frames, precision=precision)
        xyz = cloud.world_xyz
        want = np.array(walls)[cloud.camera]
        rows.append(
            Row(
                f"20 km wide site: cloud ({precision} xyz) made absolute",
                tol,
                float(np.abs(xyz[:, 0] - want).max()),
                "m",
                "float32 keeps |xyz|·2^-24 from the origin" if precision == "float32" else "",
            )
        )
    return rows


# -- the command
# ---------------------------------------------------------------------------------------
def run_cases(names=None, context=None) -> list[Row]:
    unknown = [n for n in names or () if n not in CASES]
    if unknown:
        raise ConfigError(
            f"--case {unknown[0]!r}: unknown{did_you_mean(unknown[0], CASES)}; expected some of "
            f"{', '.join(sorted(CASES))}"
        )
    rows = []
    for name in names or CASES:
        t0 = time.perf_counter()
        got = CASES[name](context=context)
        dt = (time.perf_counter() - t0) / max(1, len(got))
        rows.extend(replace(r, seconds=dt) for r in got)
    return rows


def table(rows: list[Row]) -> str:
    w = max(len(r.case) for r in rows)
    lines = [
        f"{'case':<{w}}  {'tolerance':>10}  {'worst error':>12}  {'unit':<14}  status  note",
        "-" * (w + 60),
    ]
    for r in rows:
        lines.append(
            f"{r.case:<{w}}  {r.tolerance:>10.3g}  {r.worst:>12.3g}  {r.unit:<14}  "
            f"{'ok' if r.ok else 'FAIL':<6}  {r.note}"
        )
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    rows = run_cases(args.case)
    print(table(rows))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / ".stability.json.tmp"
    tmp.write_text(json.dumps([dict(asdict(r), ok=r.ok) for r in rows], indent=1, default=float))
    tmp.replace(out / "stability.json")
    failed = [r.case for r in rows if not r.ok]
    print(
        f"{len(rows) - len(failed)} of {len(rows)} cases within tolerance; table in "
        f"{out / 'stability.json'}"
    )
    return 1 if failed else 0
