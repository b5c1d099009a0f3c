"""Scans as the survey formats, with the scanner's fields (LIDAR.md §9.5).

**LAS 1.4, point format 6** (written with ``laspy``), the scans fused in the world:
``X Y Z`` scaled integers (0.1 mm, offsets at the cloud's origin); ``intensity`` the
reflectivity x 65535 (LAS asks for 16 bits over the sensor's range); ``return_number`` and
``number_of_returns``; ``scanner_channel`` the head (0-3: LAS's head of a multi-head system,
not the ring); ``scan_angle`` the beam's azimuth in its head's frame, 0.006 degrees per count;
``gps_time`` the pulse's emission time on the recording clock (s; equal for every echo of a
pulse); ``classification`` the semantic id; ``synthetic`` set; extra bytes ``ring`` (uint16)
and ``instance_id`` (uint32).

**E57** (written with libE57Format through ``pye57.libe57``): one Data3D scan per scan, its
pose the head's at the scan start and its points in that frame (deskewed), with
``rowIndex`` (the ring), ``columnIndex`` (the firing), ``returnIndex`` (0-based) and
``returnCount``, ``timeStamp`` (s from the scan's start) and ``intensity`` (0-1). pye57's
own reader gives back the coordinates, rows, columns and intensity; the time stamps and
returns are read with libE57Format itself.
"""

from __future__ import annotations

import os
import uuid
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..capture.scan_record import Scan
from ..cloud.scan_cloud import scans_cloud
from ..errors import ExportError
from ..outputs import check_replaceable, written
from ..motion.trajectory import quaternion_xyzw
from .e57 import _guids, _pye57, content_guid
from .las import SCALE_M, SOFTWARE, _laspy, las_is_ours

SCAN_ANGLE_DEG = 0.006  # LAS 1.4 scan angle: degrees per count


def write_scans_las(scans: Sequence[Scan], path: str | os.PathLike) -> Path:
    """The scans fused in the world as one LAS 1.4 (point format 6) file."""
    laspy = _laspy()
    if not scans or not sum(len(s) for s in scans):
        raise ExportError(f"{path}: no point in the scans; nothing was written")
    if max(s.head_index for s in scans) > 3:
        raise ExportError("LAS scanner_channel holds heads 0-3; the rig has more heads")
    path = check_replaceable(path, las_is_ours, what="LAS point cloud")
    cloud = scans_cloud(scans)
    if len(cloud) and int(cloud.semantic.max()) > 255:
        raise ExportError(
            f"LAS classification holds ids 0-255, got semantic id {int(cloud.semantic.max())}"
        )
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.generating_software = SOFTWARE
    header.scales = np.full(3, SCALE_M)
    header.offsets = np.asarray(cloud.origin, np.float64)
    header.add_extra_dim(
        laspy.ExtraBytesParams(name="ring", type=np.uint16, description="beam ring")
    )
    header.add_extra_dim(
        laspy.ExtraBytesParams(
            name="instance_id", type=np.uint32, description="genie-gl instance id"
        )
    )
    las = laspy.LasData(header)
    world = cloud.world_xyz
    las.x, las.y, las.z = world[:, 0], world[:, 1], world[:, 2]
    las.intensity = np.round(cloud.intensity.astype(np.float64) * 65535).astype(np.uint16)
    las.return_number, las.number_of_returns = cloud.return_number, cloud.returns
    las.scanner_channel = np.concatenate([np.full(len(s), s.head_index, np.uint8) for s in scans])
    az = np.concatenate([s.azimuth_rad for s in scans])
    las.scan_angle = np.round(np.degrees(az) / SCAN_ANGLE_DEG).astype(np.int16)
    las.gps_time = np.concatenate([s.start_s + s.time_s for s in scans])
    las.classification = cloud.semantic.astype(np.uint8)
    las.synthetic = np.ones(len(cloud), np.uint8)
    las.ring, las.instance_id = cloud.ring, cloud.instance
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp.las")
    path.parent.mkdir(parents=True, exist_ok=True)
    with written(path, tmp):
        las.write(str(tmp))
        tmp.replace(path)
    return path


