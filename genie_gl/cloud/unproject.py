"""Frames to points: per-camera ray tables computed once, then one gather per frame.

A ray table holds, for every pixel, the camera-frame direction with z = 1 (so depth · ray is
the point); a distorted sensor's table holds the undistorted ray of each distorted pixel.
"""
from __future__ import annotations

from functools import lru_cache

import cv2
import numpy as np

from ..frame import Frame
from ..sensors.camera import Sensor
from .pointcloud import PointCloud

CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)


@lru_cache(maxsize=32)
def _table(w: int, h: int, K: bytes, dist: bytes) -> np.ndarray:
    Km = np.frombuffer(K).reshape(3, 3)
    D = np.frombuffer(dist)
    u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    if np.any(D):
        xy = cv2.undistortPoints(np.stack([u, v], -1).reshape(-1, 1, 2), Km, D, None, None, None,
                                 CRITERIA).reshape(h, w, 2)
        x, y = xy[..., 0], xy[..., 1]
    else:
        y = (v - Km[1, 2]) / Km[1, 1]
        x = (u - Km[0, 2] - Km[0, 1] * y) / Km[0, 0]
    # x and y as two contiguous rows (z is 1): gathers from them are twice as fast
    table = np.stack([x.ravel(), y.ravel()]).astype(np.float32)
    table.setflags(write=False)
    return table


def ray_table(sensor: Sensor) -> np.ndarray:
    """(2, H·W) float32: x and y of the camera-frame ray (z = 1) of every pixel, row-major;
    cached per camera model."""
    return _table(sensor.width, sensor.height, sensor.K.tobytes(), sensor.dist.tobytes())


def unproject(frame: Frame, *, origin: np.ndarray | None = None, camera_index: int | None = None) -> PointCloud:
    """The world-frame points of ``frame``'s valid pixels (depth > 0), relative to ``origin``."""
    origin = np.zeros(3) if origin is None else np.asarray(origin, np.float64)
    depth = frame.depth.ravel()
    idx = np.flatnonzero(depth)
    pose = frame.world_from_camera
    R = pose[:3, :3].astype(np.float32)
    t = (pose[:3, 3] - origin).astype(np.float32)  # float64 difference first: exact far away
    table = ray_table(frame.sensor)
    d = depth[idx]
    rx, ry = table[0][idx], table[1][idx]   # z of every ray is 1
    xyz = np.empty((len(idx), 3), np.float32)
    # (R · (d·ray)) + t, one column at a time: (N, 3) @ (3, 3) matmul is several times slower
    for k in range(3):
        col = rx * R[k, 0]
        col += ry * R[k, 1]
        col += R[k, 2]
        col *= d
        col += t[k]
        xyz[:, k] = col
    rgb = None if frame.rgb is None else frame.rgb.reshape(-1, 3)[idx]
    normal = None if frame.normal is None else frame.normal.reshape(-1, 3)[idx] @ R.T
    camera = None if camera_index is None else np.full(len(idx), camera_index, np.uint16)
    return PointCloud(xyz, frame.semantic.ravel()[idx], frame.instance.ravel()[idx], origin, rgb, normal, camera)
