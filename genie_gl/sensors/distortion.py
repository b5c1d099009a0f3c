"""Lens distortion for every OpenCV model: render an ideal pinhole image wide enough to
cover the distorted field, then remap it (nearest neighbour: ids never blended, depth never
mixed across silhouettes). Pixels whose ray lies beyond the model's valid range get 0."""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

from ..frame import Frame
from .camera import Sensor

CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)


@dataclass(frozen=True, eq=False)
class DistortionMaps:
    """The wide pinhole render and, per distorted pixel, where to sample it."""

    render_sensor: Sensor
    map_x: np.ndarray   # (H, W) float32
    map_y: np.ndarray
    valid: np.ndarray   # (H, W) bool


def _key(s: Sensor) -> tuple:
    return (s.width, s.height, s.K.tobytes(), s.dist.tobytes(), s.near_m, s.far_m)


@lru_cache(maxsize=16)
def _undistorted(w: int, h: int, K: bytes, dist: bytes) -> np.ndarray:
    Km = np.frombuffer(K).reshape(3, 3)
    D = np.frombuffer(dist)
    u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    xy = cv2.undistortPoints(np.stack([u, v], -1).reshape(-1, 1, 2), Km, D, None, None, None,
                             CRITERIA).reshape(h, w, 2)
    xy.setflags(write=False)
    return xy


def undistorted_rays(sensor: Sensor) -> np.ndarray:
    """(H, W, 2) float64: x, y (z = 1) of the ray of every distorted pixel (NaN where the model
    has none); cached per camera model, read-only."""
    return _undistorted(sensor.width, sensor.height, sensor.K.tobytes(), sensor.dist.tobytes())


def project(xy: np.ndarray, K: np.ndarray, D: np.ndarray) -> np.ndarray:
    """(N, 2) pixels of the normalised points ``xy`` (N, 2) through OpenCV's lens model:
    the equations of FORMATS.md §3.2 in numpy (cv2.projectPoints for the tilted model and
    for a skewed K), several times faster than cv2 on whole images."""
    D = np.asarray(D, np.float64)
    if len(D) == 14 or K[0, 1] != 0:
        pts = np.concatenate([xy, np.ones((len(xy), 1))], 1).reshape(-1, 1, 3)
        return cv2.projectPoints(pts, np.zeros(3), np.zeros(3), K, D)[0].reshape(-1, 2)
    k = np.zeros(12)
    k[:len(D)] = D
    k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4 = k
    x, y = xy[:, 0], xy[:, 1]
    r2 = x * x + y * y
    r4 = r2 * r2
    radial = (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x) + s1 * r2 + s2 * r4
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y + s3 * r2 + s4 * r4
    return np.stack([K[0, 0] * xd + K[0, 2], K[1, 1] * yd + K[1, 2]], 1)


@lru_cache(maxsize=16)
def _maps(key: tuple) -> DistortionMaps:
    W, H = key[0], key[1]
    K = np.frombuffer(key[2]).reshape(3, 3)
    D = np.frombuffer(key[3])
    u, v = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    uv = np.stack([u, v], -1).reshape(-1, 2)
    xy = _undistorted(W, H, key[2], key[3]).reshape(-1, 2)
    # valid where the model maps the ray back onto its pixel (no folding past its range)
    with np.errstate(invalid="ignore", over="ignore"):
        err = np.linalg.norm(project(xy, K, D) - uv, axis=1)
    valid = np.isfinite(xy).all(1) & (err < 0.01)
    xv = xy[valid]
    fx, fy = K[0, 0], K[1, 1]
    lo = xv.min(0) if len(xv) else np.zeros(2)
    hi = xv.max(0) if len(xv) else np.zeros(2)
    w_r = int(np.ceil((hi[0] - lo[0]) * fx)) + 3
    h_r = int(np.ceil((hi[1] - lo[1]) * fy)) + 3
    cx_r, cy_r = -lo[0] * fx + 1, -lo[1] * fy + 1
    Kr = np.array([[fx, 0, cx_r], [0, fy, cy_r], [0, 0, 1.0]])
    mx = (xy[:, 0] * fx + cx_r).reshape(H, W)
    my = (xy[:, 1] * fy + cy_r).reshape(H, W)
    valid = valid.reshape(H, W)
    mx[~valid], my[~valid] = -1, -1
    rs = Sensor(w_r, h_r, Kr, near_m=key[4], far_m=key[5], name="pinhole-margin")
    return DistortionMaps(rs, mx.astype(np.float32), my.astype(np.float32), valid)


def distortion_maps(sensor: Sensor) -> DistortionMaps:
    """Cached maps of a distorted ``sensor``."""
    return _maps(_key(sensor))


def distort(wide: Frame, sensor: Sensor, maps: DistortionMaps) -> Frame:
    """Resample the wide pinhole ``wide`` into ``sensor``'s distorted image."""
    def nearest(img: np.ndarray) -> np.ndarray:
        if img.dtype == np.uint32:  # remap has no 32-bit unsigned: go through the bits as float
            out = cv2.remap(img.view(np.float32), maps.map_x, maps.map_y, cv2.INTER_NEAREST,
                            borderMode=cv2.BORDER_CONSTANT, borderValue=0)
            return out.view(np.uint32)
        return cv2.remap(img, maps.map_x, maps.map_y, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT,
                         borderValue=0)

    depth, inst, sem = nearest(wide.depth), nearest(wide.instance), nearest(wide.semantic)
    inv = ~maps.valid
    depth[inv], inst[inv], sem[inv] = 0, 0, 0
    rgb = None if wide.rgb is None else nearest(wide.rgb)
    normal = None if wide.normal is None else nearest(wide.normal)
    if rgb is not None:
        rgb[inv] = 0
    return Frame(depth, inst, sem, rgb, sensor, wide.world_from_camera, normal, wide.meta)
