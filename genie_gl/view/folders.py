"""What ``genie view`` shows, read from files genie-gl exported (never from the pipeline).

A path is one of: a dataset folder (``manifest.json`` and ``scenes/NNNN``), one scene folder
of it (static scans, or a recording: ``trajectory.txt`` beside its sequence or sensor
folders), a ``genie capture`` folder (``cloud.ply|npz|las|e57``) or a USD scene. Each
scene becomes one :class:`SceneView`: the world cloud with class and instance ids, the
cameras with their poses, intrinsics and the images the folder holds, the body's poses
along the trajectory, the layout and, for a USD scene, its meshes.

Scene folders, as the exporters write them (``docs/formats.md``):

- SemanticKITTI static scans: ``velodyne/NNNNNN.bin`` in the scan frame, ``poses.txt`` the
  translation to the world;
- SemanticKITTI recordings, per sensor group ``GG/``: scans in the body frame,
  ``world = world_pose · Tr⁻¹ · pose_i · Tr · p``; camera 0 of the group at scan ``i`` is
  ``world_pose · Tr⁻¹ · pose_i`` and ``Pj = Kj [R|t]`` gives camera j from camera 0;
- TUM RGB-D, per rig sensor ``NAME/``: ``groundtruth.txt`` (world_from_camera), ``depth/``
  (x 5000), ``semantic/`` and ``instance/`` 16-bit PNGs; the intrinsics come from the
  dataset's sensor or rig, named in its ``manifest.json``.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image

from ..errors import ConfigError
from ..export import e57, las, npz, semantickitti
from ..layout.model import Layout
from ..scene.usd import read_usd
from ..effects.profile import load_sensor
from ..motion.rig import load_rig

log = logging.getLogger(__name__)
CLOUD_SUFFIXES = (".ply", ".npz", ".las", ".e57")
USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")
TUM_DEPTH_SCALE = 5000.0


@dataclass
class Shot:
    """One camera at one time.

    Attributes
    ----------
    camera : str, the camera's name (entity path part).
    time_s : float or None, seconds on the recording's clock (None: standing camera).
    world_from_camera : (4, 4) float64, OpenCV camera frame (x right, y down, z forward).
    K : (3, 3) float64 or None, intrinsics in pixels (None: unknown, no pinhole).
    size : (width, height) in pixels.
    depth : (H, W) float32 metres or None (0: no return); semantic (H, W) uint16 or None;
    instance : (H, W) uint32 or None.
    """

    camera: str
    time_s: float | None
    world_from_camera: np.ndarray
    K: np.ndarray | None = None
    size: tuple[int, int] = (0, 0)
    depth: np.ndarray | None = None
    semantic: np.ndarray | None = None
    instance: np.ndarray | None = None


@dataclass
class SceneView:
    """One scene as the viewer shows it.

    Attributes
    ----------
    name : str, entity path part (``scene_0000``).
    xyz : (N, 3) float64 world points (m); semantic (N,) uint16; instance (N,) uint32.
    times_s : (T,) float64 or None, the body's clock; world_from_body (T, 4, 4) float64 or None.
    shots : cameras, in time order.
    layout : genie_gl Layout or None.
    meshes : list of (vertices (V, 3) float32 world, faces (F, 3) uint32, semantic id, instance id).
    ring : (N,) uint16 or None, each point's scanner channel (a scanner dataset's points).
    """

    name: str
    xyz: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    semantic: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint16))
    instance: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint32))
    times_s: np.ndarray | None = None
    world_from_body: np.ndarray | None = None
    shots: list[Shot] = field(default_factory=list)
    layout: object | None = None
    meshes: list = field(default_factory=list)
    ring: np.ndarray | None = None


def read_views(path: str | Path) -> list[SceneView]:
    """The scenes at ``path`` (see the module's docstring); one clear error when it holds
    nothing genie view can show."""
    p = Path(path)
    if not p.exists():
        raise ConfigError(
            f"{p}: no such file or folder; expected a dataset folder, a scene or capture folder of "
            "one, or a USD scene"
        )
    if p.is_file():
        if p.suffix.lower() in USD_SUFFIXES:
            return [_usd_view(p)]
        if p.suffix.lower() in CLOUD_SUFFIXES:
            return [_cloud_file_view(p, p.stem)]
        raise ConfigError(
            f"{p}: not a folder or a USD scene ({', '.join(USD_SUFFIXES)}) or a cloud "
            f"({', '.join(CLOUD_SUFFIXES)})"
        )
    if (p / "scenes").is_dir():
        scenes = sorted(d for d in (p / "scenes").iterdir() if d.is_dir() and d.name.isdigit())
        if not scenes:
            raise ConfigError(
                f"{p / 'scenes'}: holds no scene folder (NNNN); is the dataset finished?"
            )
        manifest = _manifest(p)
        return [_scene_view(d, f"scene_{d.name}", manifest) for d in scenes]
    views = [
        _scene_view(
            p, f"scene_{p.name}" if p.name.isdigit() else p.name, _manifest(p.parent.parent)
        )
    ]
    return views


def _manifest(folder: Path) -> dict:
    try:
        return json.loads((folder / "manifest.json").read_text())
    except (OSError, ValueError):
        return {}


def _scene_view(folder: Path, name: str, manifest: dict) -> SceneView:
    view = SceneView(name)
    if (folder / "layout.json").is_file():
        view.layout = Layout.from_json(folder / "layout.json")
    if (folder / "trajectory.txt").is_file():
        times, poses = read_tum_poses(folder / "trajectory.txt")
        view.times_s, view.world_from_body = times, poses
    parts = []
    if (folder / "velodyne").is_dir():
        parts.append(_static_scans(folder))
    for g in sorted(
        d for d in folder.iterdir() if d.is_dir() and d.name.isdigit() and len(d.name) == 2
    ):
        if (g / "world_pose.txt").is_file():
            parts.append(_group_scans(g, view))
    for d in sorted(
        d for d in folder.iterdir() if d.is_dir() and (d / "groundtruth.txt").is_file()
    ):
        _tum_sensor(d, view, manifest)
    clouds = sorted(
        f for f in folder.iterdir() if f.is_file() and f.suffix.lower() in CLOUD_SUFFIXES
    )
    for f in clouds:
        c = _cloud_file_view(f, name)
        parts.append((c.xyz, c.semantic, c.instance))
    rings = []
    for d in sorted(  # a scanner rig's heads: HEAD/NNNNNN.ply, one raw scan a file
        d
        for d in folder.iterdir()
        if d.is_dir() and not d.name.isdigit() and not (d / "groundtruth.txt").is_file()
    ):
        for f in sorted(f for f in d.iterdir() if f.is_file() and f.suffix.lower() == ".ply"):
            c = _ply_view(f, name)
            parts.append((c.xyz, c.semantic, c.instance))
            rings.append(c.ring if c.ring is not None else np.zeros(len(c.xyz), np.uint16))
    if parts:
        view.xyz = np.concatenate([p[0] for p in parts])
        view.semantic = np.concatenate([p[1] for p in parts]).astype(np.uint16)
        view.instance = np.concatenate([p[2] for p in parts]).astype(np.uint32)
        if rings and sum(len(r) for r in rings) == len(view.xyz):
            view.ring = np.concatenate(rings).astype(np.uint16)
    if not len(view.xyz) and not view.shots and view.world_from_body is None:
        raise ConfigError(
            f"{folder}: holds nothing genie view can show (no scans velodyne/ or GG/, no scanner "
            "head's HEAD/NNNNNN.ply, no TUM sensor "
            f"folder, no cloud file {'/'.join(CLOUD_SUFFIXES)}, no trajectory.txt); expected a "
            "dataset folder, a scene or capture folder of one, or a USD scene"
        )
    view.shots.sort(key=lambda s: (s.time_s if s.time_s is not None else -1.0, s.camera))
    return view


def read_poses_3x4(path: Path) -> np.ndarray:
    """(n, 4, 4) float64 from a KITTI poses file (12 numbers a line)."""
    rows = np.loadtxt(path, ndmin=2)
    if rows.shape[1] != 12:
        raise ConfigError(f"{path}: expected 12 numbers a line (a 3x4 pose), got {rows.shape[1]}")
    out = np.tile(np.eye(4), (len(rows), 1, 1))
    out[:, :3, :] = rows.reshape(-1, 3, 4)
    return out


def read_calib(path: Path) -> dict[str, np.ndarray]:
    """``KEY: 12 numbers`` lines of a KITTI calib.txt, each as (3, 4) float64."""
    out = {}
    for line in path.read_text().splitlines():
        if ":" in line:
            k, v = line.split(":", 1)
            out[k.strip()] = np.array(v.split(), np.float64).reshape(3, 4)
    return out


def read_tum_poses(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(times (n,) s, poses (n, 4, 4)) of a TUM file ``t tx ty tz qx qy qz qw``."""
    rows = np.loadtxt(path, comments="#", ndmin=2)
    if rows.shape[1] != 8:
        raise ConfigError(
            f"{path}: expected 8 numbers a line (t tx ty tz qx qy qz qw), got {rows.shape[1]}"
        )
    poses = np.tile(np.eye(4), (len(rows), 1, 1))
    poses[:, :3, :3] = _rotation(rows[:, 4:8])
    poses[:, :3, 3] = rows[:, 1:4]
    return rows[:, 0], poses


def _rotation(q: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations of (n, 4) unit quaternions x, y, z, w."""
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    x, y, z, w = q.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        1,
    )


def _static_scans(folder: Path):
    poses = read_poses_3x4(folder / "poses.txt")
    xyz, sem, inst = [], [], []
    for j, pose in enumerate(poses):
        p, s, i = semantickitti.read(folder / "velodyne" / f"{j:06d}.bin")
        xyz.append(p.astype(np.float64) @ pose[:3, :3].T + pose[:3, 3])
        sem.append(s)
        inst.append(i)
    return np.concatenate(xyz), np.concatenate(sem), np.concatenate(inst)


def split_projection(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """K (3, 3) and the rigid (4, 4) camera_from_reference of ``P = K [R|t]`` (RQ of P's left
    3x3)."""
    M = P[:, :3]
    # RQ through QR of the row-reversed transpose
    flip = np.eye(3)[::-1]
    q, r = np.linalg.qr((flip @ M).T)
    K = flip @ r.T @ flip
    R = flip @ q.T
    signs = np.diag(np.sign(np.diag(K)))
    K, R = K @ signs, signs @ R
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = np.linalg.solve(K, P[:, 3])
    return K / K[2, 2], T


def _group_scans(g: Path, view: SceneView):
    """A recording's sequence group: its scans in the world and camera 0..3 at each scan."""
    world0 = np.eye(4)
    world0[:3] = np.loadtxt(g / "world_pose.txt").reshape(3, 4)
    calib = read_calib(g / "calib.txt")
    Tr = np.eye(4)
    Tr[:3] = calib["Tr"]
    poses = read_poses_3x4(g / "poses.txt")
    times = np.loadtxt(g / "times.txt", ndmin=1)
    cams, seen = [], []
    for k in ("P0", "P1", "P2", "P3"):
        if k in calib and not any(np.array_equal(calib[k], s) for s in seen):
            seen.append(calib[k])
            cams.append(split_projection(calib[k]))
    world_from_cam0_first = world0 @ np.linalg.inv(Tr)
    xyz, sem, inst = [], [], []
    for i, pose in enumerate(poses):
        p, s, n = semantickitti.read(g / "velodyne" / f"{i:06d}.bin")
        T = world_from_cam0_first @ pose @ Tr
        xyz.append(p.astype(np.float64) @ T[:3, :3].T + T[:3, 3])
        sem.append(s)
        inst.append(n)
        cam0 = world_from_cam0_first @ pose
        for j, (K, cam_from_cam0) in enumerate(cams):
            size = (int(round(2 * K[0, 2] + 1)), int(round(2 * K[1, 2] + 1)))
            view.shots.append(
                Shot(
                    f"group_{g.name}_cam{j}",
                    float(times[i]),
                    cam0 @ np.linalg.inv(cam_from_cam0),
                    K,
                    size,
                )
            )
    return np.concatenate(xyz), np.concatenate(sem), np.concatenate(inst)


def _intrinsics(manifest: dict, sensor_name: str):
    """The K and size of rig sensor ``sensor_name`` (or the run's one sensor), from the
    sensor or rig the dataset's manifest names; None when it cannot be read."""
    inputs = manifest.get("inputs", {})
    try:
        if inputs.get("rig"):
            rig = load_rig(inputs["rig"])
            s = next(r.sensor for r in rig.sensors if r.name == sensor_name)
        else:
            s = load_sensor(inputs["sensor"])
        return np.asarray(s.K, np.float64), (int(s.width), int(s.height))
    except (KeyError, StopIteration, OSError, ValueError) as exc:
        log.warning("camera %s: intrinsics unknown (%s); shown without a pinhole", sensor_name, exc)
        return None, (0, 0)


def _png(path: Path) -> np.ndarray:
    with Image.open(path) as im:
        return np.asarray(im)


def _tum_sensor(d: Path, view: SceneView, manifest: dict) -> None:
    times, poses = read_tum_poses(d / "groundtruth.txt")
    K, size = _intrinsics(manifest, d.name)
    for t, pose in zip(times, poses):
        stamp = f"{t:.6f}.png"
        shot = Shot(d.name, float(t), pose, K, size)
        if (d / "depth" / stamp).is_file():
            shot.depth = (_png(d / "depth" / stamp).astype(np.float64) / TUM_DEPTH_SCALE).astype(
                np.float32
            )
            if K is None:
                shot.size = shot.depth.shape[::-1]
        if (d / "semantic" / stamp).is_file():
            shot.semantic = _png(d / "semantic" / stamp).astype(np.uint16)
        if (d / "instance" / stamp).is_file():
            shot.instance = _png(d / "instance" / stamp).astype(np.uint32)
        view.shots.append(shot)


def _cloud_file_view(f: Path, name: str) -> SceneView:
    """A cloud file genie-gl wrote, read with its format's reader (world coordinates)."""
    suffix = f.suffix.lower()
    if suffix == ".npz":
        c = npz.read(f)
    elif suffix == ".las":
        c = las.read(f)
    elif suffix == ".e57":
        cs = e57.read(f)
        return SceneView(
            name,
            np.concatenate([c.world_xyz for c in cs]),
            np.concatenate([c.semantic for c in cs]),
            np.concatenate([c.instance for c in cs]),
        )
    elif suffix == ".ply":
        return _ply_view(f, name)
    else:
        raise ConfigError(
            f"{f}: genie view reads clouds as .ply, .npz, .las or .e57 (capture with one of them)"
        )
    return SceneView(name, c.world_xyz, c.semantic, c.instance)


PLY_TYPES = {
    "float": "<f4",
    "float32": "<f4",
    "double": "<f8",
    "float64": "<f8",
    "uchar": "u1",
    "uint8": "u1",
    "char": "i1",
    "int8": "i1",
    "ushort": "<u2",
    "uint16": "<u2",
    "short": "<i2",
    "int16": "<i2",
    "uint": "<u4",
    "uint32": "<u4",
    "int": "<i4",
    "int32": "<i4",
}


def _ply_view(f: Path, name: str) -> SceneView:
    """A binary little-endian PLY of vertices (``x y z``, ``semantic``, ``instance`` as
    :mod:`genie_gl.export.ply` writes them; world = xyz + the ``comment origin``)."""
    raw = f.read_bytes()
    end = raw.find(b"end_header\n")
    if not raw.startswith(b"ply") or end < 0:
        raise ConfigError(f"{f}: not a PLY file (no 'ply' ... 'end_header')")
    fields, origin, count, fmt = [], np.zeros(3), 0, ""
    for line in raw[:end].decode("ascii", "replace").splitlines():
        w = line.split()
        if w[:2] == ["comment", "origin"]:
            origin = np.array(w[2:5], np.float64)
        elif w[:1] == ["format"]:
            fmt = w[1]
        elif w[:2] == ["element", "vertex"]:
            count = int(w[2])
        elif w[:1] == ["element"]:
            break
        elif w[:1] == ["property"] and len(w) == 3 and w[1] in PLY_TYPES:
            fields.append((w[2], PLY_TYPES[w[1]]))
    if fmt != "binary_little_endian" or not {"x", "y", "z"} <= {n for n, _ in fields}:
        raise ConfigError(
            f"{f}: genie view reads binary little-endian PLY vertices with x, y, z (as genie-gl "
            "writes them)"
        )
    v = np.frombuffer(raw, np.dtype(fields), count, end + len("end_header\n"))
    names = v.dtype.names
    xyz = np.stack([v["x"], v["y"], v["z"]], 1).astype(np.float64) + origin
    zeros = np.zeros(len(xyz))
    return SceneView(
        name,
        xyz,
        np.asarray(v["semantic"] if "semantic" in names else zeros, np.uint16),
        np.asarray(v["instance"] if "instance" in names else zeros, np.uint32),
        ring=np.asarray(v["ring"], np.uint16) if "ring" in names else None,
    )


def _usd_view(path: Path) -> SceneView:
    scene = read_usd(path)
    view = SceneView(path.stem)
    for inst in scene.instances:
        m = scene.meshes[inst.mesh]
        T = inst.world_from_model
        v = (m.vertices.astype(np.float64) @ T[:3, :3].T + T[:3, 3]).astype(np.float32)
        view.meshes.append(
            (v, np.asarray(m.faces, np.uint32), int(inst.semantic), int(inst.instance))
        )
    if not view.meshes:
        raise ConfigError(f"{path}: the USD stage holds no mesh to show")
    return view
