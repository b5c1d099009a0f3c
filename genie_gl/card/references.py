"""Published reference figures of a sensor: ``sensors/<name>.reference.yml`` beside its profile.

A reference file names its sources (authors or maker, title, venue, year, where in it) and
lists figures, each tied to one source and one metric of the report card
(:data:`METRICS`) at stated conditions::

    sensor: azure_kinect_nfov
    sources:
      ms_hw_spec:
        citation: Microsoft, "Azure Kinect DK hardware specifications", Microsoft Learn, 2020
        where: Depth camera supported operating modes, table footnote
        url: https://learn.microsoft.com/azure/kinect-dk/hardware-specification
        verification: read          # read | secondary | unverified
    figures:
      - metric: temporal_noise_mm
        distance_range_m: [0.5, 3.86]
        bound: max                   # max | min | max_abs | value
        value: 17.0
        source: ms_hw_spec
        quote: "random error std. dev. <= 17 mm"

``bound`` says how ours is judged: ``max`` (ours <= value), ``min`` (ours >= value),
``max_abs`` (|ours| <= value), ``value`` (|ours - value| <= tolerance, where ``tolerance``
and ``tolerance_from`` - what spread of the source gives it - are required). ``per_m`` makes
the figure grow with distance (value + per_m * distance_m: "11 mm + 0.1 % of distance" is
value 11, per_m 1). A figure holds at one ``distance_m`` or over every card distance inside
``distance_range_m``. ``verification`` says how the figure was obtained: ``read`` in the
source itself, ``secondary`` (quoted by someone else; the source itself not read), or
``unverified`` (a figure to confirm). The card shows every figure and counts only the ones
read in their source.

``profile_parameter`` (``effect.parameter``, e.g. ``depth_noise.subpixel``) names a parameter of
the profile that was itself taken from the figure's sentence: ours then agrees by construction,
and the card shows the figure as ``by construction``, not counted. A figure of a systematic error
(:data:`SYSTEMATIC`) against a profile none of whose effects moves the mean depth
(``Effect.systematic_error``) is shown as ``not modelled``, not counted.

Unknown keys, metrics, sources or bounds are refused with the file and the key named.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from ..errors import ConfigError, did_you_mean, json_path
from ..resources import data_dir, read_text

# metric -> (test scene, unit, what it is)
METRICS: dict[str, tuple[str, str, str]] = {
    "fill_rate_pct": ("wall", "%", "valid pixels in the central ROI (Intel DQT)"),
    "z_accuracy_pct": ("wall", "%", "signed median depth error as % of the distance (Intel DQT)"),
    "plane_fit_rms_mm": (
        "wall",
        "mm",
        "RMS distance to the fitted plane, spatial noise (Intel DQT)",
    ),
    "plane_fit_rms_pct": ("wall", "%", "plane-fit RMS as % of the distance"),
    "subpixel_rms_px": ("wall", "px", "RMS disparity error against the fitted plane (Intel DQT)"),
    "temporal_noise_mm": (
        "wall",
        "mm",
        "RMS over pixels of each pixel's std over frames (random error)",
    ),
    "temporal_noise_pct": ("wall", "%", "temporal noise as % of the distance"),
    "bias_mm": ("wall", "mm", "median over pixels of temporal mean - truth (systematic error)"),
    "bias_pct": ("wall", "%", "systematic error as % of the distance"),
    "flying_pixel_pct": (
        "step",
        "%",
        "valid pixels within 3 px of a depth step lying on neither surface",
    ),
    "lateral_noise_px": (
        "step",
        "px",
        "std over frames of the step edge's position, RMS over rows",
    ),
    "edge_fill_pct": ("step", "%", "valid pixels within 3 px of the step edge"),
    "bar_fill_pct": ("bars", "%", "pixels of a thin bar returning the bar's depth"),
    "panel_fill_pct": ("panels", "%", "valid pixels on a panel of one material"),
    "banding_occupied": (
        "wall",
        "bins",
        "of 64 sub-pixel disparity bins, how many hold pixels (stereo)",
    ),
    "banding_peak_ratio": (
        "wall",
        "x",
        "fullest sub-pixel disparity bin over the mean bin (stereo)",
    ),
}
BOUNDS = ("max", "min", "max_abs", "value")
SYSTEMATIC = ("bias_mm", "bias_pct", "z_accuracy_pct")  # metrics of a systematic (mean) depth error
VERIFICATION = ("read", "secondary", "unverified")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class SourceSpec(_Strict):
    citation: str = Field(min_length=8)
    where: str = Field(min_length=2)
    url: str | None = None
    verification: Literal["read", "secondary", "unverified"]
    note: str | None = None


class FigureSpec(_Strict):
    metric: str
    bound: Literal["max", "min", "max_abs", "value"]
    value: float
    source: str
    quote: str = Field(min_length=3)
    distance_m: float | None = Field(default=None, gt=0)
    distance_range_m: tuple[float, float] | None = None
    angle_deg: float = Field(default=0.0, ge=0, le=80)
    part: str | None = None
    per_m: float = 0.0
    tolerance: float | None = Field(default=None, ge=0)
    tolerance_from: str | None = None
    profile_parameter: str | None = Field(default=None, pattern=r"^[a-z_]+\.[a-z_0-9]+$")
    note: str | None = None

    @model_validator(mode="after")
    def _conditions(self) -> "FigureSpec":
        if (self.distance_m is None) == (self.distance_range_m is None):
            raise ValueError("give exactly one of distance_m or distance_range_m")
        if (
            self.distance_range_m is not None
            and not 0 < self.distance_range_m[0] <= self.distance_range_m[1]
        ):
            raise ValueError(
                "distance_range_m must be [low, high] with 0 < low <= high, got "
                f"{self.distance_range_m}"
            )
        if self.bound == "value" and (self.tolerance is None or not self.tolerance_from):
            raise ValueError(
                "bound 'value' needs tolerance and tolerance_from (the source's spread it comes "
                "from)"
            )
        return self


class ReferenceSpec(_Strict):
    sensor: str
    sources: dict[str, SourceSpec]
    figures: list[FigureSpec] = Field(min_length=1)


@dataclass(frozen=True)
class Source:
    """One cited source: ``key`` (its name in the file), citation, where in it, url,
    verification (``read`` | ``secondary`` | ``unverified``) and a note."""

    key: str
    citation: str
    where: str
    url: str | None
    verification: str
    note: str | None


@dataclass(frozen=True)
class Figure:
    """One published figure, validated: the metric (a key of :data:`METRICS`), its test scene,
    the conditions (one distance, or a distance range; incidence angle; the part: a bar
    width or a panel material), how ours is judged (``bound``, ``value``, ``per_m``,
    ``tolerance``), and its :class:`Source`."""

    metric: str
    scene: str
    bound: str
    value: float
    source: Source
    quote: str
    distance_m: float | None
    distance_range_m: tuple[float, float] | None
    angle_deg: float
    part: str | None
    per_m: float
    tolerance: float | None
    tolerance_from: str | None
    note: str | None
    profile_parameter: str | None = None

    def limit(self, distance_m: float) -> float:
        """The figure's value at ``distance_m`` (value + per_m * distance)."""
        return float(self.value + self.per_m * distance_m)

    def covers(self, distance_m: float) -> bool:
        """Whether a measurement at ``distance_m`` falls under this figure."""
        if self.distance_m is not None:
            return abs(distance_m - self.distance_m) < 1e-9
        lo, hi = self.distance_range_m  # type: ignore[misc]
        return lo - 1e-9 <= distance_m <= hi + 1e-9

    def judge(self, ours: float, distance_m: float) -> bool:
        """True when ``ours`` (at ``distance_m``) agrees with the figure."""
        lim = self.limit(distance_m)
        if self.bound == "max":
            return ours <= lim
        if self.bound == "min":
            return ours >= lim
        if self.bound == "max_abs":
            return abs(ours) <= lim
        return abs(ours - lim) <= float(self.tolerance or 0.0)

    @property
    def counted(self) -> bool:
        """Only figures read in their source count; secondary and unverified ones are shown."""
        return self.source.verification == "read"


