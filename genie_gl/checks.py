"""Checks of geometric input shared by the entry points (bottom of the package, numpy only).

- :func:`check_pose`: a camera pose is a rigid transform (rotation and translation): finite,
  last row (0, 0, 0, 1), rotation orthonormal with determinant +1 (no scale, shear or mirror).
- :data:`MAX_COORD_M`: coordinates beyond it (1e9 m, a million kilometres) are refused as
  absurd; float64 still resolves 0.1 um there, so every real site fits far inside.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from .errors import ConfigError

MAX_COORD_M = 1e9
ROTATION_TOL = 1e-6


def check_pose(pose: Any, where: str = "pose") -> np.ndarray:
    """``pose`` as a (4, 4) float64 world_from_camera, or a one-line ConfigError saying why not."""
    try:
        T = np.asarray(pose, dtype=np.float64)
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: expected a (4, 4) matrix of numbers, got {pose!r:.60}") from None
    if T.shape != (4, 4):
        raise ConfigError(f"{where}: expected a (4, 4) matrix, got shape {T.shape}")
    if not np.all(np.isfinite(T)):
        raise ConfigError(f"{where}: contains NaN or Inf")
    if np.abs(T[:3, 3]).max() > MAX_COORD_M:
        raise ConfigError(f"{where}: translation {T[:3, 3].tolist()} m is beyond {MAX_COORD_M:g} m")
    if not np.allclose(T[3], [0, 0, 0, 1], atol=1e-12):
        raise ConfigError(f"{where}: last row {T[3].tolist()}, expected [0, 0, 0, 1] (a rigid transform)")
    R = T[:3, :3]
    err = float(np.abs(R.T @ R - np.eye(3)).max())
    if err > ROTATION_TOL or np.linalg.det(R) < 0:
        raise ConfigError(f"{where}: not a rotation (|RᵀR - I| = {err:.3g}, det {np.linalg.det(R):.3g}); a camera pose "
                          "has no scale, shear or mirror")
    return T


def read_poses(path: str | Path) -> list[np.ndarray]:
    """Poses from a .npy (K, 4, 4) array or a JSON list of 4x4 matrices."""
    path = Path(path)
    try:
        data = np.load(path) if path.suffix == ".npy" else np.array(json.loads(path.read_text()), dtype=np.float64)
    except (OSError, ValueError) as exc:
        raise ConfigError(f"{path}: cannot read poses ({exc}); expected .npy (K, 4, 4) or JSON [[4x4], ...]") from None
    data = np.asarray(data, dtype=np.float64)
    if data.ndim != 3 or data.shape[1:] != (4, 4) or not np.isfinite(data).all():
        raise ConfigError(f"{path}: poses: expected K finite 4x4 matrices, got shape {data.shape}")
    return list(data)
