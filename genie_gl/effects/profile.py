"""Sensor profiles: a YAML file beside an OpenCV calibration file, plus the effect list."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from ..validation.arguments import finite_number
from ..errors import ConfigError, did_you_mean
from ..resources import read_text, resolve
from ..sensors.accuracy import PROFILE_KEYS, from_dict
from ..sensors.calibration import Calibration, is_calibration, read_calibration
from ..sensors.camera import Sensor, Stereo
from .registry import build_effects


MAX_RANGE_M = 1e5  # the farthest range of any sensor a profile may describe


def calibration_fields(calib: Calibration) -> dict[str, Any]:
    """The :class:`Sensor` fields a calibration gives beside the camera: ``calibration`` (its
    path), ``stereo`` (its R, T) when it is a stereo calibration, ``reprojection_error_px``
    (OpenCV's RMS) when it has one."""
    out: dict[str, Any] = {"calibration": calib.source}
    if (
        calib.T is not None and calib.baseline_m > 0
    ):  # cameras at one place (a rig's zero offset) are no pair
        out["stereo"] = Stereo(calib.baseline_m, np.eye(3) if calib.R is None else calib.R, calib.T)
    if calib.reprojection_error is not None:
        out["reprojection_error_px"] = float(calib.reprojection_error)
    return out


def load_sensor(
    name_or_path: str | os.PathLike, *, near_m: float = 0.05, far_m: float = 1.0e4
) -> Sensor:
    """A sensor from a profile (``sensors/<name>.yaml`` or a path) or a bare calibration file."""
    path = resolve(name_or_path, "sensors", (".yaml",))
    try:
        return _load_sensor(path, near_m, far_m)
    except (
        ConfigError
    ) as exc:  # the file is named in every message (a camera's own check names the camera)
        if str(path) in str(exc) or Path(path).name in str(exc):
            raise
        raise ConfigError(f"{path}: {exc}") from None
    except (
        cv2.error,
        TypeError,
        ValueError,
        KeyError,
        IndexError,
        AttributeError,
        OverflowError,
    ) as exc:
        # a field of the wrong kind that no check above named: still one line naming the file
        why = str(exc).strip().splitlines()[-1][:160] if str(exc).strip() else type(exc).__name__
        raise ConfigError(
            f"{path}: not a usable sensor profile or OpenCV calibration ({why})"
        ) from None


def _load_sensor(path: Path, near_m: float, far_m: float) -> Sensor:
    text = read_text(path, "sensor profile or OpenCV calibration")
    if "opencv-matrix" in text or text.lstrip().startswith("<?xml"):
        calib = read_calibration(path)
        return Sensor(
            calib.width,
            calib.height,
            calib.K,
            calib.dist,
            near_m,
            far_m,
            name=Path(path).stem,
            model=calib.model,
            **calibration_fields(calib),
        )
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML ({exc})") from None
    if is_calibration(data):
        calib = read_calibration(path)  # a bare ROS camera_info, Kalibr camchain or vendor's file
        return Sensor(
            calib.width,
            calib.height,
            calib.K,
            calib.dist,
            near_m,
            far_m,
            name=Path(path).stem,
            model=calib.model,
            **calibration_fields(calib),
        )
    if not isinstance(data, dict) or "calibration" not in data:
        raise ConfigError(
            f"{path}: a sensor profile needs a 'calibration' field (an OpenCV calibration file)"
        )
    for key in data:
        if key not in PROFILE_KEYS:
            raise ConfigError(
                f"{path}: {key}: not a field of a sensor profile{did_you_mean(key, PROFILE_KEYS)} "
                f"(its fields: {', '.join(PROFILE_KEYS)})"
            )
    calib = read_calibration(Path(path).parent / data["calibration"], camera=data.get("camera"))
    effects = build_effects(data.get("effects") or [], str(path))
    # the sensor's range (minimum range: nearer surfaces give no return) may be the profile's
    # the sensor's range (a real sensor's: metres to kilometres) and a stereo baseline (cm to m)
    if "near_m" in data:
        near_m = finite_number(data["near_m"], f"{path}: near_m (m)", 0.0, 1e3, lo_open=True)
    if "far_m" in data:
        far_m = finite_number(data["far_m"], f"{path}: far_m (m)", 0.0, MAX_RANGE_M, lo_open=True)
    fields = calibration_fields(calib)
    if calib.T is None and data.get("baseline_m") is not None:
        fields["stereo"] = Stereo(
            finite_number(data["baseline_m"], f"{path}: baseline_m (m)", 0.0, 100.0, lo_open=True)
        )
    accuracy = None if data.get("accuracy") is None else from_dict(data["accuracy"], str(path))
    return Sensor(
        calib.width,
        calib.height,
        calib.K,
        calib.dist,
        near_m,
        far_m,
        effects,
        name=str(data.get("name", Path(path).stem)),
        model=calib.model,
        profile=str(path),
        accuracy=accuracy,
        **fields,
    )