@dataclass(frozen=True)
class References:
    """The validated reference file of one sensor: its path, the sensor's name, the sources
    by key and the figures in file order."""

    path: str
    sensor: str
    sources: dict[str, Source]
    figures: tuple[Figure, ...]


def reference_path(sensor_name: str) -> Path:
    """``sensors/<name>.reference.yml`` among the shipped files."""
    return data_dir("sensors") / f"{sensor_name}.reference.yml"


def load_references(path_or_name: str | os.PathLike) -> References:
    """Read and validate a reference file (a path, or a shipped sensor's name); every error
    is one :class:`~genie_gl.errors.ConfigError` naming the file and the key."""
    p = Path(path_or_name)
    if not p.is_file():
        shipped = reference_path(str(path_or_name))
        if not shipped.is_file():
            names = sorted(
                x.name[: -len(".reference.yml")]
                for x in data_dir("sensors").glob("*.reference.yml")
            )
            raise ConfigError(
                f"{path_or_name}: no such reference file, and no shipped sensor of that name with "
                f"one (shipped: {', '.join(names) or 'none'}"
                f"){did_you_mean(str(path_or_name), names)}"
            )
        p = shipped
    text = read_text(p, "reference file (YAML)")
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{p}: not valid YAML ({str(exc).splitlines()[0]})") from None
    return parse_references(data, str(p))


def parse_references(data: object, source: str = "<dict>") -> References:
    """Validate parsed reference data; errors name ``source`` and the key's path."""
    try:
        spec = ReferenceSpec.model_validate(data)
    except ValidationError as exc:
        e = exc.errors()[0]
        raise ConfigError(f"{source}: {json_path(tuple(e['loc']))}: {e['msg']}") from None
    sources = {
        k: Source(k, s.citation, s.where, s.url, s.verification, s.note)
        for k, s in spec.sources.items()
    }
    figures = []
    for i, f in enumerate(spec.figures):
        where = f"{source}: $.figures[{i}]"
        if f.metric not in METRICS:
            raise ConfigError(
                f"{where}.metric: unknown metric {f.metric!r}{did_you_mean(f.metric, METRICS)} "
                f"(known: {', '.join(METRICS)})"
            )
        if f.source not in sources:
            raise ConfigError(
                f"{where}.source: {f.source!r} is not in $.sources{did_you_mean(f.source, sources)}"
            )
        scene = METRICS[f.metric][0]
        if scene in ("bars", "panels") and not f.part:
            raise ConfigError(
                f"{where}.part: {f.metric} needs the part it is about (a bar such as 'bar_10mm', "
                "or a "
                "panel material such as 'dark_15')"
            )
        figures.append(
            Figure(
                f.metric,
                scene,
                f.bound,
                float(f.value),
                sources[f.source],
                f.quote,
                f.distance_m,
                f.distance_range_m,
                float(f.angle_deg),
                f.part,
                float(f.per_m),
                f.tolerance,
                f.tolerance_from,
                f.note,
                f.profile_parameter,
            )
        )
    return References(source, spec.sensor, sources, tuple(figures))
