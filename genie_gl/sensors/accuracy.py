"""Accuracy settings: the knobs that trade exactness for time, and the ``accuracy:`` block.

A sensor profile (``sensors/*.yaml``) and ``genie dataset --accuracy FILE`` accept a block::

    accuracy:
      supersample: 2          # render at 2x and reduce; ids never blended
      resample: exact         # nearest | bilinear | plane | exact (distorted lenses)
      raster: cpu             # cpu | gl (missing: cpu without a hardware GPU, else gl)
      depth_precision: float32   # the GL raster's depth buffer

``genie bench accuracy --budget-mm X`` writes such a file: the fastest setting whose error
stays within the budget. Every key is optional; a missing key keeps the default. A value of
``None`` (``null``) for ``oversample``, ``shadow_scale``, ``tessellation`` and
``multipath_samples`` keeps the owner's own default (the lens module's margin, the profile's
second-view scale, each asset's segment count, the multipath model's neighbourhood).

The settings are part of a sensor profile (``Sensor.accuracy``), so they live in the sensors
stage; the capture stage applies them (:mod:`genie_gl.capture.settings`).
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import yaml

from ..validation.arguments import expect_path
from ..errors import ConfigError, did_you_mean
from ..outputs import atomic_write_text, check_replaceable

RESAMPLE = ("nearest", "bilinear", "plane", "exact")
SHADOW = ("scanline", "render")
DEPTH_PRECISION = ("float32", "depth24", "reversed_z")
RASTER = ("cpu", "gl")  # the rasterisers (genie_gl.render.rasters; sensors cannot import render)
SUPERSAMPLE = (1, 2, 4)


#: the fields of a sensor profile (``profile.py`` reads them; an accuracy file may be a profile)
PROFILE_KEYS = (
    "name",
    "calibration",
    "camera",
    "effects",
    "near_m",
    "far_m",
    "accuracy",
    "baseline_m",
    "description",
    "source",
)


@dataclass(frozen=True)
class AccuracySettings:
    """How exactly a frame is made (every field has a cheaper and a more exact end).

    Attributes
    ----------
    supersample : 1, 2 or 4; render at ``s`` times the resolution and reduce each ``s x s``
        block to one pixel (the majority instance, its samples' mean depth; ids never blended).
    resample : how a distorted image is sampled from its wide pinhole render: "nearest",
        "bilinear" (depth-aware: never across a silhouette), "plane" (ids from the nearest
        view pixel, depth along each distorted ray from the plane of the triangle it hit) or
        "exact" (each pixel's own ray intersected with the triangles around it: ids and depth
        a ray caster's).
    oversample : float or None, resolution of that wide pinhole render relative to the
        sensor's (None: the lens module's default).
    raster : "cpu", "gl" or None: which rasteriser draws (:mod:`genie_gl.render.rasters`).
        "cpu": no GL, each pixel centre's ray meets its nearest triangle in float64 (exact
        depth and ids; the fastest without a GPU); "gl": OpenGL. None (the default): "cpu"
        on a machine without a hardware GPU, else "gl" (a dataset records what it used).
    depth_precision : the GL raster's depth: "float32" (linear view-z target), "depth24"
        (24-bit window depth read back and linearised) or "reversed_z" (reversed-Z float
        depth).
    shadow_scale : float or None, resolution of the second view's render (stereo /
        structured-light shadow) relative to the sensor's (None: the profile's); used by the
        "render" shadow method only.
    shadow : "scanline", "render" or None: how the stereo shadow finds what the second view
        cannot see (``stereo_shadow`` ``method``: "scanline" draws a rectified pinhole pair's
        second view row by row from the depth image; "render" renders it). None: the
        profile's (by default scanline where the pair allows it, else render).
    tessellation : int or None, segments per circle of curved assets and USD implicit gprims
        (None: each asset's own).
    multipath_samples : int or None, neighbours the multipath model samples (None: its own).
    lod_px : float or None, level of detail: an instance whose bounding sphere looks fewer
        than this many pixels across is drawn from a simplified copy of its mesh (10 % of its
        faces; :class:`genie_gl.render.LevelOfDetail`). None (the default): off, exact.
    """

    supersample: int = 1
    resample: str = "exact"
    oversample: float | None = None
    depth_precision: str = "float32"
    shadow_scale: float | None = None
    tessellation: int | None = None
    multipath_samples: int | None = None
    shadow: str | None = None
    lod_px: float | None = None
    raster: str | None = None

    def __post_init__(self) -> None:
        check(self, "accuracy")

    def to_dict(self) -> dict[str, Any]:
        """The ``accuracy:`` block (every field, ``None`` kept as null; ``raster`` only when
        given, so the blocks written before it existed read the same)."""
        out = dataclasses.asdict(self)
        if out["raster"] is None:
            del out["raster"]
        return out

    def changed(self) -> dict[str, Any]:
        """Only the fields that differ from the defaults."""
        base = AccuracySettings()
        return {
            f.name: getattr(self, f.name)
            for f in fields(self)
            if getattr(self, f.name) != getattr(base, f.name)
        }

    def label(self) -> str:
        """A short name: ``default`` or ``supersample=2, resample=nearest``."""
        ch = self.changed()
        return ", ".join(f"{k}={v}" for k, v in ch.items()) or "default"


def check(s: AccuracySettings, where: str) -> None:
    """Raise ConfigError naming ``where`` and the field when a value is out of range."""

    def bad(name: str, expected: str) -> ConfigError:
        return ConfigError(
            f"{where}: accuracy.{name}: expected {expected}, got {getattr(s, name)!r}"
        )

    if (
        not isinstance(s.supersample, int)
        or isinstance(s.supersample, bool)
        or s.supersample not in SUPERSAMPLE
    ):
        raise bad("supersample", "1, 2 or 4")
    if s.resample not in RESAMPLE:
        raise bad("resample", " | ".join(RESAMPLE) + did_you_mean(s.resample, RESAMPLE))
    if s.depth_precision == "exact":
        raise ConfigError(
            f"{where}: accuracy.depth_precision: 'exact' is the CPU rasteriser: write raster: cpu "
            "(depth_precision names the GL raster's depth buffers: "
            + " | ".join(DEPTH_PRECISION)
            + ")"
        )
    if s.raster is not None and s.raster not in RASTER:
        raise bad("raster", " | ".join(RASTER) + " or null" + did_you_mean(str(s.raster), RASTER))
    if s.depth_precision not in DEPTH_PRECISION:
        raise bad(
            "depth_precision",
            " | ".join(DEPTH_PRECISION) + did_you_mean(s.depth_precision, DEPTH_PRECISION),
        )
    if s.oversample is not None and not (_number(s.oversample) and 0.25 <= s.oversample <= 8):
        raise bad("oversample", "a number in [0.25, 8] or null")
    if s.shadow_scale is not None and not (_number(s.shadow_scale) and 0 < s.shadow_scale <= 4):
        raise bad("shadow_scale", "a number in (0, 4] or null")
    if s.shadow is not None and s.shadow not in SHADOW:
        raise bad("shadow", " | ".join(SHADOW) + " or null" + did_you_mean(s.shadow, SHADOW))
    if s.lod_px is not None and not (_number(s.lod_px) and 0 < s.lod_px < 1e6):
        raise bad("lod_px", "a number of pixels > 0 or null")
    for name, lo in (("tessellation", 3), ("multipath_samples", 1)):
        v = getattr(s, name)
        if v is not None and (not isinstance(v, int) or isinstance(v, bool) or v < lo):
            raise bad(name, f"an integer >= {lo} or null")


def _number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and v == v


def from_dict(data: Any, where: str) -> AccuracySettings:
    """Settings from an ``accuracy:`` mapping; unknown keys and bad values are named."""
    if data is None:
        return AccuracySettings()
    if not isinstance(data, dict):
        raise ConfigError(
            f"{where}: accuracy: expected a mapping of settings, got {type(data).__name__}"
        )
    names = [f.name for f in fields(AccuracySettings)]
    for key in data:
        if key not in names:
            raise ConfigError(
                f"{where}: accuracy.{key}: unknown setting{did_you_mean(key, names)}; "
                f"expected some of {', '.join(names)}"
            )
    try:
        return AccuracySettings(**data)
    except ConfigError as exc:
        raise ConfigError(
            str(exc).replace("accuracy: accuracy.", f"{where}: accuracy.", 1)
        ) from None


def load_accuracy(path: str | os.PathLike) -> AccuracySettings:
    """Settings from a YAML or JSON file holding an ``accuracy:`` block (a profile, or what
    ``genie bench accuracy --budget-mm`` wrote), or the bare mapping."""
    p = expect_path(path, "accuracy")
    try:
        data = yaml.safe_load(p.read_text())  # JSON is YAML
    except OSError as exc:
        raise ConfigError(f"{p}: cannot read accuracy settings ({exc.strerror})") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{p}: not valid YAML or JSON ({str(exc).splitlines()[0]})") from None
    if isinstance(data, dict) and "accuracy" in data:
        for key in data:  # a profile's other fields may stand beside the block
            if key not in PROFILE_KEYS:
                raise ConfigError(
                    f"{p}: {key}: not a field of an accuracy file or sensor profile"
                    f"{did_you_mean(str(key), PROFILE_KEYS)} (expected an accuracy: block)"
                )
        data = data["accuracy"]
    elif isinstance(data, dict):
        names = [f.name for f in fields(AccuracySettings)]
        for key in data:
            if key not in names:
                raise ConfigError(
                    f"{p}: {key}: unknown{did_you_mean(str(key), [*names, 'accuracy'])}; expected "
                    "an "
                    f"accuracy: block, or its settings ({', '.join(names)})"
                )
    return from_dict(data, str(p))


def write_accuracy(
    path: str | os.PathLike, settings: AccuracySettings, *, comment: str = ""
) -> Path:
    """Write ``settings`` as a YAML file with an ``accuracy:`` block (write, then rename)."""
    p = check_replaceable(path, _written_by_genie, what="accuracy settings")
    head = "".join(f"# {line}\n" for line in [*comment.splitlines(), STAMP])
    return atomic_write_text(
        p, head + yaml.safe_dump({"accuracy": settings.to_dict()}, sort_keys=False)
    )


STAMP = "written by genie-gl"


def _written_by_genie(path: Path) -> bool:
    head = path.read_text().split("accuracy:", 1)[0]
    return f"# {STAMP}" in head
