"""Sensor effects: each maps an ideal ``Frame`` to a realistic one, only when asked for.

This module is the one place that lists the effects: :data:`EFFECTS` (name -> class). The
base class lives in :mod:`.effect`; the effects in their topic modules, which import only
the base (never this list). An effect is built from its profile parameters;
``apply(frame, rng)`` returns a new Frame. Noise draws come only from ``rng``; an effect not
in a sensor's list never runs and never draws. Two class flags ask ``simulate`` for more than
the ideal frame: ``needs_normals`` (the frame is rendered with ``Frame.normal``; the normals are
dropped again before the frame is returned) and ``needs_render`` (``apply`` also receives
``render_depth(sensor, pose) -> (H, W) float32``, a depth-only render of the scene from any
pose, e.g. the second view of a stereo pair at low resolution).

``range`` and ``depth_noise`` (noise.py) — the published noise models offered by name
(``depth_noise`` ``model:``):

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

More effects, one module per topic: ``stereo_shadow`` (shadow.py); ``lateral_noise``,
``incidence_dropout``, ``multipath`` (surface.py); ``flying_pixels``, ``edge_dropout``
(edges.py); ``calibration_error`` (miscalibration.py); ``tof_multipath``, ``mixed_pixels``,
``ambiguity``, ``low_albedo`` (tof.py, time-of-flight physics); ``specular_loss`` (specular.py,
active stereo and structured light on shiny and clear surfaces).
"""
from __future__ import annotations

from typing import Any

from ..errors import ConfigError, did_you_mean
from .edges import EdgeDropout, FlyingPixels
from .effect import Decision, Effect, View, drop, record
from .miscalibration import CalibrationError
from .noise import DEFAULT_BASELINE_M, DEFAULT_SIGMA_D_PX, DepthNoise, RangeLimits
from .shadow import StereoShadow
from .specular import SpecularLoss
from .surface import IncidenceDropout, LateralNoise, Multipath
from .tof import Ambiguity, LowAlbedo, MixedPixels, TofMultipath

EFFECTS: dict[str, type[Effect]] = {cls.name: cls for cls in (
    RangeLimits, DepthNoise, StereoShadow, LateralNoise, IncidenceDropout, Multipath, FlyingPixels,
    EdgeDropout, CalibrationError, TofMultipath, MixedPixels, Ambiguity, LowAlbedo, SpecularLoss,
)}

__all__ = ["DEFAULT_BASELINE_M", "DEFAULT_SIGMA_D_PX", "EFFECTS", "Decision", "DepthNoise", "Effect",
           "RangeLimits", "View", "build_effects", "drop", "record"]


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
        try:
            out.append(cls(**params))
        except TypeError as exc:
            raise ConfigError(f"{where}: effects[{i}] ({spec['type']}): {exc}") from None
    return tuple(out)
