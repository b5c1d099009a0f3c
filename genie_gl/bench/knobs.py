"""The knobs ``genie bench accuracy`` turns, one small registry entry each.

A knob names a field of :class:`~genie_gl.sensors.accuracy.AccuracySettings` (or the resolution,
which changes the sensor rather than a setting), its levels, the value the reference uses
(the most exact), whether the built-in case measures it against analytic truth (knobs that
change geometry) or against the exact setting (knobs that change how faithfully an effect
is simulated), and what it needs to run. A knob that has nothing to act on (lens knobs on a
pinhole sensor, an effect's knob on a sensor without that effect: the effects declare their
knobs, :attr:`~genie_gl.effects.base.Effect.accuracy_knobs`) reports why and shows as
unavailable; it is never faked.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

from ..sensors.accuracy import AccuracySettings
from ..effects.registry import EFFECTS
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


def _lens(case: Case) -> str | None:
    """What a lens knob needs: a distorted sensor."""
    if case.sensor.is_pinhole:
        return f"{case.sensor.name} has no lens distortion: nothing to resample"
    return None


def _effect_knob(knob: str) -> Callable[[Case], str | None]:
    """What a knob an effect declares (:attr:`Effect.accuracy_knobs`) needs: an effect of the
    sensor that takes it and on which it acts (:meth:`Effect.knob_unused`)."""

    def need(case: Case) -> str | None:
        effs = _takers(case.sensor, knob)
        if not effs:
            owners = sorted(name for name, cls in EFFECTS.items() if knob in cls.accuracy_knobs)
            return f"{case.sensor.name} has no {' or '.join(owners)} effect"
        unused = [why for e in effs if (why := e.knob_unused(knob, case.sensor)) is not None]
        return unused[0] if len(unused) == len(effs) else None

    return need


def _takers(sensor, knob: str) -> list:
    """The sensor's effects that take ``knob``."""
    return [e for e in sensor.effects if knob in e.accuracy_knobs]


def _tessellation(case: Case) -> str | None:
    if case.tessellation_supported:
        return None
    return {
        "usd": "this build's USD reader takes no segments= (not landed)",
        "strategy": "this build's scene builder takes no segments= (not landed)",
    }.get(case.kind, "not supported")


def _always(case: Case) -> str | None:
    return None


@dataclass(frozen=True)
class Knob:
    name: str
    title: str
    field: str | None  # AccuracySettings field; None: the resolution
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
    Knob(
        "resample",
        "lens resampling",
        "resample",
        ("nearest", "bilinear", "plane", "exact"),
        "exact",
        True,
        _lens,
    ),
    Knob("oversample", "wide-render oversampling", "oversample", (1.0, 1.5, 2.0), 2.0, True, _lens),
    Knob(
        "depth_precision",
        "depth precision (GL)",
        "depth_precision",
        ("depth24", "reversed_z", "float32"),
        "float32",
        True,
    ),
    Knob("raster", "rasteriser", "raster", ("gl", "cpu"), "cpu", True),
    Knob(
        "shadow_scale",
        "second-view scale",
        "shadow_scale",
        (0.25, 0.5, 1.0),
        2.0,
        False,
        _effect_knob("shadow_scale"),
    ),
    Knob(
        "tessellation",
        "tessellation (segments/circle)",
        "tessellation",
        (8, 16, 32, 64),
        128,
        True,
        _tessellation,
    ),
    Knob(
        "multipath_samples",
        "multipath samples",
        "multipath_samples",
        (8, 16, 32, 64),
        128,
        False,
        _effect_knob("multipath_samples"),
    ),
    Knob(
        "lod",
        "level of detail (below px across)",
        "lod_px",
        (16.0, 48.0, 128.0),
        None,
        True,
        unit=" px",
    ),
)
KNOB = {k.name: k for k in KNOBS}


def own_value(knob: Knob, case: Case) -> Any:
    """What a knob left at its default (None: "keep the owner's") amounts to on ``case``,
    or None when it cannot be told (the row is then labelled "own")."""
    d = knob.default()
    if d is not None:
        return d
    takers = [] if knob.field is None else _takers(case.sensor, knob.field)
    if takers:  # the first effect's own parameter
        return getattr(takers[0], takers[0].accuracy_knobs[knob.field])
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
