"""The ``Sensor``: a camera model (image size, OpenCV K and distortion) plus its effects.

Conventions (DESIGN.md): OpenCV camera frame (x right, y down, z forward); pixel (u, v) has
its centre at integer coordinates, as ``cv2.projectPoints`` has it.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError

DIST_LENGTHS = (0, 4, 5, 8, 12, 14)


@dataclass(frozen=True, eq=False)
class Sensor:
    """A virtual RGB-D camera.

    Attributes
    ----------
    width, height : int, image size in pixels.
    K : (3, 3) float64, OpenCV camera matrix ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]``.
    dist : (N,) float64, OpenCV distortion coefficients, N in 0/4/5/8/12/14 (empty = pinhole).
    near_m, far_m : float, clip range of the renderer (not a sensor range limit).
    effects : tuple, ordered effects applied to the ideal frame (empty = ideal sensor).
    name : str, profile name.
    meta : dict, extra profile fields (baseline, sources, ...).
    """

    width: int
    height: int
    K: np.ndarray
    dist: np.ndarray = field(default_factory=lambda: np.zeros(0))
    near_m: float = 0.05
    far_m: float = 1.0e4
    effects: tuple = ()
    name: str = "ideal"
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        K = np.array(self.K, dtype=np.float64)
        if K.shape != (3, 3) or not np.all(np.isfinite(K)):
            raise ConfigError(f"sensor {self.name}: K must be a finite 3x3 matrix, got shape {K.shape}")
        if K[0, 0] <= 0 or K[1, 1] <= 0:
            raise ConfigError(f"sensor {self.name}: fx and fy must be > 0 (fx={K[0, 0]}, fy={K[1, 1]})")
        if not np.allclose(K[2], [0, 0, 1]) or K[1, 0] != 0:
            raise ConfigError(f"sensor {self.name}: K's last row must be [0, 0, 1] and K[1,0] = 0")
        if int(self.width) <= 0 or int(self.height) <= 0:
            raise ConfigError(f"sensor {self.name}: width and height must be > 0 ({self.width}x{self.height})")
        d = np.asarray(self.dist, dtype=np.float64).ravel()
        if len(d) not in DIST_LENGTHS or not np.all(np.isfinite(d)):
            raise ConfigError(
                f"sensor {self.name}: distortion must have 4, 5, 8, 12 or 14 finite coefficients, got {len(d)}"
            )
        if not 0 < self.near_m < self.far_m:
            raise ConfigError(f"sensor {self.name}: need 0 < near_m < far_m, got {self.near_m}, {self.far_m}")
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "dist", d)
        object.__setattr__(self, "width", int(self.width))
        object.__setattr__(self, "height", int(self.height))
        object.__setattr__(self, "effects", tuple(self.effects))

    @property
    def fx(self) -> float:
        return float(self.K[0, 0])

    @property
    def fy(self) -> float:
        return float(self.K[1, 1])

    @property
    def cx(self) -> float:
        return float(self.K[0, 2])

    @property
    def cy(self) -> float:
        return float(self.K[1, 2])

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in pixels."""
        return (self.width, self.height)

    @property
    def is_pinhole(self) -> bool:
        """True when the lens has no distortion."""
        return not np.any(self.dist)

    @classmethod
    def pinhole(cls, width: int, height: int, fx: float, fy: float | None = None,
                cx: float | None = None, cy: float | None = None, **kw: Any) -> "Sensor":
        """An ideal pinhole sensor; cx, cy default to the image centre ((W-1)/2, (H-1)/2)."""
        fy = fx if fy is None else fy
        cx = (width - 1) / 2 if cx is None else cx
        cy = (height - 1) / 2 if cy is None else cy
        return cls(width, height, np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1]], float), **kw)

    @classmethod
    def from_opencv(cls, path: str | Path) -> "Sensor":
        """An ideal sensor (no noise) with the lens model of an OpenCV calibration file."""
        from .calibration import read_calibration  # the calibration module owns the formats

        calib = read_calibration(path)
        return cls(calib.width, calib.height, calib.K, calib.dist, name=Path(path).stem)
