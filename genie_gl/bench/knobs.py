"""The knobs ``genie bench accuracy`` turns, one small registry entry each.

A knob names a field of :class:`~genie_gl.sensors.accuracy.AccuracySettings` (or the resolution,
which changes the sensor rather than a setting), its levels, the value the reference uses
(the most exact), whether the built-in case measures it against analytic truth (knobs that
change geometry) or against the exact setting (knobs that change how faithfully an effect
is simulated), and what it needs to run. A knob whose mechanism is missing from this build,
or that has nothing to act on (lens knobs on a pinhole sensor), reports why and shows as
unavailable; it is never faked.
"""
from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

from ..render import Renderer
from ..sensors import distortion
from ..sensors.accuracy import AccuracySettings
from ..sensors.simulate import simulate
from .analytic import DEFAULT_SEGMENTS


@dataclass(frozen=True)
class Setting:
    """One row's setting: a resolution factor of the sensor and the accuracy settings."""

    resolution: float = 1.0
    accuracy: AccuracySettings = field(default_factory=AccuracySettings)

    def key(self) -> tuple:
        return (self.resolution, tuple(sorted(self.accuracy.to_dict().items())))


@dataclass(frozen=True)
class Case:
    """What the rows run on: ``kind`` is "builtin", "usd" or "strategy"; ``scene_for(t)``
    gives the scene at tessellation ``t`` (None: the scene's own)."""

    kind: str
    source: str
    sensor: Any
    poses: list
    scene_for: Callable[[int | None], Any]
    layout: Any = None
    tessellation_supported: bool = False


def _takes(fn: Callable, name: str) -> bool:
    try:
        return name in inspect.signature(fn).parameters
    except (TypeError, ValueError):
        return False


def _effect(sensor, name: str):
    return next((e for e in sensor.effects if getattr(e, "name", "") == name), None)


def _lens(keyword: str) -> Callable[[Case], str | None]:
    def need(case: Case) -> str | None:
        if case.sensor.is_pinhole:
            return f"{case.sensor.name} has no lens distortion: nothing to resample"
        if not (_takes(distortion.distort, keyword) or _takes(distortion.distortion_maps, keyword)):
            return f"this build's lens module takes no {keyword}= (not landed)"
        if not _takes(simulate, keyword):
            return f"this build's simulate takes no {keyword}= (not landed)"
        return None
    return need


def _depth_precision(case: Case) -> str | None:
    return None if _takes(Renderer.__init__, "depth_precision") else "this build's Renderer takes no depth_precision= (not landed)"


def _shadow(case: Case) -> str | None:
    eff = _effect(case.sensor, "stereo_shadow")
    if eff is None:
        return f"{case.sensor.name} has no stereo_shadow effect"
    resolved = getattr(eff, "resolved_method", None)
    if resolved is not None and resolved(case.sensor) == "scanline":
        return f"{case.sensor.name}'s stereo shadow is drawn by scanline: no second view to scale (shadow: render)"
    return None


def _multipaths(sensor) -> list:
    return [e for e in sensor.effects if "multipath" in getattr(e, "name", "")]


def _multipath(case: Case) -> str | None:
    effs = _multipaths(case.sensor)
    if not effs:
        return f"{case.sensor.name} has no multipath effect"
    if any(hasattr(e, "samples") for e in effs):
        return None
    return "this build's multipath model takes no samples= (not landed)"


def _tessellation(case: Case) -> str | None:
    if case.tessellation_supported:
        return None
    return {"usd": "this build's USD reader takes no segments= (not landed)",
            "strategy": "this build's scene builder takes no segments= (not landed)"}.get(case.kind, "not supported")


def _always(case: Case) -> str | None:
    return None


@dataclass(frozen=True)
class Knob:
    name: str
    title: str
    field: str | None                 # AccuracySettings field; None: the resolution
    levels: tuple
    exact: Any
    geometric: bool
    requires: Callable[[Case], str | None] = _always
    unit: str = ""

    def setting(self, value: Any, base: Setting | None = None) -> Setting:
        base = base or Setting()
        if self.field is None:
            return replace(base, resolution=float(value))
        return replace(base, accuracy=replace(base.accuracy, **{self.field: value}))

    def default(self) -> Any:
        return 1.0 if self.field is None else getattr(AccuracySettings(), self.field)

    def label(self, value: Any) -> str:
        if value is None:
            return "off" if self.field == "lod_px" else "own"
        if self.name in ("resolution", "supersample"):
            return f"x{value:g}"
        return f"{value:g}{self.unit}" if isinstance(value, (int, float)) else str(value)


KNOBS: tuple[Knob, ...] = (
    Knob("resolution", "resolution (x sensor)", None, (0.5, 1.0, 2.0), 1.0, True),
    Knob("supersample", "edge supersampling", "supersample", (1, 2, 4), 4, True),
    Knob("resample", "lens resampling", "resample", ("nearest", "bilinear", "plane", "exact"), "exact", True,
         _lens("resample")),
    Knob("oversample", "wide-render oversampling", "oversample", (1.0, 1.5, 2.0), 2.0, True, _lens("oversample")),
    Knob("depth_precision", "depth precision", "depth_precision", ("depth24", "reversed_z", "float32"),
         "float32", True, _depth_precision),
    Knob("shadow_scale", "second-view scale", "shadow_scale", (0.25, 0.5, 1.0), 2.0, False, _shadow),
    Knob("tessellation", "tessellation (segments/circle)", "tessellation", (8, 16, 32, 64), 128, True,
         _tessellation),
    Knob("multipath_samples", "multipath samples", "multipath_samples", (8, 16, 32, 64), 128, False, _multipath),
    Knob("lod", "level of detail (below px across)", "lod_px", (16.0, 48.0, 128.0), None, True, unit=" px"),
)
KNOB = {k.name: k for k in KNOBS}


def own_value(knob: Knob, case: Case) -> Any:
    """What a knob left at its default (None: "keep the owner's") amounts to on ``case``,
    or None when it cannot be told (the row is then labelled "own")."""
    d = knob.default()
    if d is not None:
        return d
    if knob.name == "shadow_scale":
        return getattr(_effect(case.sensor, "stereo_shadow"), "scale", None)
    if knob.name == "multipath_samples":
        return next((e.samples for e in _multipaths(case.sensor) if hasattr(e, "samples")), None)
    if knob.name == "tessellation" and case.kind == "builtin":
        return DEFAULT_SEGMENTS
    return None


def levels(knob: Knob, case: Case) -> list[tuple[Any, str]]:
    """(value, label) of the rows of ``knob`` on ``case``: its levels, the one that equals the
    default given as the default itself (so the default row is shared, not rendered twice)."""
    d, own = knob.default(), own_value(knob, case)
    out = [(d if v == own else v, knob.label(v)) for v in knob.levels]
    if own not in knob.levels:
        out.insert(0, (d, knob.label(own)))
    return out


def exact_setting(case: Case) -> Setting:
    """Every available knob at its most exact value (the resolution stays the sensor's)."""
    acc = AccuracySettings()
    for k in KNOBS:
        if k.field is not None and k.requires(case) is None:
            acc = replace(acc, **{k.field: k.exact})
    return Setting(1.0, acc)


# placement effort: (generations, population) of the genetic search; greedy is its seed
PLACEMENT_LEVELS = ((0, 1), (10, 8), (50, 16), (150, 32))
PLACEMENT_DEFAULT = (150, 32)
