"""Scanner profiles: ``sensors/<name>.lidar.yml``, every figure with its source.

A profile (shipped ones found by bare name, a user's own by path)::

    name: my_head
    style: generic            # velodyne | ouster | generic: the driver's point fields
    elevation_deg: [-15, 1, -13, 3]      # per channel, in channel order
    azimuth_offset_deg: 0                # one number for all, or one per channel
    channel_time_us: [0, 2.304, 4.608, 6.912]   # per channel, non-decreasing
    firing_period_us: 55.296             # or columns: 1024 (firing period 1/(columns rate))
    rate_hz: 10
    rates_hz: [5, 10, 20]                # the rates a rig may choose (default: rate_hz alone)
    range_m: [0.9, 100]
    effects: [{type: range_noise, sigma_m: 0.015}]
    sources: {elevation_deg: "[V] the manual's table 9-1"}

Unknown fields are refused with a did-you-mean; a mistake is one line naming the file and
the field (NaN elevations, no channel, a rate of 0, a field of view over 360 degrees,
firing times out of order, ...). ``sources`` keys must be fields of the profile.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Literal

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..errors import ConfigError, did_you_mean
from ..resources import read_text, resolve
from .lidar import build_lidar_effects
from ..sensors.scanner import Scanner

SUFFIX = ".lidar.yml"


class _ScannerSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")

    name: str | None = None
    description: str = ""
    style: Literal["velodyne", "ouster", "generic"] = "generic"
    elevation_deg: list[float]
    azimuth_offset_deg: float | list[float] = 0.0
    channel_time_us: float | list[float] = 0.0
    firing_period_us: float | None = None
    columns: int | None = None
    rate_hz: float
    rates_hz: list[float] | None = None
    fov_deg: float = 360.0
    start_azimuth_deg: float = 0.0
    spin: Literal["clockwise", "counterclockwise"] = "clockwise"
    range_m: tuple[float, float]
    range_accuracy_m: float = 0.0
    range_resolution_m: float = 0.0
    returns: Literal["strongest", "last", "dual"] = "strongest"
    return_modes: list[Literal["strongest", "last", "dual"]] | None = None
    beam_divergence_mrad: float | None = None
    beam_origin_mm: float = 0.0
    wavelength_nm: float | None = None
    ring: Literal["elevation", "row"] = "elevation"
    effects: list[dict] | None = None
    sources: dict[str, str] = Field(default_factory=dict)


FIELDS = tuple(_ScannerSpec.model_fields)


def load_scanner(
    name_or_path: str | os.PathLike, *, rate_hz: float | None = None, returns: str | None = None
) -> Scanner:
    """A :class:`Scanner` from a profile (``sensors/<name>.lidar.yml`` or a path);
    ``rate_hz`` and ``returns`` choose among the profile's ``rates_hz`` and ``return_modes``."""
    path = resolve(name_or_path, "sensors", (SUFFIX,))
    try:
        data = yaml.safe_load(read_text(path, "scanner profile (YAML)"))
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML ({str(exc).splitlines()[0]})") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: a scanner profile is a mapping of fields ({', '.join(FIELDS)})")
    return scanner_from_dict(data, str(path), rate_hz=rate_hz, returns=returns)


