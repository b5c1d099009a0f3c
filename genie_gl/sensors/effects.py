"""Sensor effects: each maps an ideal ``Frame`` to a realistic one, only when asked for.

An effect is a class in :data:`EFFECTS` (name -> class) built from its profile parameters;
``apply(frame, rng)`` returns a new Frame. Noise draws come only from ``rng``; an effect not
in a sensor's list never runs and never draws. Two class flags ask ``simulate`` for more than
the ideal frame: ``needs_normals`` (the frame is rendered with ``Frame.normal``; the normals are
dropped again before the frame is returned) and ``needs_render`` (``apply`` also receives
``render_depth(sensor, pose) -> (H, W) float32``, a depth-only render of the scene from any
pose, e.g. the second view of a stereo pair at low resolution).

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

More effects, one module per topic, registered here too: ``stereo_shadow`` (shadow.py);
``lateral_noise``, ``incidence_dropout``, ``multipath`` (surface.py); ``flying_pixels``,
``edge_dropout`` (edges.py); ``calibration_error`` (miscalibration.py).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..errors import ConfigError, did_you_mean
from ..frame import Frame
from .camera import Sensor
from .geometry import incidence_angle


class Effect:
    """Base class: ``apply(frame, rng)`` returns the frame the sensor would report."""

    name: ClassVar[str] = ""
    draws: ClassVar[bool] = False          # True when apply() uses the RNG
    needs_normals: ClassVar[bool] = False  # simulate renders Frame.normal for it
    needs_render: ClassVar[bool] = False   # apply() also takes render_depth= (see module doc)

    def apply(self, frame: Frame, rng: np.random.Generator) -> Frame:
        raise NotImplementedError


EFFECTS: dict[str, type[Effect]] = {}


def effect(cls: type[Effect]) -> type[Effect]:
    EFFECTS[cls.name] = cls
    return cls


def record(frame: Frame, name: str, **values: Any) -> Frame:
    """A copy of ``frame`` whose ``meta[name]`` holds ``values`` (what an effect drew or did)."""
    return frame.replace(meta={**(frame.meta or {}), name: values})


def drop(frame: Frame, mask: np.ndarray, depth: np.ndarray | None = None) -> Frame:
    """``frame`` with no return where ``mask``: depth 0, ids 0 (and normal 0); ``depth``, when
    given, replaces the frame's depth first."""
    d = (frame.depth if depth is None else depth).copy()
    d[mask] = 0
    inst, sem = frame.instance.copy(), frame.semantic.copy()
    inst[mask], sem[mask] = 0, 0
    normal = frame.normal
    if normal is not None and mask.any():
        normal = normal.copy()
        normal[mask] = 0
    return frame.replace(depth=d.astype(np.float32), instance=inst, semantic=sem, normal=normal)


@effect
@dataclass
class RangeLimits(Effect):
    """Returns outside [min_m, max_m] are dropped (depth 0, ids 0)."""

    name: ClassVar[str] = "range"
    min_m: float = 0.0
    max_m: float = float("inf")

    def apply(self, frame: Frame, rng: np.random.Generator) -> Frame:
        z = frame.depth
        return drop(frame, (z > 0) & ((z < self.min_m) | (z > self.max_m)))


DEFAULT_BASELINE_M = 0.05   # stereo model without a baseline in the profile or calibration
DEFAULT_SIGMA_D_PX = 0.08   # stereo model without σ_d in the profile or a calibration RMS


@effect
@dataclass
class DepthNoise(Effect):
    """Axial Gaussian depth noise from a published model; see the module docstring.

    Parameters
    ----------
    model : "kinect_nguyen2012", "stereo" or "tof_linear".
    baseline_m : stereo baseline b; None = the calibration's (``sensor.meta["baseline_m"]``,
        from its stereo T), else 0.05.
    subpixel : σ_d in pixels (stereo); None = derived from the calibration, see
        :meth:`sigma_d_px`.
    subpixel_step : disparity quantisation step in pixels (0 = none).
    a_m, b, z0_m : tof_linear coefficients.
    incidence : kinect_nguyen2012 only: add Nguyen's θ > 60° term (needs normals; θ is
        clamped to 85°, where the term, 0.029/√z m, already dwarfs the rest).
    """

    name: ClassVar[str] = "depth_noise"
    draws: ClassVar[bool] = True
    model: str = "kinect_nguyen2012"
    baseline_m: float | None = None
    subpixel: float | None = None
    subpixel_step: float = 0.0
    a_m: float = 0.0005
    b: float = 0.001
    z0_m: float = 0.5
    incidence: bool = True

    def __post_init__(self) -> None:
        if self.model not in ("kinect_nguyen2012", "stereo", "tof_linear"):
            raise ConfigError(f"depth_noise.model: unknown model {self.model!r}; expected "
                              "kinect_nguyen2012, stereo or tof_linear")

    @property
    def needs_normals(self) -> bool:  # type: ignore[override]
        return self.model == "kinect_nguyen2012" and self.incidence

    def baseline(self, sensor: Sensor | None = None) -> float:
        """b in metres: the profile's, else the calibration's, else 0.05."""
        if self.baseline_m is not None:
            return float(self.baseline_m)
        meta = sensor.meta if sensor is not None else {}
        return float(meta.get("baseline_m", DEFAULT_BASELINE_M))

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
        rms = (sensor.meta if sensor is not None else {}).get("reprojection_error_px")
        return DEFAULT_SIGMA_D_PX if rms is None else float(rms)

    def sigma(self, z: np.ndarray, f_px: float, theta: np.ndarray | None = None,
              sensor: Sensor | None = None) -> np.ndarray:
        """σ_z in metres at depths ``z`` (m) and incidence angles ``theta`` (rad, optional)."""
        if self.model == "kinect_nguyen2012":
            s = 0.0012 + 0.0019 * (z - 0.4) ** 2
            if self.incidence and theta is not None:
                t = np.minimum(theta, np.radians(85.0))  # past the measured range the term diverges
                steep = t > np.pi / 3
                extra = 0.0001 / np.sqrt(np.maximum(z, 1e-6)) * t ** 2 / (np.pi / 2 - t) ** 2
                s = s + np.where(steep, extra, 0.0)
            return s
        if self.model == "stereo":
            return z * z * self.sigma_d_px(sensor) / (f_px * self.baseline(sensor))
        return self.a_m + self.b * np.maximum(z - self.z0_m, 0.0)

    def apply(self, frame: Frame, rng: np.random.Generator) -> Frame:
        z = frame.depth.astype(np.float64)
        valid = z > 0
        f = frame.sensor.fx
        noisy = z.copy()
        zv = z[valid]
        theta = incidence_angle(frame)[valid] if self.needs_normals else None
        noisy[valid] = zv + rng.standard_normal(zv.size) * self.sigma(zv, f, theta, frame.sensor)
        if self.model == "stereo" and self.subpixel_step > 0:
            fb = f * self.baseline(frame.sensor)
            disp = fb / np.maximum(noisy[valid], 1e-6)
            disp = np.round(disp / self.subpixel_step) * self.subpixel_step
            noisy[valid] = np.where(disp > 0, fb / np.maximum(disp, 1e-12), 0.0)
        bad = valid & ~(noisy > 0)
        out = frame.replace(depth=noisy.astype(np.float32))
        return drop(out, bad) if bad.any() else out


