"""A user's own captures of a wall, measured like the simulated card's walls.

The input is what any depth camera's tools can save:

* a folder of depth images, one per frame: single-channel 16-bit PNG, ``depth_scale`` metres
  per unit (0.001 for millimetres, what RealSense and Azure Kinect tools write), 0 = no
  return; read in file-name order; at least 2 (the temporal metrics need several);
* the camera's intrinsics: an OpenCV calibration file (``calibrateCamera`` YAML/XML, ROS
  ``camera_info`` or Kalibr; see :mod:`genie_gl.sensors.calibration`) of the same image size,
  whose lens undistorts each pixel's ray (a stereo calibration's T also gives the baseline
  for the sub-pixel RMS);
* the distance from the camera to the wall along its optical axis, in metres, with the camera
  facing the wall squarely (the ground truth of Z accuracy and of the systematic error).

``tools/record_captures.py`` records such a folder with a RealSense camera.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from ..camera import Camera
from ..errors import ConfigError
from ..sensors.calibration import read_calibration
from .measurements import wall_measurements
from .metrics import central_roi

PATTERNS = ("*.png", "*.PNG")


@dataclass(frozen=True, eq=False)
class Captures:
    """Depth frames of a flat wall facing the camera.

    Attributes
    ----------
    depth : (N, H, W) float32, metres (0 = no return), N >= 2.
    camera : the calibration's :class:`~genie_gl.Camera` (size, K, lens).
    distance_m : the wall's distance on the optical axis, m.
    baseline_m : stereo baseline from the calibration's T, m (None without one).
    source : the folder the frames came from.
    """

    depth: np.ndarray
    camera: Camera
    distance_m: float
    baseline_m: float | None
    source: str


def _read_png(path: Path, scale: float) -> np.ndarray:
    try:
        with Image.open(path) as im:
            a = np.array(im)
    except OSError as exc:
        raise ConfigError(f"{path}: not a readable PNG ({exc})") from None
    if a.ndim != 2 or a.dtype != np.uint16:
        raise ConfigError(
            f"{path}: expected a single-channel 16-bit depth PNG, got {a.dtype} with shape "
            f"{a.shape}"
        )
    return (a.astype(np.float64) * scale).astype(np.float32)


def load_captures(
    folder: str | os.PathLike,
    calibration: str | os.PathLike,
    distance_m: float,
    *,
    depth_scale: float = 0.001,
) -> Captures:
    """Read a folder of depth PNGs and the calibration beside them (see the module docstring);
    every problem is one :class:`~genie_gl.errors.ConfigError` naming the file."""

    d = Path(folder)
    if not d.is_dir():
        raise ConfigError(f"{folder}: not a folder of depth PNGs")
    if not (np.isfinite(distance_m) and distance_m > 0):
        raise ConfigError(
            f"--wall-distance: expected the wall's distance in metres (> 0), got {distance_m}"
        )
    if not (np.isfinite(depth_scale) and depth_scale > 0):
        raise ConfigError(f"--depth-scale: expected metres per depth unit (> 0), got {depth_scale}")
    files = sorted({p for pat in PATTERNS for p in d.glob(pat)})
    if len(files) < 2:
        raise ConfigError(
            f"{folder}: found {len(files)} depth PNG(s); the temporal metrics need at least 2 "
            "frames"
        )
    calib = read_calibration(calibration)
    cam = Camera(calib.width, calib.height, calib.K, calib.dist, model=calib.model)
    frames = []
    for f in files:
        z = _read_png(f, float(depth_scale))
        if z.shape != (calib.height, calib.width):
            raise ConfigError(
                f"{f}: image is {z.shape[1]}x{z.shape[0]}, the calibration {calibration} is "
                f"{calib.width}x{calib.height}; expected the same size"
            )
        frames.append(z)
    stack = np.stack(frames)
    if not (stack > 0).any():
        raise ConfigError(
            f"{folder}: every depth pixel of every frame is 0 (no return); nothing to measure"
        )
    return Captures(stack, cam, float(distance_m), calib.baseline_m, str(d))


def measure_captures(captures: Captures, *, roi_fraction: float) -> list:
    """The card's wall metrics (:func:`genie_gl.card.measurements.wall_measurements`) of the
    captures, at their wall distance and incidence 0."""

    cam = captures.camera
    rays = np.asarray(cam.rays(), np.float64)
    roi = central_roi(cam.width, cam.height, roi_fraction)
    return wall_measurements(
        captures.depth,
        rays,
        roi,
        distance_m=captures.distance_m,
        angle_deg=0.0,
        focal_px=float(cam.fx),
        truth_m=captures.distance_m,
        baseline_m=captures.baseline_m,
    )