def scanner_from_dict(
    data: dict, where: str, *, rate_hz: float | None = None, returns: str | None = None
) -> Scanner:
    """A :class:`Scanner` from a profile's fields (``where`` names it in messages)."""
    for key in data:
        if key not in FIELDS:
            raise ConfigError(
                f"{where}: {key}: not a field of a scanner profile{did_you_mean(str(key), FIELDS)} "
                f"(its fields: {', '.join(FIELDS)})"
            )
    try:
        spec = _ScannerSpec(**data)
    except ValidationError as exc:
        e = exc.errors()[0]
        loc = ".".join(str(p) for p in e["loc"]) or "?"
        raise ConfigError(f"{where}: {loc} {e.get('input')!r:.60}: {e['msg']}") from None
    for key in spec.sources:
        if key not in FIELDS:
            raise ConfigError(
                f"{where}: sources.{key}: not a field of the profile{did_you_mean(key, FIELDS)}"
            )
    n = len(spec.elevation_deg)
    for name in ("azimuth_offset_deg", "channel_time_us"):
        v = getattr(spec, name)
        if isinstance(v, list) and len(v) != n:
            raise ConfigError(
                f"{where}: {name}: expected one value per channel ({n}), got {len(v)}"
            )
    if any(not np.isfinite(x) for x in spec.elevation_deg):
        bad = next(k for k, x in enumerate(spec.elevation_deg) if not np.isfinite(x))
        raise ConfigError(
            f"{where}: elevation_deg[{bad}]: expected a finite angle in degrees, got "
            f"{spec.elevation_deg[bad]}"
        )
    rate = spec.rate_hz if rate_hz is None else float(rate_hz)
    allowed = spec.rates_hz or [spec.rate_hz]
    if not np.isfinite(rate) or rate <= 0:
        raise ConfigError(f"{where}: rate_hz: expected a rate > 0 (Hz), got {rate}")
    if rate_hz is not None and not any(abs(rate - r) < 1e-9 for r in allowed):
        raise ConfigError(
            f"{where}: rate_hz {rate:g}: not a rate of this scanner; expected one of "
            f"{', '.join(f'{r:g}' for r in allowed)}"
        )
    mode = spec.returns if returns is None else returns
    if returns is not None and mode not in (spec.return_modes or [spec.returns]):
        raise ConfigError(
            f"{where}: returns {mode!r}: not a mode of this scanner; expected one of "
            f"{', '.join(spec.return_modes or [spec.returns])}"
        )
    if (spec.firing_period_us is None) == (spec.columns is None):
        raise ConfigError(
            f"{where}: firing_period_us / columns: give exactly one (the time between firings, "
            "or the columns per revolution)"
        )
    if spec.columns is not None and spec.columns < 2:
        raise ConfigError(
            f"{where}: columns: expected at least 2 columns per revolution, got {spec.columns}"
        )
    if spec.firing_period_us is not None and not (
        np.isfinite(spec.firing_period_us) and spec.firing_period_us > 0
    ):
        raise ConfigError(
            f"{where}: firing_period_us: expected a time > 0 (us), got {spec.firing_period_us}"
        )
    period = spec.firing_period_us * 1e-6 if spec.columns is None else 1.0 / (spec.columns * rate)
    if not (np.isfinite(spec.fov_deg) and 0 < spec.fov_deg <= 360):
        raise ConfigError(
            f"{where}: fov_deg: expected a field of view in (0, 360] degrees, got {spec.fov_deg}"
        )
    div = spec.beam_divergence_mrad
    if div is not None and not (np.isfinite(div) and div >= 0):
        raise ConfigError(f"{where}: beam_divergence_mrad: expected a number >= 0, got {div}")
    effects = build_lidar_effects(spec.effects or [], where)
    return Scanner(
        name=spec.name or Path(where).name.removesuffix(SUFFIX),
        elevation_rad=np.radians(np.asarray(spec.elevation_deg, np.float64)),
        azimuth_offset_rad=np.radians(np.asarray(spec.azimuth_offset_deg, np.float64)),
        channel_time_s=np.asarray(spec.channel_time_us, np.float64) * 1e-6,
        firing_period_s=float(period),
        rate_hz=float(rate),
        min_range_m=float(spec.range_m[0]),
        max_range_m=float(spec.range_m[1]),
        fov_deg=float(spec.fov_deg),
        start_azimuth_rad=float(np.radians(spec.start_azimuth_deg)),
        spin=1 if spec.spin == "clockwise" else -1,
        returns=mode,
        beam_divergence_rad=None if div is None else div * 1e-3,
        beam_origin_m=spec.beam_origin_mm * 1e-3,
        ring_order=spec.ring,
        style=spec.style,
        range_accuracy_m=spec.range_accuracy_m,
        range_resolution_m=spec.range_resolution_m,
        effects=effects,
        sources=dict(spec.sources),
        profile=where,
    )
