"""Range limits and axial depth noise from published models.

Published models offered by name (``depth_noise`` ``model:``):

* ``kinect_nguyen2012`` — Nguyen, Izadi & Lovell, "Modeling Kinect Sensor Noise for Improved
  3D Reconstruction and Tracking", 3DIMPVT 2012, axial noise (their eqs. for σ_z(z, θ)):
  σ_z = 0.0012 + 0.0019·(z − 0.4)² m for θ ≤ 60°, plus 0.0001/√z · θ²/(π/2 − θ)² m for
  θ > 60° (θ the incidence angle, from the surface normals; ``incidence: false`` drops the term);
* ``stereo`` — σ_z = z²·σ_d / (f·b) (RealSense D400 RMS model with σ_d = subpixel ≈ 0.08 px;
  Redwood/PrimeSense σ_d ≈ 1/36 px), plus quantisation of disparity to ``subpixel_step``.
  Without ``subpixel`` in the profile, σ_d comes from the calibration's RMS reprojection error
  (see :meth:`DepthNoise.sigma_d_px`); without ``baseline_m``, b comes from the calibration's
  stereo T;
* ``tof_linear`` — σ_z = a + b·max(z − z0, 0) (Azure Kinect evaluation: 0.5 mm + 1 mm/m
  beyond 0.5 m).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..errors import ConfigError
from ..frame import Frame
from . import kernels
from ..sensors.camera import Sensor
from .base import Decision, Effect, View, drop, record
from .geometry import incidence_angle, view_directions


@dataclass
class RangeLimits(Effect):
    """Returns outside [min_m, max_m] are dropped (depth 0, ids 0)."""

    name: ClassVar[str] = "range"
    cost_ms_per_mpx: ClassVar[float] = 4.0
    min_m: float = 0.0
    max_m: float = float("inf")

    def plan(self, view: View) -> Decision | None:
        if view.empty:
            return Decision(False, "nothing in range or view")
        if view.z_min >= self.min_m and view.z_max <= self.max_m:
            return Decision(
                False,
                f"everything in view lies at {view.z_min:.2f}-{view.z_max:.2f} m, "
                f"inside [{self.min_m}, {self.max_m}] m",
            )
        return None

    def check(self, frame: Frame, **needs: Any) -> str | None:
        lo, hi = kernels.valid_span(frame.depth)
        if hi == 0 or (lo >= self.min_m and hi <= self.max_m):
            return f"every return lies inside [{self.min_m}, {self.max_m}] m"
        return None

    def range_m(self) -> tuple[float, float] | None:
        return (float(self.min_m), float(self.max_m)) if np.isfinite(self.max_m) else None

    def reach_m(self, sensor: Any) -> float | None:
        return float(self.max_m)

    def apply(self, frame: Frame, *, rng: np.random.Generator) -> Frame:
        z = frame.depth
        return drop(frame, (z > 0) & ((z < self.min_m) | (z > self.max_m)))


DEFAULT_BASELINE_M = 0.05  # stereo model without a baseline in the profile or calibration
DEFAULT_SIGMA_D_PX = 0.08  # stereo model without σ_d in the profile or a calibration RMS


@dataclass
class DepthNoise(Effect):
    """Axial Gaussian depth noise from a published model; see the module docstring.

    Parameters
    ----------
    model : "kinect_nguyen2012", "stereo" or "tof_linear".
    baseline_m : stereo baseline b; None = the calibration's (``sensor.stereo.baseline_m``,
        from its stereo T), else 0.05.
    subpixel : σ_d in pixels (stereo); None = derived from the calibration, see
        :meth:`sigma_d_px`.
    subpixel_step : disparity quantisation step in pixels (0 = none).
    a_m, b, z0_m : tof_linear coefficients.
    incidence : kinect_nguyen2012 only: add Nguyen's θ > 60° term (needs normals; θ is
        clamped to 85°, where the term, 0.029/√z m, already dwarfs the rest).
    fused : stereo, tof_linear: draw inside the compiled pass (default); False: the reference
        computation, numpy's ``rng.standard_normal(n)`` before the pass: the same bytes, slower
        (``genie bench planning`` times both).
    """

    name: ClassVar[str] = "depth_noise"
    draws: ClassVar[bool] = True
    cost_ms_per_mpx: ClassVar[float] = 40.0
    model: str = "kinect_nguyen2012"
    baseline_m: float | None = None
    subpixel: float | None = None
    subpixel_step: float = 0.0
    a_m: float = 0.0005
    b: float = 0.001
    z0_m: float = 0.5
    incidence: bool = True
    fused: bool = True

    def __post_init__(self) -> None:
        if self.model not in ("kinect_nguyen2012", "stereo", "tof_linear"):
            raise ConfigError(
                f"depth_noise.model: unknown model {self.model!r}; expected "
                "kinect_nguyen2012, stereo or tof_linear"
            )

    def cost_per_mpx(self, sensor: Any) -> float:
        """The compiled models (stereo, tof_linear: ~2.6 ms at 848 x 480 in bench planning)
        cost a sixth of the numpy one's estimate."""
        return 6.5 if self.model in ("stereo", "tof_linear") else float(self.cost_ms_per_mpx)

    @property
    def needs_normals(self) -> bool:  # type: ignore[override]
        return self.model == "kinect_nguyen2012" and self.incidence

    def baseline(self, sensor: Sensor | None = None) -> float:
        """b in metres: the profile's, else the calibration's, else 0.05."""
        if self.baseline_m is not None:
            return float(self.baseline_m)
        stereo = getattr(sensor, "stereo", None)
        return DEFAULT_BASELINE_M if stereo is None else float(stereo.baseline_m)

    def sigma_d_px(self, sensor: Sensor | None = None) -> float:
        """σ_d, the disparity noise in pixels: ``subpixel`` when the profile sets it; else from
        the calibration's RMS reprojection error; else 0.08.

        OpenCV's RMS (``calibrateCamera`` / ``stereoCalibrate``, FORMATS.md §3.1) is the root
        mean square of the 2-D error vector, so one image coordinate has σ_x = rms/√2; the
        disparity d = x_left − x_right is the difference of two such coordinates, so
        σ_d = √2·σ_x = rms. (Were the RMS per coordinate, σ_d would be rms·√2.) This takes the
        calibration's corner noise as a proxy for matching noise: a floor, not a datasheet.
        """
        if self.subpixel is not None:
            return float(self.subpixel)
        rms = getattr(sensor, "reprojection_error_px", None)
        return DEFAULT_SIGMA_D_PX if rms is None else float(rms)

    def sigma(
        self,
        z: np.ndarray,
        f_px: float | None = None,
        theta: np.ndarray | None = None,
        sensor: Sensor | None = None,
    ) -> np.ndarray:
        """σ_z in metres at depths ``z`` (m) and incidence angles ``theta`` (rad, optional);
        ``f_px`` (the focal length in pixels) and ``sensor`` (its calibration) are read by the
        stereo model only."""
        if self.model == "kinect_nguyen2012":
            s = 0.0012 + 0.0019 * (z - 0.4) ** 2
            if self.incidence and theta is not None:
                t = np.minimum(theta, np.radians(85.0))  # past the measured range the term diverges
                steep = t > np.pi / 3
                extra = 0.0001 / np.sqrt(np.maximum(z, 1e-6)) * t**2 / (np.pi / 2 - t) ** 2
                s = s + np.where(steep, extra, 0.0)
            return s
        if self.model == "stereo":
            if f_px is None:
                raise ValueError(
                    "DepthNoise.sigma: the stereo model needs f_px, the focal length in pixels"
                )
            return z * z * self.sigma_d_px(sensor) / (f_px * self.baseline(sensor))
        return self.a_m + self.b * np.maximum(z - self.z0_m, 0.0)

    @staticmethod
    def steep_angles(frame: Frame, valid: np.ndarray) -> np.ndarray:
        """Incidence angles of the valid pixels (row-major), computed only where they can
        exceed 60° (the Nguyen term's threshold); 0 elsewhere, which gives the same σ."""
        if frame.normal is None:
            return incidence_angle(frame)[valid]
        n = frame.normal[valid].astype(np.float64)
        d = view_directions(frame.sensor)[valid]
        cos = -(n[:, 0] * d[:, 0] + n[:, 1] * d[:, 1] + n[:, 2] * d[:, 2])
        theta = np.zeros(len(cos))
        cand = (cos < 0.5 + 1e-9) & (n != 0).any(axis=1)  # θ > 60° only where cos θ < 1/2
        theta[cand] = np.arccos(np.clip(cos[cand], 0.0, 1.0))
        return theta

    def apply_reference(self, frame: Frame, *, rng: np.random.Generator) -> Frame:
        """The compiled models with their draws made first by numpy (``rng.standard_normal``,
        one per return, row-major): what the fused pass computes, draw for draw."""
        draws = rng.standard_normal(int(np.count_nonzero(frame.depth > 0)))
        if self.model == "stereo":
            depth, lost = kernels.stereo_noise(
                frame.depth,
                draws,
                frame.sensor.fx * self.baseline(frame.sensor),
                self.sigma_d_px(frame.sensor),
                float(self.subpixel_step),
            )
        else:
            depth, lost = kernels.linear_noise(
                frame.depth, draws, float(self.a_m), float(self.b), float(self.z0_m)
            )
        return self._noisy(frame, depth, lost, int(np.count_nonzero(depth != frame.depth)))

    def _noisy(self, frame: Frame, depth: np.ndarray, lost: int, changed: int) -> Frame:
        """``frame`` with the compiled pass's depth; the returns it lost dropped (ids 0); the
        pixels it changed recorded for ``simulate``."""
        out = frame.replace(depth=depth)
        out = drop(out, (frame.depth > 0) & (depth == 0)) if lost else out
        return record(out, self.name, changed=int(changed))

    def apply(self, frame: Frame, *, rng: np.random.Generator) -> Frame:
        if not self.fused and self.model in ("stereo", "tof_linear"):
            return self.apply_reference(frame, rng=rng)
        if self.model == "stereo":  # one compiled pass drawing from rng: the draws as below
            fb = frame.sensor.fx * self.baseline(frame.sensor)
            depth, lost, changed = kernels.stereo_noise_rng(
                frame.depth, rng, fb, self.sigma_d_px(frame.sensor), float(self.subpixel_step)
            )
            return self._noisy(frame, depth, lost, changed)
        if self.model == "tof_linear":
            depth, lost, changed = kernels.linear_noise_rng(
                frame.depth, rng, float(self.a_m), float(self.b), float(self.z0_m)
            )
            return self._noisy(frame, depth, lost, changed)
        z = frame.depth.astype(np.float64)  # kinect_nguyen2012: neither f nor the sensor enters σ
        valid = z > 0
        noisy = z.copy()
        zv = z[valid]
        theta = self.steep_angles(frame, valid) if self.needs_normals else None
        noisy[valid] = zv + rng.standard_normal(zv.size) * self.sigma(zv, theta=theta)
        bad = valid & ~(noisy > 0)
        out = frame.replace(depth=noisy.astype(np.float32))
        return drop(out, bad) if bad.any() else out
