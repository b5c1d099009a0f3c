"""The ``Sensor``: a camera model (:mod:`genie_gl.camera`: size, K, lens, range) plus its effects.

Conventions (DESIGN.md): OpenCV camera frame (x right, y down, z forward); pixel (u, v) has
its centre at integer coordinates, as ``cv2.projectPoints`` has it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..camera import PINHOLE_LENGTHS, Camera
from ..errors import ConfigError
from .accuracy import AccuracySettings
from .calibration import read_calibration

DIST_LENGTHS = PINHOLE_LENGTHS  # kept for older imports: the pinhole model's coefficient counts


@dataclass(frozen=True, eq=False)
class Stereo:
    """The second view of a stereo pair or of a structured-light projector.

    Attributes
    ----------
    baseline_m : float, distance between the two views' centres (m), > 0.
    R : (3, 3) float64 or None, rotation of ``X2 = R·X1 + T`` (as ``cv2.stereoCalibrate``
        writes it); None with ``T`` None: only the baseline is known.
    T : (3,) float64 or None, translation of the same (m).
    """

    baseline_m: float
    R: np.ndarray | None = None
    T: np.ndarray | None = None

    def __post_init__(self) -> None:
        if not (np.isfinite(self.baseline_m) and self.baseline_m > 0):
            raise ConfigError(
                f"stereo baseline_m: expected a number > 0 (metres), got {self.baseline_m!r}"
            )
        if self.T is not None:
            object.__setattr__(self, "T", np.array(self.T, dtype=np.float64).reshape(3))
            R = np.eye(3) if self.R is None else np.array(self.R, dtype=np.float64).reshape(3, 3)
            object.__setattr__(self, "R", R)
        elif self.R is not None:
            raise ConfigError("stereo: a rotation R needs its translation T")

    @classmethod
    def from_extrinsics(cls, R: Any, T: Any) -> "Stereo":
        """The pair of ``X2 = R·X1 + T`` (R None: identity); the baseline is ``|T|``."""
        T = np.array(T, dtype=np.float64).reshape(3)
        return cls(float(np.linalg.norm(T)), R, T)


@dataclass(frozen=True, eq=False)
class Sensor(Camera):
    """A virtual RGB-D camera: a :class:`genie_gl.camera.Camera` plus its effects.

    Attributes
    ----------
    width, height, K, dist, near_m, far_m, model : the camera (see :class:`Camera`); near_m is
        the minimum range (nearer surfaces give no return), far_m the maximum.
    effects : tuple, ordered effects applied to the ideal frame (empty = ideal sensor).
    name : str, profile name.
    stereo : Stereo or None, the second view (from the calibration's R, T, or a profile's
        ``baseline_m``); the stereo noise and shadow read it.
    accuracy : AccuracySettings or None, the profile's ``accuracy:`` block.
    calibration : str or None, the calibration file the camera was read from.
    profile : str or None, the profile file.
    reprojection_error_px : float or None, the calibration's RMS reprojection error.
    """

    effects: tuple = ()
    name: str = "ideal"
    stereo: Stereo | None = field(default=None, kw_only=True)
    accuracy: AccuracySettings | None = field(default=None, kw_only=True)
    calibration: str | None = field(default=None, kw_only=True)
    profile: str | None = field(default=None, kw_only=True)
    reprojection_error_px: float | None = field(default=None, kw_only=True)

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "effects", tuple(self.effects))

    @property
    def files(self) -> dict[str, str]:
        """The files the sensor was read from: ``profile`` and ``calibration``, those known."""
        return {
            k: v for k, v in (("profile", self.profile), ("calibration", self.calibration)) if v
        }

    @classmethod
    def pinhole(
        cls,
        width: int,
        height: int,
        fx: float,
        fy: float | None = None,
        cx: float | None = None,
        cy: float | None = None,
        **kw: Any,
    ) -> "Sensor":
        """An ideal pinhole sensor; cx, cy default to the image centre ((W-1)/2, (H-1)/2)."""
        fy = fx if fy is None else fy
        cx = (width - 1) / 2 if cx is None else cx
        cy = (height - 1) / 2 if cy is None else cy
        return cls(width, height, [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], **kw)

    @classmethod
    def from_camera(cls, camera: Camera, **kw: Any) -> "Sensor":
        """An ideal sensor (no effects) with ``camera``'s model; ``kw`` sets Sensor fields."""
        base = dict(
            width=camera.width,
            height=camera.height,
            K=camera.K,
            dist=camera.dist,
            near_m=camera.near_m,
            far_m=camera.far_m,
            model=camera.model,
        )
        base.update(kw)
        return cls(**base)

    @classmethod
    def from_opencv(cls, path: str | Path, *, camera: int | str | None = None) -> "Sensor":
        """An ideal sensor (no noise) with the lens model of a calibration file (OpenCV,
        ROS camera_info or Kalibr camchain; see :mod:`.calibration`); ``camera``: which
        camera of a file of several (an index, or a name such as ``cam1``)."""
        calib = read_calibration(path, camera=camera)
        return cls(
            calib.width, calib.height, calib.K, calib.dist, name=Path(path).stem, model=calib.model
        )
