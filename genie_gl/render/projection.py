"""Camera maths for the rasteriser: OpenCV K to clip space, frustum planes, rigid inverses.

All in float64; the renderer casts to float32 only after composing transforms relative to
the camera.
"""

from __future__ import annotations

import numpy as np


def clip_coefficients(K: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients of the OpenCV pinhole model in clip space.

    With eye point (x, y, z) (OpenCV camera frame), ``clip_x = a·x + b·y + c·z`` and
    ``clip_y = d·y + e·z``, ``clip_w = z``: the pixel with centre (u, v) = (fx x/z + s y/z + cx,
    fy y/z + cy) lands at window (u + 0.5, v + 0.5), so read-back row 0 is v = 0.

    Returns
    -------
    proj_x : (3,) float64, (a, b, c).
    proj_y : (2,) float64, (d, e).
    """
    fx, s, cx = K[0, 0], K[0, 1], K[0, 2]
    fy, cy = K[1, 1], K[1, 2]
    proj_x = np.array([2 * fx / width, 2 * s / width, 2 * (cx + 0.5) / width - 1])
    proj_y = np.array([2 * fy / height, 2 * (cy + 0.5) / height - 1])
    return proj_x, proj_y


def frustum_planes(K: np.ndarray, width: int, height: int, near: float) -> np.ndarray:
    """(5, 4) float64 planes ``n·p + d >= 0`` bounding what the camera sees (camera frame).

    Planes: near, left (u = -0.5), right (u = W - 0.5), top (v = -0.5), bottom (v = H - 0.5);
    a margin of one pixel keeps culling conservative (skew included by widening).
    """
    fx, s, cx = K[0, 0], K[0, 1], K[0, 2]
    fy, cy = K[1, 1], K[1, 2]
    y_top, y_bot = (-1.5 - cy) / fy, (height + 0.5 - cy) / fy
    skew = abs(s) * max(abs(y_top), abs(y_bot)) / fx
    x_lo, x_hi = (-1.5 - cx) / fx - skew, (width + 0.5 - cx) / fx + skew
    planes = np.array(
        [
            [0.0, 0.0, 1.0, -near],
            [1.0, 0.0, -x_lo, 0.0],
            [-1.0, 0.0, x_hi, 0.0],
            [0.0, 1.0, -y_top, 0.0],
            [0.0, -1.0, y_bot, 0.0],
        ]
    )
    planes[1:] /= np.linalg.norm(planes[1:, :3], axis=1, keepdims=True)
    return planes


_EYE3 = np.eye(3)


def rigid_inverse(T: np.ndarray) -> np.ndarray:
    """Inverse of a 4x4 transform; exact (transpose) when its rotation is orthonormal."""
    T = np.asarray(T, dtype=np.float64)
    R = T[:3, :3]
    # np.allclose(R @ R.T, I, atol=1e-12) without its per-call overhead (once per frame)
    if (np.abs(R @ R.T - _EYE3) <= 1e-12 + 1e-5 * _EYE3).all():
        out = np.eye(4)
        out[:3, :3] = R.T
        out[:3, 3] = -R.T @ T[:3, 3]
        return out
    return np.linalg.inv(T)


# camera poses belong to the sensors stage; re-exported here for the renderer's users
