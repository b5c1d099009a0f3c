"""Stereo and structured-light shadowing: a point the second view cannot see returns nothing.

An active stereo camera (RealSense D400) matches its image against a second camera's; a
structured-light camera (Zivid, Photoneo, Kinect v1) against its projector's pattern. Either
way a surface point measures only when both views see it: beside every foreground edge lies
a strip of background that the second view cannot see (the "shadow"), and a band along one
image border lies outside the second view's field. The strip on a wall at z_w behind an
edge at z_b is b·(z_w − z_b)/z_b wide on the wall, f·b·(1/z_b − 1/z_w) pixels in the image.

Two methods (``method``; the ``accuracy:`` block's ``shadow``):

* ``render`` — every valid pixel's camera-frame point goes into the second view's frame, is
  projected there, and is compared with a low-resolution depth render of the scene from that
  view (``render_depth``, which ``simulate`` hands to effects with ``needs_render``). Any
  pair, any lens. The second view is rendered only when the frame has an edge that can hide
  something from it: two neighbouring returns whose depth gap exceeds the tolerance and whose
  shadow, f·b·(1/z_near − 1/z_far) pixels, reaches half a pixel. Without one, only the border
  band (pure geometry) is dropped.
* ``scanline`` — for a rectified pair (R = I, T along x: the D400's two imagers) and an
  undistorted pinhole sensor, a return at (u, v, z) appears in the second view in the same
  row at u + f·t_x/z, so each row of the second view is drawn from the row of the depth
  image itself (:func:`.kernels.scanline_shadow`, a one-dimensional depth buffer per row):
  no render: about 2 ms at 848 x 480 against 10-18 ms for the render method, its render
  included (``genie bench planning``, 2 shared cores). ``auto`` (the default) takes it
  wherever the pair allows it.

What differs: the scanline method knows only the surfaces the first view sees, as the
pixels sample them (a pixel covers half a pixel either side of its centre in the second
view where no neighbour continues its surface). A surface the first view cannot see but the
second can (the side of a post turned to the second imager, an object just outside the
first view on the baseline's side) hides nothing, and an edge is placed at the pixel
boundary rather than where the triangle ends, so the two methods can part by a pixel at an
edge. Measured on the generated assembly line (D435, 4 and 8 views, 407,040 returns each):
the scanline and a full-resolution render agree on 99.3-99.9 % of the returns; the
half-resolution render the render method uses by default agrees with the full-resolution one
on 98.4-99.85 % (``genie bench planning`` prints both; tests/effects/test_scanline_shadow.py:
analytic strip widths, a post narrower than its shadow, agreement on a cluttered scene).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..errors import ConfigError
from ..frame import Frame
from . import kernels
from ..sensors.camera import Sensor
from ..lens.distortion import distortion_maps
from .base import Effect, drop, drop_compiled, record
from .geometry import pixel_rays

METHODS = ("auto", "scanline", "render")
SCANLINE_MS_PER_MPX = 5.0  # the planner's estimate of the scanline method (cost_per_mpx)


@dataclass
class StereoShadow(Effect):
    """Drop the returns the second view (camera or projector) cannot see.

    Parameters
    ----------
    baseline_m : offset of the second view along ``axis``, used when the calibration has no
        stereo T. The calibration's R, T (``X2 = R·X1 + T``, as ``stereoCalibrate`` writes
        them; ``sensor.stereo.R``, ``.T``) take precedence; without either, a profile-level
        ``baseline_m`` (``sensor.stereo.baseline_m``) is used.
    axis : (3,) direction of the second view's centre in the camera frame (default +x: the
        right imager of a D400, the projector of a Zivid).
    scale : resolution of the second view's render relative to the sensor's (0.5: a quarter
        of the pixels). The second view has the sensor's field of view (for a distorted
        sensor, the pinhole field that covers it).
    tolerance_m, tolerance_rel : a point is hidden when it lies behind the rendered surface in
        the second view by more than tolerance_m + tolerance_rel·z (the render is sampled at
        the nearest pixel: the relative term absorbs the depth change across half a pixel of a
        slanted surface, up to about 75° incidence at scale 0.5).
    second_view : "needed" (default): the render method renders the second view only when
        the frame has an edge that can hide something from it; "always": on every frame (the
        same bytes; how it ran before that check, ``genie bench planning``'s "before").
    fused : True (default): the returns dropped in one compiled pass; False: the reference
        computation, the mask then :func:`~.effect.drop` (the same bytes, slower).
    """

    name: ClassVar[str] = "stereo_shadow"
    needs_render: ClassVar[bool] = True
    cost_ms_per_mpx: ClassVar[float] = 120.0
    accuracy_knobs: ClassVar[Mapping[str, str]] = {"shadow_scale": "scale", "shadow": "method"}
    baseline_m: float | None = None
    axis: tuple[float, float, float] = (1.0, 0.0, 0.0)
    scale: float = 0.5
    tolerance_m: float = 0.005
    tolerance_rel: float = 0.02
    method: str = "auto"
    second_view: str = "needed"
    fused: bool = True

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ConfigError(
                f"stereo_shadow.method: expected {' | '.join(METHODS)}, got {self.method!r}"
            )
        if self.second_view not in ("needed", "always"):
            raise ConfigError(
                f"stereo_shadow.second_view: expected needed | always, got {self.second_view!r}"
            )
        a = np.asarray(self.axis, dtype=np.float64)
        if a.shape != (3,) or not np.isfinite(a).all() or np.linalg.norm(a) == 0:
            raise ConfigError(
                f"stereo_shadow.axis: expected a non-zero 3-vector, got {self.axis!r}"
            )
        if not 0 < self.scale <= 4:
            raise ConfigError(f"stereo_shadow.scale: expected 0 < scale <= 4, got {self.scale}")
        if self.baseline_m is not None and not self.baseline_m > 0:
            raise ConfigError(f"stereo_shadow.baseline_m: expected > 0, got {self.baseline_m}")

    def second_from_first(self, sensor: Sensor) -> np.ndarray:
        """(4, 4) camera2_from_camera1: the calibration's [R | T], else a translation of the
        baseline along ``axis``."""
        stereo = getattr(sensor, "stereo", None)
        out = np.eye(4)
        if stereo is not None and stereo.T is not None:
            out[:3, :3] = stereo.R
            out[:3, 3] = stereo.T
            return out
        b = (
            self.baseline_m
            if self.baseline_m is not None
            else (None if stereo is None else stereo.baseline_m)
        )
        if b is None:
            raise ConfigError(
                f"stereo_shadow on sensor {sensor.name!r}: no baseline; give the effect "
                "baseline_m, or a calibration with a stereo T"
            )
        a = np.asarray(self.axis, dtype=np.float64)
        out[:3, 3] = -float(b) * a / np.linalg.norm(a)  # X2 = X1 − C2, C2 = b·axis
        return out

    def scanline_shift(self, sensor: Sensor) -> float | None:
        """fx·tx (pixel·metres) when the second view is the first one moved along its x axis
        only (R = I, T = (tx, 0, 0)) and the sensor is an undistorted pinhole without skew, so
        that a return at depth z appears in the same row, fx·tx/z pixels along; else None."""
        if not sensor.is_pinhole or sensor.K[0, 1] != 0:
            return None
        second = self.second_from_first(sensor)
        R, t = second[:3, :3], second[:3, 3]
        if np.abs(R - np.eye(3)).max() > 1e-12 or abs(t[1]) > 1e-12 or abs(t[2]) > 1e-12:
            return None
        return float(sensor.fx * t[0])

    def resolved_method(self, sensor: Sensor) -> str:
        """ "scanline" or "render": what ``method`` amounts to for ``sensor``."""
        if self.method == "render":
            return "render"
        if self.scanline_shift(sensor) is not None:
            return "scanline"
        if self.method == "scanline":
            raise ConfigError(
                f"stereo_shadow.method: scanline needs a rectified pair (R = I, T along x) "
                f"and an undistorted pinhole sensor; {sensor.name!r} is not one (use render)"
            )
        return "render"

    def cost_per_mpx(self, sensor: Sensor) -> float:
        """The render method's estimate, or the scanline's (measured at 848 x 480 on the
        llvmpipe host: about 1.6 ms for the pass and 0.3 ms for the drop)."""
        return (
            SCANLINE_MS_PER_MPX
            if self.resolved_method(sensor) == "scanline"
            else float(self.cost_ms_per_mpx)
        )

    def knob_unused(self, knob: str, sensor: Sensor) -> str | None:
        if knob == "shadow_scale" and self.resolved_method(sensor) == "scanline":
            return (
                f"{sensor.name}'s stereo shadow is drawn by scanline: no second view to scale "
                "(shadow: render)"
            )
        return None

    def view_sensor(self, sensor: Sensor) -> Sensor:
        """The pinhole camera of the second view's low-resolution render."""
        base = sensor
        if not sensor.is_pinhole:
            base = distortion_maps(sensor).render_sensor
        w = max(2, int(round(base.width * self.scale)))
        h = max(2, int(round(base.height * self.scale)))
        sx, sy = w / base.width, h / base.height
        K = base.K.copy()
        K[0, :] *= sx
        K[1, :] *= sy
        K[0, 2] = (base.cx + 0.5) * sx - 0.5  # pixel centres at integers at both sizes
        K[1, 2] = (base.cy + 0.5) * sy - 0.5
        return Sensor(
            w, h, K, near_m=base.near_m, far_m=base.far_m, name=f"{sensor.name}-second-view"
        )

    def casts_shadow(self, frame: Frame) -> bool:
        """True when some depth edge can hide a point from the second view (module docstring);
        always True with ``second_view="always"``."""
        if self.second_view == "always":
            return True
        b = float(np.linalg.norm(self.second_from_first(frame.sensor)[:3, 3]))
        fb = max(frame.sensor.fx, frame.sensor.fy) * b
        return bool(
            kernels.casts_shadow(
                frame.depth, fb, float(self.tolerance_m), float(self.tolerance_rel)
            )
        )

    def apply(self, frame: Frame, *, rng: np.random.Generator, render_depth=None, **needs) -> Frame:
        if self.resolved_method(frame.sensor) == "scanline":
            return self.apply_scanline(frame)
        if render_depth is None:
            raise ConfigError(
                "stereo_shadow needs a renderer: run it through simulate()/capture(), "
                "or pass render_depth=(sensor, pose) -> depth"
            )
        valid = frame.depth > 0
        if not valid.any():
            return frame
        second = self.second_from_first(frame.sensor)
        view = self.view_sensor(frame.sensor)
        rendered = self.casts_shadow(frame)
        depth2 = (
            render_depth(view, frame.world_from_camera @ np.linalg.inv(second))
            if rendered
            else np.zeros((1, 1), np.float32)
        )
        gone, occluded, outside = kernels.shadow_mask(
            frame.depth,
            pixel_rays(frame.sensor),
            np.ascontiguousarray(second[:3, :3]),
            np.ascontiguousarray(second[:3, 3]),
            view.K,
            view.width,
            view.height,
            float(view.near_m),
            depth2,
            rendered,
            float(self.tolerance_m),
            float(self.tolerance_rel),
        )
        out = self._drop(frame, gone) if occluded + outside else frame
        return record(
            out,
            self.name,
            occluded=int(occluded),
            outside=int(outside),
            second_view=rendered,
            method="render",
            changed=int(occluded + outside),
        )

    def _drop(self, frame: Frame, gone: np.ndarray) -> Frame:
        return drop_compiled(frame, gone) if self.fused else drop(frame, gone)

    def apply_scanline(self, frame: Frame) -> Frame:
        """The scanline method: the second view from the depth image (no render)."""
        gone, occluded, outside = kernels.scanline_shadow(
            frame.depth,
            float(self.scanline_shift(frame.sensor)),
            float(self.tolerance_m),
            float(self.tolerance_rel),
        )
        out = self._drop(frame, gone) if occluded + outside else frame
        return record(
            out,
            self.name,
            occluded=int(occluded),
            outside=int(outside),
            second_view=False,
            method="scanline",
            changed=int(occluded + outside),
        )
