"""Frames to points: one compiled pass per frame (validity, pose transform and label gather
fused; see :mod:`.kernels`).

A pinhole camera's rays are separable (x from the column, y from the row), so no table is read;
a distorted (or skewed) camera reads a ray table computed once per camera model, holding for
every pixel the camera-frame direction with z = 1 of its undistorted ray: the inverse of the
frame's lens (:meth:`genie_gl.camera.Camera.rays`), never K alone.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..camera import Camera
from ..frame import Frame
from . import kernels
from .pointcloud import PointCloud


@lru_cache(maxsize=32)
def _table(key: tuple) -> np.ndarray:
    model, w, h, K, dist = key
    xy = Camera(w, h, np.frombuffer(K).reshape(3, 3), np.frombuffer(dist), model=model).rays()
    # x and y as two contiguous rows (z is 1): gathers from them are twice as fast. A pixel
    # without a ray (past the lens's fold) gets none here either; rendering gives it no return.
    table = np.nan_to_num(np.stack([xy[..., 0].ravel(), xy[..., 1].ravel()])).astype(np.float32)
    table.setflags(write=False)
    return table


def ray_table(sensor: Camera) -> np.ndarray:
    """(2, H·W) float32: x and y of the camera-frame ray (z = 1) of every pixel, row-major,
    through the inverse of the camera's lens; cached per camera model."""
    return _table(sensor.lens_key)


@lru_cache(maxsize=32)
def _axes(w: int, h: int, K: bytes) -> tuple[np.ndarray, np.ndarray]:
    """The separable rays of a pinhole without skew: x (1, W) by column, y (H, 1) by row."""
    Km = np.frombuffer(K).reshape(3, 3)
    xs = ((np.arange(w) - Km[0, 2]) / Km[0, 0]).astype(np.float32)
    ys = ((np.arange(h) - Km[1, 2]) / Km[1, 1]).astype(np.float32)
    return xs[None], ys[:, None]


def rays(sensor: Camera) -> tuple[np.ndarray, np.ndarray]:
    """(tx, ty), the camera-frame ray (x, y, 1) of every pixel as the kernel reads it: (1, W)
    and (H, 1) for a pinhole without skew, (H, W) tables otherwise; cached per camera model."""
    if not sensor.is_pinhole or sensor.K[0, 1] != 0:
        t = ray_table(sensor).reshape(2, sensor.height, sensor.width)
        return t[0], t[1]
    return _axes(sensor.width, sensor.height, sensor.K.tobytes())


def _pose_rows(frame: Frame, origin: np.ndarray) -> np.ndarray:
    """(3, 4) float32 [R | t - origin]: the difference taken in float64, so far scenes stay
    exact."""
    M = frame.world_from_camera[:3].copy()
    M[:, 3] -= origin
    return M.astype(np.float32)


NO_RGB = np.zeros((0, 0, 3), np.uint8)  # no colour source
NO_RGB_OUT = np.zeros((0, 3), np.uint8)  # no colour output


def _colour_source(rgb: np.ndarray) -> np.ndarray:
    """``rgb`` as the kernel reads it: C-contiguous (H, W, 3), or the (H, W, 4) RGBA block a
    read-back ``[..., :3]`` view lies in (no copy; a read-only view, and only when the block
    lies wholly inside the memory the view's owner holds), else a contiguous copy."""
    if rgb.flags.c_contiguous:
        return rgb
    H, W, _ = rgb.shape
    if rgb.strides == (4 * W, 4, 1):
        owner = rgb
        while isinstance(owner.base, np.ndarray):
            owner = owner.base
        lo, hi = owner.ctypes.data, owner.ctypes.data + owner.nbytes
        if lo <= rgb.ctypes.data and rgb.ctypes.data + 4 * H * W <= hi:
            return np.lib.stride_tricks.as_strided(rgb, (H, W, 4), writeable=False)  # rgb's strides
    return np.ascontiguousarray(rgb)


def unproject_into(
    frame: Frame,
    origin: np.ndarray,
    xyz: np.ndarray,
    semantic: np.ndarray,
    instance: np.ndarray,
    rgb: np.ndarray | None = None,
    *,
    n: int | None = None,
) -> int:
    """Write ``frame``'s valid points (and colours, when ``rgb`` is given) into the given
    arrays, in pixel order; returns their number n. The outputs need room for n + 1 points
    and xyz for n + 2 (the kernel's branch-free compaction writes past the last point; see
    :mod:`.kernels`). n : the frame's valid-pixel count (``kernels.count_valid``) when the
    caller knows it; the room is checked either way, before anything is written."""
    colour = rgb is not None and frame.rgb is not None
    n = kernels.count_valid(frame.depth) if n is None else n
    room = min(
        xyz.shape[0] - 1, semantic.shape[0], instance.shape[0], rgb.shape[0] if colour else n + 1
    )
    if room < n + 1 or xyz.ndim != 2 or xyz.shape[1] != 3:
        raise ValueError(
            f"unproject_into: {n} points need xyz (>= {n + 2}, 3) and labels (>= {n + 1},); "
            f"got xyz {xyz.shape}, semantic {semantic.shape}, instance {instance.shape}"
        )
    tx, ty = rays(frame.sensor)
    c = np.ascontiguousarray
    return kernels.unproject(
        c(frame.depth),
        tx,
        ty,
        _pose_rows(frame, origin),
        c(frame.semantic),
        c(frame.instance),
        _colour_source(frame.rgb) if colour else NO_RGB,
        xyz,
        semantic,
        instance,
        rgb if colour else NO_RGB_OUT,
    )


def world_normals(frame: Frame) -> np.ndarray:
    """(n, 3) float32 world-frame normals of the valid pixels, in pixel order."""
    return rotate(frame.normal[frame.valid], frame.world_from_camera)


def rotate(v: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """(n, 3) float32 vectors turned by the pose's rotation, element by element in float32
    (a matrix product's rounding can depend on how many rows it is given)."""
    R = pose.astype(np.float32)  # only its rotation block R[:3, :3] is read
    return np.stack(
        [v[:, 0] * R[r, 0] + v[:, 1] * R[r, 1] + v[:, 2] * R[r, 2] for r in range(3)], 1
    )


def unproject(
    frame: Frame, *, origin: np.ndarray | None = None, camera_index: int | None = None
) -> PointCloud:
    """The world-frame points of ``frame``'s valid pixels (0 < depth < inf), relative to
    ``origin``."""
    origin = np.zeros(3) if origin is None else np.asarray(origin, np.float64)
    n = kernels.count_valid(frame.depth)
    xyz = np.empty((n + 2, 3), np.float32)
    sem, inst = np.empty(n + 1, np.uint16), np.empty(n + 1, np.uint32)
    rgb = None if frame.rgb is None else np.empty((n + 1, 3), np.uint8)
    unproject_into(frame, origin, xyz, sem, inst, rgb, n=n)
    normal = None if frame.normal is None else world_normals(frame)
    camera = None if camera_index is None else np.full(n, camera_index, np.uint16)
    return PointCloud(
        xyz[:n], sem[:n], inst[:n], origin, None if rgb is None else rgb[:n], normal, camera
    )
