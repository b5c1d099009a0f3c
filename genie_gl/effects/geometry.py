"""Per-pixel geometry of a frame for the effects: rays, camera-frame points, normals, incidence.

All arrays are in the camera frame (OpenCV: x right, y down, z forward) and indexed like the
frame's buffers (row v, column u). Pure numpy (the lens maps of :mod:`genie_gl.camera`): no GL.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..camera import Camera
from ..frame import Frame


def pixel_rays(sensor: Camera) -> np.ndarray:
    """(H, W, 2) float64: x and y of the camera-frame ray (z = 1) of every pixel (the
    undistorted ray for a distorted sensor: :meth:`Camera.rays`; (0, 0) for a pixel without
    one, past the lens's fold); cached per camera model, read-only."""
    return _safe_rays(sensor.lens_key)


def pixel_rays_xy(sensor: Camera) -> tuple[np.ndarray, np.ndarray]:
    """The rays of :func:`pixel_rays` as (X, Y): (1, W) and (H, 1) when x depends on the
    column only and y on the row only (a pinhole sensor: the same values), else (H, W) each.
    For compiled loops that would otherwise stream the (H, W, 2) array; read-only."""
    return _separable_rays(sensor.lens_key)


@lru_cache(maxsize=16)
def _separable_rays(key: tuple) -> tuple[np.ndarray, np.ndarray]:
    xy = _safe_rays(key)
    X, Y = xy[..., 0], xy[..., 1]
    if (X == X[:1]).all() and (Y == Y[:, :1]).all():
        X, Y = X[:1], Y[:, :1]
    X, Y = np.ascontiguousarray(X), np.ascontiguousarray(Y)
    X.setflags(write=False)
    Y.setflags(write=False)
    return X, Y


@lru_cache(maxsize=16)
def _safe_rays(key: tuple) -> np.ndarray:
    model, w, h, K, dist = key
    xy = np.nan_to_num(
        Camera(w, h, np.frombuffer(K).reshape(3, 3), np.frombuffer(dist), model=model).rays()
    )
    xy.setflags(write=False)
    return xy


def camera_points(frame: Frame) -> np.ndarray:
    """(H, W, 3) float64: the camera-frame point of every pixel, depth · (x, y, 1); zero where
    there is no return."""
    z = frame.depth.astype(np.float64)
    xy = pixel_rays(frame.sensor)
    return np.concatenate([xy * z[..., None], z[..., None]], axis=-1)


@lru_cache(maxsize=16)
def _directions(key: tuple) -> np.ndarray:
    xy = _safe_rays(key)
    d = np.concatenate([xy, np.ones(xy.shape[:2] + (1,))], axis=-1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    d.setflags(write=False)
    return d


def view_directions(sensor: Camera) -> np.ndarray:
    """(H, W, 3) float64 unit vectors from the camera centre through every pixel; cached."""
    return _directions(sensor.lens_key)


def surface_normals(frame: Frame) -> np.ndarray:
    """(H, W, 3) float64 unit normals facing the camera; zero where unknown.

    ``frame.normal`` (the renderer's exact face normals) when the frame has it; otherwise
    estimated from the depth image by central differences of the camera-frame points (pixels
    on the border or beside a hole get no normal). The estimate is a fallback for frames made
    elsewhere: ``simulate`` renders normals for every effect that declares ``needs_normals``.
    """
    if frame.normal is not None:
        return frame.normal.astype(np.float64)
    P = camera_points(frame)
    valid = frame.depth > 0
    n = np.zeros_like(P)
    du = P[1:-1, 2:] - P[1:-1, :-2]
    dv = P[2:, 1:-1] - P[:-2, 1:-1]
    c = np.cross(du, dv)
    ok = valid[1:-1, 2:] & valid[1:-1, :-2] & valid[2:, 1:-1] & valid[:-2, 1:-1] & valid[1:-1, 1:-1]
    length = np.linalg.norm(c, axis=-1)
    ok &= length > 0
    c[ok] /= length[ok, None]
    c[~ok] = 0
    # face the camera: the normal points against the viewing ray
    flip = (c * P[1:-1, 1:-1]).sum(-1) > 0
    c[flip] *= -1
    n[1:-1, 1:-1] = c
    return n


def incidence_angle(frame: Frame) -> np.ndarray:
    """(H, W) float64 incidence angle θ in radians, in [0, π/2]: the angle between the surface
    normal and the ray back to the camera. 0 where there is no return or no normal."""
    n = surface_normals(frame)
    d = view_directions(frame.sensor)
    cos = -(n[..., 0] * d[..., 0] + n[..., 1] * d[..., 1] + n[..., 2] * d[..., 2])
    has = (frame.depth > 0) & ((n[..., 0] != 0) | (n[..., 1] != 0) | (n[..., 2] != 0))
    return np.where(has, np.arccos(np.clip(cos, 0.0, 1.0)), 0.0)
