"""A head's scans as the field's sequence formats (LIDAR.md §9.5): SemanticKITTI sequences
and ROS 2 bags of ``PointCloud2`` with the drivers' point fields.

**SemanticKITTI** (one head, one sequence folder):

- ``velodyne/NNNNNN.bin``: float32 x, y, z, remission, remission the head's reflectivity in
  [0, 1] (KITTI's own range, LIDAR.md §9.5); points in the head's frame at the scan start,
  the motion undone (``deskew=True``, what KITTI odometry scans hold) or raw, each point in
  the frame of its own firing (``deskew=False``, as KITTI raw scans);
- ``labels/``: ``(instance << 16) | semantic``; ``poses.txt``: the head at each scan start
  in the coordinates of the head at the first (3x4 rows); ``calib.txt``: ``Tr`` the identity
  (the head is the "velodyne" and the pose frame), ``P0``-``P3`` ``[I|0]``; ``times.txt``:
  each scan's start (s); ``world_pose.txt``: the head at the first scan in the world.

**ROS 2 bag** (MCAP; one topic ``/<head>/points`` per head, ``frame_id`` the head's name,
stamped with the scan's start, the recording clock's 0 at 1 ns):

- ``velodyne`` fields: ``x y z intensity`` FLOAT32 (intensity the reflectivity byte,
  0-100 for a diffuse surface), ``ring`` UINT16 (0 = lowest beam), ``time`` FLOAT32 (s from
  the header stamp, >= 0: the driver's ``timestamp_first_packet``);
- ``ouster`` fields (``ouster_ros::Point``): ``x y z intensity`` FLOAT32, ``t`` UINT32 (ns
  from the header stamp), ``reflectivity`` UINT16, ``ring`` UINT16 (0 = top row),
  ``ambient`` UINT16 (0: no sunlight simulated), ``range`` UINT32 (mm);
- ``/tf``: ``map`` -> ``<head>`` at each scan's start (the ground-truth pose).

Points are raw (as a driver publishes a moving head's scan) in firing order.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .. import __version__
from ..capture.scan_record import Scan
from ..cloud.scan_cloud import scan_cloud
from ..errors import ConfigError, ExportError
from ..outputs import atomic_write_text
from .rosbag import MAP, STAMP_KEY, _Messages, _modules, bag_is_ours
from .semantickitti import _fmt, _write_scan

STYLES = ("velodyne", "ouster")


def _one_head(scans: Sequence[Scan], what: str) -> None:
    if not scans:
        raise ExportError(f"{what}: no scan to write")
    if len({s.head for s in scans}) != 1:
        raise ExportError(
            f"{what}: one head per sequence (got {', '.join(sorted({s.head for s in scans}))}); "
            "write each head's scans on their own"
        )


def write_kitti_sequence(
    scans: Sequence[Scan], seq_dir: str | os.PathLike, *, deskew: bool = True
) -> list[Path]:
    """One head's scans as SemanticKITTI sequence folder ``seq_dir``; returns the .bin paths."""
    _one_head(scans, "SemanticKITTI sequence")
    seq = Path(seq_dir)
    first = scans[0].start_pose
    inv0 = np.linalg.inv(first)
    paths, poses = [], []
    for j, s in enumerate(scans):
        paths.append(_write_scan(scan_cloud(s, "deskewed" if deskew else "raw"), seq, j))
        poses.append(_fmt((inv0 @ s.start_pose)[:3].ravel()))
    eye = _fmt(np.eye(4)[:3].ravel())
    atomic_write_text(seq / "poses.txt", "".join(p + "\n" for p in poses))
    atomic_write_text(seq / "times.txt", "".join(f"{s.start_s:.9e}\n" for s in scans))
    atomic_write_text(
        seq / "calib.txt", "".join(f"{k}: {eye}\n" for k in ("P0", "P1", "P2", "P3", "Tr"))
    )
    atomic_write_text(seq / "world_pose.txt", _fmt(first[:3].ravel()) + "\n")
    return paths


