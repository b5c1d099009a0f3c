"""The ``Sensor``: a camera model (:mod:`genie_gl.camera`: size, K, lens, range) plus its effects.

Conventions (DESIGN.md): OpenCV camera frame (x right, y down, z forward); pixel (u, v) has
its centre at integer coordinates, as ``cv2.projectPoints`` has it.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..camera import PINHOLE_LENGTHS, Camera
from .calibration import read_calibration

DIST_LENGTHS = PINHOLE_LENGTHS  # kept for older imports: the pinhole model's coefficient counts


@dataclass(frozen=True, eq=False)
class Sensor(Camera):
    """A virtual RGB-D camera: a :class:`genie_gl.camera.Camera` plus its effects.

    Attributes
    ----------
    width, height, K, dist, near_m, far_m, model : the camera (see :class:`Camera`); near_m is
        the minimum range (nearer surfaces give no return), far_m the maximum.
    effects : tuple, ordered effects applied to the ideal frame (empty = ideal sensor).
    name : str, profile name.
    meta : dict, extra profile fields (baseline, sources, ...).
    """

    effects: tuple = ()
    name: str = "ideal"
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "effects", tuple(self.effects))

    @classmethod
    def pinhole(cls, width: int, height: int, fx: float, fy: float | None = None,
                cx: float | None = None, cy: float | None = None, **kw: Any) -> "Sensor":
        """An ideal pinhole sensor; cx, cy default to the image centre ((W-1)/2, (H-1)/2)."""
        fy = fx if fy is None else fy
        cx = (width - 1) / 2 if cx is None else cx
        cy = (height - 1) / 2 if cy is None else cy
        return cls(width, height, [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], **kw)

    @classmethod
    def from_camera(cls, camera: Camera, **kw: Any) -> "Sensor":
        """An ideal sensor (no effects) with ``camera``'s model; ``kw`` sets Sensor fields."""
        base = dict(width=camera.width, height=camera.height, K=camera.K, dist=camera.dist,
                    near_m=camera.near_m, far_m=camera.far_m, model=camera.model)
        base.update(kw)
        return cls(**base)

    @classmethod
    def from_opencv(cls, path: str | Path) -> "Sensor":
        """An ideal sensor (no noise) with the lens model of a calibration file (OpenCV,
        ROS camera_info or Kalibr camchain; see :mod:`.calibration`)."""
        calib = read_calibration(path)
        return cls(calib.width, calib.height, calib.K, calib.dist, name=Path(path).stem, model=calib.model)
