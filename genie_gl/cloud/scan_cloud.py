"""Scans as ``PointCloud`` s, with the scanner's fields (intensity, ring, time, returns).

Three frames, as the field's tools want them:

- ``world``: the points in the world (exact; a mobile map fuses these);
- ``raw``: each point in the scanner's frame at its own firing, as a driver reports a
  moving head's scan (skewed; ROS bags, PCD and PLY scans for deskewing tools);
- ``deskewed``: in the scanner's frame at the scan's start, the motion undone with the true
  poses (what KITTI odometry scans hold).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..capture.scan_record import Scan
from ..errors import ConfigError
from .pointcloud import PointCloud

FRAMES = ("world", "raw", "deskewed")


def scan_cloud(scan: Scan, frame: str = "raw", *, origin: np.ndarray | None = None) -> PointCloud:
    """One scan as a PointCloud in ``frame`` (one of :data:`FRAMES`); ``origin`` (world
    frame only): where xyz = 0 lies (default: the scan's start position snapped to 100 m)."""
    if frame not in FRAMES:
        raise ConfigError(f"scan frame {frame!r}: expected one of {', '.join(FRAMES)}")
    if frame == "world":
        if origin is None:
            origin = np.round(scan.start_pose[:3, 3] / 100.0) * 100.0
        origin = np.asarray(origin, np.float64)
        xyz = (scan.world_xyz - origin).astype(np.float32)
    else:
        origin = np.zeros(3)
        xyz = (scan.sensor_xyz if frame == "raw" else scan.deskewed_xyz()).astype(np.float32)
    return PointCloud(
        xyz,
        scan.semantic,
        scan.instance,
        origin,
        intensity=scan.intensity,
        ring=scan.ring,
        time=scan.time_s,
        return_number=scan.return_number,
        returns=scan.returns,
    )


def scans_cloud(scans: Sequence[Scan], *, origin: np.ndarray | None = None) -> PointCloud:
    """Many scans fused in the world (a mobile map); ``time`` stays per scan (from its start)."""
    if not scans:
        raise ConfigError("scans_cloud: no scan")
    if origin is None:
        origin = np.round(scans[0].start_pose[:3, 3] / 100.0) * 100.0
    return PointCloud.concatenate([scan_cloud(s, "world", origin=origin) for s in scans])