def point_fields(scan: Scan, style: str) -> tuple[np.ndarray, list[tuple[str, int, int]]]:
    """The raw points of ``scan`` as a record array in ``style`` and its fields
    (name, offset, PointField datatype code)."""
    xyz = scan.sensor_xyz.astype("<f4")
    refl = np.round(scan.intensity.astype(np.float64) * 100.0)
    if style == "velodyne":
        dt = [
            ("x", "<f4"),
            ("y", "<f4"),
            ("z", "<f4"),
            ("intensity", "<f4"),
            ("ring", "<u2"),
            ("pad", "<u2"),
            ("time", "<f4"),
        ]
        codes = {"x": 7, "y": 7, "z": 7, "intensity": 7, "ring": 4, "time": 7}
        rec = np.zeros(len(scan), dt)
        rec["intensity"], rec["ring"], rec["time"] = refl, scan.ring, scan.time_s
    elif style == "ouster":
        dt = [
            ("x", "<f4"),
            ("y", "<f4"),
            ("z", "<f4"),
            ("intensity", "<f4"),
            ("t", "<u4"),
            ("reflectivity", "<u2"),
            ("ring", "<u2"),
            ("ambient", "<u2"),
            ("pad", "<u2"),
            ("range", "<u4"),
        ]
        codes = {
            "x": 7,
            "y": 7,
            "z": 7,
            "intensity": 7,
            "t": 6,
            "reflectivity": 4,
            "ring": 4,
            "ambient": 4,
            "range": 6,
        }
        rec = np.zeros(len(scan), dt)
        rec["intensity"], rec["reflectivity"], rec["ring"] = refl, refl, scan.ring
        rec["t"] = np.round(scan.time_s * 1e9).astype(np.uint32)
        rec["range"] = np.round(scan.range_m * 1000.0).astype(np.uint32)
    else:
        raise ConfigError(f"point style {style!r}: expected one of {', '.join(STYLES)}")
    rec["x"], rec["y"], rec["z"] = xyz.T
    fields = [(name, rec.dtype.fields[name][1], code) for name, code in codes.items()]
    return rec, fields


def write_scan_bag(
    scans: Sequence[Scan], bag_dir: str | os.PathLike, *, style: str | None = None
) -> Path:
    """The scans (any heads, any order: written in time order) as an MCAP bag in ``bag_dir``;
    ``style``: the point fields (default: each head's own, a generic head's velodyne)."""
    if not scans:
        raise ExportError("ROS 2 bag: no scan to write")
    Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime, writer, ts = _modules()
    bag_dir = Path(bag_dir)
    if bag_dir.exists() and not bag_is_ours(bag_dir):
        raise ConfigError(
            f"{bag_dir}: already exists and was not written by genie-gl; it is left as it is "
            "(remove "
            "or rename it, or write the ROS 2 bag elsewhere)"
        )
    tmp_root = bag_dir.parent / f".{bag_dir.name}.{os.getpid()}.tmp"
    shutil.rmtree(tmp_root, ignore_errors=True)
    tmp_root.mkdir(parents=True)
    m = _Messages(ts)
    F = ts.types["sensor_msgs/msg/PointField"]
    t0 = min(s.start_s for s in scans)
    try:
        with writer(tmp_root / bag_dir.name, True) as w:  # zstd chunks, as the camera bags
            w.set_custom_data(STAMP_KEY, __version__)
            tf = w.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=ts)
            topics = {}
            for s in sorted(scans, key=lambda s: (s.start_s, s.head_index)):
                t = int(round((s.start_s - t0) * 1e9)) + 1
                if s.head not in topics:
                    topics[s.head] = w.add_connection(
                        f"/{s.head}/points", "sensor_msgs/msg/PointCloud2", typestore=ts
                    )
                msg = ts.types["tf2_msgs/msg/TFMessage"](
                    transforms=[m.transform(t, MAP, s.head, s.start_pose)]
                )
                w.write(tf, t, ts.serialize_cdr(msg, "tf2_msgs/msg/TFMessage"))
                kind = style or (s.scanner.style if s.scanner.style in STYLES else "velodyne")
                rec, fields = point_fields(s, kind)
                cloud = ts.types["sensor_msgs/msg/PointCloud2"](
                    header=m.header(t, s.head),
                    height=1,
                    width=len(rec),
                    fields=[F(name=n, offset=o, datatype=c, count=1) for n, o, c in fields],
                    is_bigendian=False,
                    point_step=rec.itemsize,
                    row_step=rec.itemsize * len(rec),
                    data=rec.view(np.uint8).reshape(-1),
                    is_dense=True,
                )
                w.write(topics[s.head], t, ts.serialize_cdr(cloud, "sensor_msgs/msg/PointCloud2"))
        if bag_dir.exists():
            shutil.rmtree(bag_dir)  # a bag genie-gl wrote (checked above)
        (tmp_root / bag_dir.name).rename(bag_dir)
    finally:
        shutil.rmtree(tmp_root, ignore_errors=True)
    return bag_dir