def write_scans_e57(scans: Sequence[Scan], path: str | os.PathLike) -> Path:
    """The scans as one E57 file, a Data3D scan each (see the module's docstring); the same
    scans give the same bytes (the GUIDs come from the content)."""
    pye57 = _pye57()
    if not scans or not sum(len(s) for s in scans):
        raise ExportError(f"{path}: no point in the scans; nothing was written")
    path = check_replaceable(path, lambda p: False, what="E57")  # never over a file of the user's
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp.e57")
    path.parent.mkdir(parents=True, exist_ok=True)
    key = content_guid(*[a for s in scans for a in (s.world_xyz, s.time_s)])
    with written(path, tmp), _guids(key, "lidar"):
        e = pye57.E57(str(tmp), mode="w")
        try:
            for k, s in enumerate(scans):
                _scan_node(pye57.libe57, e.image_file, e.data3d, s, k, key)
        finally:
            e.close()
        tmp.replace(path)
    return path


def _scan_node(lib, f, data3d, s: Scan, k: int, key) -> None:
    n = len(s)
    node = lib.StructureNode(f)
    node.set("guid", lib.StringNode(f, "{%s}" % uuid.uuid5(key, f"scan.{k}")))
    node.set("name", lib.StringNode(f, f"{s.head} {s.index}"))
    node.set(
        "description",
        lib.StringNode(f, f"genie-gl scan of {s.scanner.name}, start {s.start_s:.9f} s"),
    )
    pose = lib.StructureNode(f)
    q = _quat_wxyz(s.start_pose[:3, :3])
    rot, tr = lib.StructureNode(f), lib.StructureNode(f)
    for name, v in zip("wxyz", q):
        rot.set(name, lib.FloatNode(f, float(v)))
    for name, v in zip("xyz", s.start_pose[:3, 3]):
        tr.set(name, lib.FloatNode(f, float(v)))
    pose.set("rotation", rot)
    pose.set("translation", tr)
    node.set("pose", pose)
    ring = s.ring.astype(np.uint16)
    col = s.column.astype(np.uint16)  # columns per revolution stay far below 65536 (VLP-16: 1809)
    ret = (s.return_number - 1).astype(np.uint8)
    count = s.returns.astype(np.uint8)
    bounds = lib.StructureNode(f)
    for name, v in (
        ("rowMinimum", 0),
        ("rowMaximum", int(ring.max(initial=0))),
        ("columnMinimum", 0),
        ("columnMaximum", int(col.max(initial=0))),
        ("returnMinimum", 0),
        ("returnMaximum", int(ret.max(initial=0))),
    ):
        bounds.set(name, lib.IntegerNode(f, v))
    node.set("indexBounds", bounds)
    limits = lib.StructureNode(f)
    limits.set("intensityMinimum", lib.FloatNode(f, 0.0))
    limits.set("intensityMaximum", lib.FloatNode(f, 1.0))
    node.set("intensityLimits", limits)
    proto = lib.StructureNode(f)
    xyz = s.deskewed_xyz()
    big = 1e4
    arrays = {
        "cartesianX": xyz[:, 0].copy(),
        "cartesianY": xyz[:, 1].copy(),
        "cartesianZ": xyz[:, 2].copy(),
        "intensity": s.intensity.astype(np.float32),
        "rowIndex": ring,
        "columnIndex": col,
        "returnIndex": ret,
        "returnCount": count,
        "timeStamp": s.time_s.copy(),
    }
    proto.set("cartesianX", lib.FloatNode(f, 0.0, lib.E57_DOUBLE, -big, big))
    proto.set("cartesianY", lib.FloatNode(f, 0.0, lib.E57_DOUBLE, -big, big))
    proto.set("cartesianZ", lib.FloatNode(f, 0.0, lib.E57_DOUBLE, -big, big))
    proto.set("intensity", lib.FloatNode(f, 0.0, lib.E57_SINGLE, 0.0, 1.0))
    proto.set("rowIndex", lib.IntegerNode(f, 0, 0, max(int(ring.max(initial=0)), 1)))
    proto.set("columnIndex", lib.IntegerNode(f, 0, 0, max(int(col.max(initial=0)), 1)))
    proto.set("returnIndex", lib.IntegerNode(f, 0, 0, 15))
    proto.set("returnCount", lib.IntegerNode(f, 0, 0, 15))
    proto.set("timeStamp", lib.FloatNode(f, 0.0, lib.E57_DOUBLE, -big, big))
    codecs = lib.VectorNode(f, True)
    points = lib.CompressedVectorNode(f, proto, codecs)
    node.set("points", points)
    data3d.append(node)
    bufs = lib.VectorSourceDestBuffer()
    for name, arr in arrays.items():
        bufs.append(lib.SourceDestBuffer(f, name, arr, n, True, True))
    writer = points.writer(bufs)
    writer.write(n)
    writer.close()


def _quat_wxyz(R: np.ndarray) -> np.ndarray:
    x, y, z, w = quaternion_xyzw(R)
    return np.array([w, x, y, z])
