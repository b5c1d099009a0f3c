"""Sensor effects: each maps an ideal ``Frame`` to a realistic one, only when asked for.

This module is the one place that lists the effects: :data:`EFFECTS` (name -> class). The
base class lives in :mod:`.effect`; the effects in their topic modules, which import only
the base (never this list). An effect is built from its profile parameters;
``apply(frame, *, rng)`` returns a new Frame. Noise draws come only from ``rng``; an effect not
in a sensor's list never runs and never draws. Two class flags ask ``simulate`` for more than
the ideal frame: ``needs_normals`` (the frame is rendered with ``Frame.normal``; the normals are
dropped again before the frame is returned) and ``needs_render`` (``apply`` also receives
``render_depth(sensor, pose) -> (H, W) float32``, a depth-only render of the scene from any
pose, e.g. the second view of a stereo pair at low resolution).

``range`` and ``depth_noise`` (noise.py, whose docstring lists the published noise models
offered by name with their sources).

More effects, one module per topic: ``stereo_shadow`` (shadow.py); ``lateral_noise``,
``incidence_dropout``, ``multipath`` (surface.py); ``flying_pixels``, ``edge_dropout``
(edges.py); ``calibration_error`` (miscalibration.py); ``tof_multipath``, ``mixed_pixels``,
``ambiguity``, ``low_albedo`` (tof.py, time-of-flight physics); ``specular_loss`` (specular.py,
active stereo and structured light on shiny and clear surfaces).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from ..errors import ConfigError, did_you_mean
from .edges import EdgeDropout, FlyingPixels
from .base import Decision, Effect, View, drop, record
from .miscalibration import CalibrationError
from .noise import DEFAULT_BASELINE_M, DEFAULT_SIGMA_D_PX, DepthNoise, RangeLimits
from .shadow import StereoShadow
from .specular import SpecularLoss
from .surface import IncidenceDropout, LateralNoise, Multipath
from .tof import Ambiguity, LowAlbedo, MixedPixels, TofMultipath

EFFECTS: dict[str, type[Effect]] = {
    cls.name: cls
    for cls in (
        RangeLimits,
        DepthNoise,
        StereoShadow,
        LateralNoise,
        IncidenceDropout,
        Multipath,
        FlyingPixels,
        EdgeDropout,
        CalibrationError,
        TofMultipath,
        MixedPixels,
        Ambiguity,
        LowAlbedo,
        SpecularLoss,
    )
}

__all__ = [
    "DEFAULT_BASELINE_M",
    "DEFAULT_SIGMA_D_PX",
    "EFFECTS",
    "Decision",
    "DepthNoise",
    "Effect",
    "RangeLimits",
    "View",
    "build_effects",
    "drop",
    "record",
]


def build_effects(specs: list[Any], where: str) -> tuple[Effect, ...]:
    """Effects from profile data: a list of ``{"type": name, ...params}``."""
    out = []
    if specs is not None and not isinstance(specs, (list, tuple)):
        raise ConfigError(
            f"{where}: effects: expected a list of effects ({{type: name, ...}}), got {specs!r:.60}"
        )
    seen: dict[str, int] = {}
    for i, spec in enumerate(specs or []):
        if not isinstance(spec, dict) or "type" not in spec:
            raise ConfigError(
                f"{where}: effects[{i}]: expected a mapping with a 'type', got {spec!r}"
            )
        if not isinstance(spec["type"], str):
            raise ConfigError(
                f"{where}: effects[{i}].type: expected an effect name, got {spec['type']!r:.40}"
            )
        if (
            spec["type"] in seen
        ):  # an effect runs once per frame: a second entry would apply it twice
            raise ConfigError(
                f"{where}: effects[{i}]: {spec['type']!r} is listed twice (also effects"
                f"[{seen[spec['type']]}]); give each effect once, with all its parameters"
            )
        seen[spec["type"]] = i
        params = {k: v for k, v in spec.items() if k not in ("type", "source")}
        cls = EFFECTS.get(spec["type"])
        if cls is None:
            raise ConfigError(
                f"{where}: effects[{i}].type: unknown effect {spec['type']!r}"
                f"{did_you_mean(spec['type'], EFFECTS)} (known: {', '.join(sorted(EFFECTS))})"
            )
        names = [f.name for f in dataclasses.fields(cls)]
        for (
            key
        ) in params:  # our own file: a key the effect does not take is a typo, refused by name
            if key not in names:
                raise ConfigError(
                    f"{where}: effects[{i}] ({spec['type']}).{key}: not a parameter of the "
                    f"{spec['type']!r} effect{did_you_mean(str(key), names)} (its parameters: "
                    f"{', '.join(names) or 'none'})"
                )
        for f in dataclasses.fields(cls):  # a number where the effect expects one, before it looks
            d, v = f.default, params.get(f.name)
            if (
                f.name in params
                and isinstance(d, (int, float))
                and not isinstance(d, bool)
                and (isinstance(v, bool) or not isinstance(v, (int, float)))
            ):
                raise ConfigError(
                    f"{where}: effects[{i}] ({spec['type']}).{f.name}: expected a number, got "
                    f"{v!r:.40}"
                )
        try:
            out.append(cls(**params))
        except TypeError as exc:
            raise ConfigError(f"{where}: effects[{i}] ({spec['type']}): {exc}") from None
        _check_numbers(out[-1], f"{where}: effects[{i}] ({spec['type']})")
    return tuple(out)


SIGNED = {"bias_m", "axis"}  # parameters that may be negative
# the largest value a parameter of each kind takes in any real sensor (past it is a typo, or an
# overflow waiting in a kernel: 1e300 px of disparity noise is metres beyond any frame), by
# the parameter's name: (suffix or name, ceiling, unit)
CEILINGS = (
    ("_deg", 90.0, "degrees"),
    ("_mhz", 1e4, "MHz"),
    ("_mm", 1e7, "mm"),
    ("_m", 1e5, "m"),
    ("_px", 1e4, "px"),
    ("_step", 10.0, "px"),
    ("_rel", 10.0, "(a share)"),
    ("probability", 1.0, ""),
    ("subpixel", 10.0, "px"),
    ("albedo", 1.0, ""),
    ("roughness", 1.0, ""),
)
ANY_CEILING = 1e6  # any other number (a count, a coefficient)


def _magnitude(name: str) -> bool:
    """A parameter that is a size, spread, share or angle by its name (so never negative)."""
    return name not in SIGNED and (
        "sigma" in name
        or "probability" in name
        or name in ("scale", "subpixel", "b")
        or name.endswith(("_m", "_px", "_mm", "_deg", "_rel", "_step"))
    )


def _check_numbers(e: Effect, where: str) -> None:
    """The checks every effect's numbers share: real numbers, not NaN; sizes, spreads, shares
    and angles (by name, :func:`_magnitude`) not negative; probabilities in [0, 1], angles in
    [0, 90] degrees, min <= max."""
    for f in dataclasses.fields(e):
        v = getattr(e, f.name)
        values = v if isinstance(v, (tuple, list)) else [v]
        d = f.default
        numeric = (isinstance(d, (int, float)) and not isinstance(d, bool)) or (
            isinstance(d, tuple) and all(isinstance(x, (int, float)) for x in d)
        )
        if (
            not numeric
            and not (d is None and isinstance(v, (int, float)))
            or v is None
            or isinstance(v, bool)
        ):
            continue  # a name, a mode or a flag: the effect checks its own
        for x in values:
            if isinstance(x, bool) or not isinstance(x, (int, float)) or math.isnan(x):
                raise ConfigError(f"{where}.{f.name}: expected a number, got {v!r:.40}")
            if x < 0 and _magnitude(f.name):
                raise ConfigError(f"{where}.{f.name}: expected a value >= 0, got {v!r}")
            if "probability" in f.name and x > 1:
                raise ConfigError(f"{where}.{f.name}: expected a probability in [0, 1], got {v!r}")
            if f.name.endswith("_deg") and x > 90:
                raise ConfigError(
                    f"{where}.{f.name}: expected an angle in [0, 90] degrees, got {v!r}"
                )
            if math.isinf(x) and d == math.inf:
                continue  # "no bound" where the default is no bound (the range's max_m)
            hi, unit = next(
                ((c, u) for key, c, u in CEILINGS if f.name.endswith(key) or f.name == key),
                (ANY_CEILING, ""),
            )
            if not abs(x) <= hi:
                raise ConfigError(
                    f"{where}.{f.name}: expected a value of at most {hi:g}"
                    f"{' ' + unit if unit else ''} "
                    f"(beyond any real sensor), got {v!r:.40}"
                )
    lo, hi = getattr(e, "min_m", None), getattr(e, "max_m", None)
    if lo is not None and hi is not None and lo > hi:
        raise ConfigError(f"{where}: min_m {lo} is above max_m {hi}; expected min_m <= max_m")
