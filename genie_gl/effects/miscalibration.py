"""Calibration error: the camera's true intrinsics differ from the calibrated ones.

A calibration estimates K with some uncertainty (``cv2.calibrateCameraExtended`` reports it
as ``stdDeviationsIntrinsics``). The physical camera forms its image with its true K', but
everyone downstream (the dataset's calibration file, ``to_cloud``) unprojects with the
calibrated K. So the effect re-samples the frame into the image the true camera would have
made — pixel (u, v) of the true camera looks along the ray K'⁻¹(u, v, 1), which the ideal
render (made with K) holds at K·K'⁻¹(u, v, 1) — and keeps ``frame.sensor`` (K). Unprojecting
the result puts every point on the wrong ray, as a miscalibrated camera does: a lateral error
of z·Δx, with Δx the difference of normalised coordinates. (Swapping ``frame.sensor`` for a
perturbed one instead would model the opposite case, an exact camera with a wrong file, and
would change the very K the dataset reports.)

The depth of a pixel is the z of the point on its true ray, so it needs no correction; the
lens distortion is taken to be known exactly. The re-sampling is sub-pixel: depth along each
true ray recomputed from the plane of the surface it hits when the frame has normals, else
interpolated between same-instance neighbours (:mod:`.distortion`), so a shift of a fraction
of a pixel changes the depth image; ids are never blended.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from ..errors import ConfigError
from ..frame import Frame
from ..sensors.camera import Sensor
from ..lens.distortion import DistortionMaps, distort
from .base import Decision, Effect, View, record


@dataclass
class CalibrationError(Effect):
    """Per-camera intrinsics drawn around the calibrated ones: fx' = fx + N(0, σ_f²),
    fy' = fy + N(0, σ_f²), cx' = cx + N(0, σ_c²), cy' = cy + N(0, σ_c²) (pixels; one draw per
    frame, i.e. per camera of a capture), applied as a nearest-neighbour re-sampling. Pixels
    whose true ray falls outside the rendered image get no return.
    """

    name: ClassVar[str] = "calibration_error"
    draws: ClassVar[bool] = True
    needs_normals: ClassVar[bool] = True  # the exact resampling: depth from each surface's plane
    cost_ms_per_mpx: ClassVar[float] = 60.0
    sigma_f_px: float = 1.0
    sigma_c_px: float = 0.5

    def __post_init__(self) -> None:
        if self.sigma_f_px < 0 or self.sigma_c_px < 0:
            raise ConfigError(
                f"calibration_error: sigmas must be >= 0, got sigma_f_px={self.sigma_f_px}, "
                f"sigma_c_px={self.sigma_c_px}"
            )

    def plan(self, view: View) -> Decision | None:
        if self.sigma_f_px == 0 and self.sigma_c_px == 0:
            return Decision(False, "sigma_f_px = sigma_c_px = 0: the true K is the calibrated one")
        if view.empty:
            return Decision(False, "nothing in range or view")
        return Decision(
            True, "the camera's true K differs from the calibrated one: every ray moves"
        )

    def skip(self, frame: Frame, rng: np.random.Generator) -> None:
        rng.standard_normal(4)  # a run's one draw per frame

    def true_K(self, sensor: Sensor, rng: np.random.Generator) -> np.ndarray:
        """(3, 3) float64: the camera's true K, drawn (four standard normals, fx fy cx cy)."""
        d = rng.standard_normal(4) * [
            self.sigma_f_px,
            self.sigma_f_px,
            self.sigma_c_px,
            self.sigma_c_px,
        ]
        K = sensor.K.copy()
        K[0, 0] += d[0]
        K[1, 1] += d[1]
        K[0, 2] += d[2]
        K[1, 2] += d[3]
        if K[0, 0] <= 0 or K[1, 1] <= 0:
            raise ConfigError(
                f"calibration_error: sigma_f_px={self.sigma_f_px} drew a focal length <= 0"
            )
        return K

    def maps(self, sensor: Sensor, K_true: np.ndarray) -> DistortionMaps:
        """Where each pixel of the true camera samples the frame rendered with ``sensor.K``."""
        W, H = sensor.width, sensor.height
        u, v = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
        true = replace(sensor, K=K_true)  # the same lens with the true intrinsics
        d = true.unproject(np.stack([u.ravel(), v.ravel()], 1))
        uv = sensor.project(d)  # where the calibrated render holds that ray
        mx, my = uv[:, 0].reshape(H, W), uv[:, 1].reshape(H, W)
        with np.errstate(invalid="ignore"):
            valid = (
                np.isfinite(mx)
                & np.isfinite(my)
                & (mx > -0.5)
                & (mx < W - 0.5)
                & (my > -0.5)
                & (my < H - 0.5)
            )
            rx, ry = (d[:, 0] / d[:, 2]).reshape(H, W), (d[:, 1] / d[:, 2]).reshape(H, W)
        mx, my = np.where(valid, mx, -1), np.where(valid, my, -1)
        return DistortionMaps(
            sensor,
            mx.astype(np.float32),
            my.astype(np.float32),
            valid,
            None,
            np.where(valid, rx, 0.0),
            np.where(valid, ry, 0.0),
            None,
        )

    def apply(self, frame: Frame, *, rng: np.random.Generator) -> Frame:
        K_true = self.true_K(frame.sensor, rng)
        mode = "plane" if frame.normal is not None else "bilinear"
        out = distort(frame, frame.sensor, self.maps(frame.sensor, K_true), resample=mode)
        return record(out, self.name, K_true=K_true.tolist())