def build_effects(specs: list[Any], where: str) -> tuple[Effect, ...]:
    """Effects from profile data: a list of ``{"type": name, ...params}``."""
    out = []
    for i, spec in enumerate(specs or []):
        if not isinstance(spec, dict) or "type" not in spec:
            raise ConfigError(f"{where}: effects[{i}]: expected a mapping with a 'type', got {spec!r}")
        params = {k: v for k, v in spec.items() if k not in ("type", "source")}
        cls = EFFECTS.get(spec["type"])
        if cls is None:
            raise ConfigError(f"{where}: effects[{i}].type: unknown effect {spec['type']!r}"
                              f"{did_you_mean(spec['type'], EFFECTS)} (known: {', '.join(sorted(EFFECTS))})")
        import dataclasses

        for f in dataclasses.fields(cls):  # a number where the effect expects one, before it looks
            d, v = f.default, params.get(f.name)
            if f.name in params and isinstance(d, (int, float)) and not isinstance(d, bool) and \
                    (isinstance(v, bool) or not isinstance(v, (int, float))):
                raise ConfigError(f"{where}: effects[{i}] ({spec['type']}).{f.name}: expected a number, got {v!r:.40}")
        try:
            out.append(cls(**params))
        except TypeError as exc:
            raise ConfigError(f"{where}: effects[{i}] ({spec['type']}): {exc}") from None
        _check_numbers(out[-1], f"{where}: effects[{i}] ({spec['type']})")
    return tuple(out)


SIGNED = {"bias_m", "axis"}  # parameters that may be negative


def _magnitude(name: str) -> bool:
    """A parameter that is a size, spread, share or angle by its name (so never negative)."""
    return name not in SIGNED and ("sigma" in name or "probability" in name or name in ("scale", "subpixel", "b")
                                   or name.endswith(("_m", "_px", "_mm", "_deg", "_rel", "_step")))


def _check_numbers(e: Effect, where: str) -> None:
    """The checks every effect's numbers share: real numbers, not NaN; sizes, spreads, shares
    and angles (by name, :func:`_magnitude`) not negative; probabilities in [0, 1], angles in
    [0, 90] degrees, min <= max."""
    import dataclasses
    import math

    for f in dataclasses.fields(e):
        v = getattr(e, f.name)
        values = v if isinstance(v, (tuple, list)) else [v]
        if f.name in ("model",) or v is None or isinstance(v, bool):
            continue
        for x in values:
            if isinstance(x, bool) or not isinstance(x, (int, float)) or math.isnan(x):
                raise ConfigError(f"{where}.{f.name}: expected a number, got {v!r:.40}")
            if x < 0 and _magnitude(f.name):
                raise ConfigError(f"{where}.{f.name}: expected a value >= 0, got {v!r}")
            if "probability" in f.name and x > 1:
                raise ConfigError(f"{where}.{f.name}: expected a probability in [0, 1], got {v!r}")
            if f.name.endswith("_deg") and x > 90:
                raise ConfigError(f"{where}.{f.name}: expected an angle in [0, 90] degrees, got {v!r}")
    lo, hi = getattr(e, "min_m", None), getattr(e, "max_m", None)
    if lo is not None and hi is not None and lo > hi:
        raise ConfigError(f"{where}: min_m {lo} is above max_m {hi}; expected min_m <= max_m")


# effects defined in their own topic modules register themselves on import
from . import edges, miscalibration, shadow, surface  # noqa: E402,F401
