"""The report card: a sensor profile's measurements (:mod:`genie_gl.card.measurements`) with
the published figures of its reference file (:mod:`genie_gl.card.references`) beside them.

:func:`report_card` measures the profile (and a user's captures, when given) and judges every
figure: ``pass`` when every measurement under it agrees, ``differs`` otherwise, ``not
measured`` when none falls under it; the worst case is reported. Two verdicts are shown and
never counted, because the profile could not have failed them: ``by construction`` (the figure
names the profile parameter taken from its own sentence) and ``not modelled`` (a systematic
error the profile has no effect for: its measured bias is the noise's, not a model's).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace
from typing import Any, Iterable

from ..errors import ConfigError, RenderError
from ..sensors.camera import Sensor
from ..effects.profile import load_sensor
from .captures import measure_captures
from .measurements import CardSettings, Measurement, measure
from .references import SYSTEMATIC, Figure, References, load_references, reference_path

UNCOUNTED = ("by construction", "not modelled")  # verdicts shown beside a figure, never counted


@dataclass(frozen=True)
class Judgement:
    """A figure judged against one set of measurements: the distance of the worst case
    (None when nothing was measured under the figure), our value there, the figure's limit
    there, and ``verdict``: ``"pass"``, ``"differs"`` or ``"not measured"``."""

    distance_m: float | None
    ours: float | None
    limit: float | None
    verdict: str
    why: str | None = None  # for a verdict in UNCOUNTED: the reason


@dataclass(frozen=True)
class Comparison:
    """One reference figure beside the simulated profile (``sim``) and, when the card was
    given a user's captures, beside those (``captures``)."""

    figure: Figure
    sim: Judgement
    captures: Judgement | None = None


@dataclass(frozen=True)
class ReportCard:
    """A sensor's report card: the profile's name and path, the settings, every measurement,
    the reference file's path (None without one), each figure's comparison, and the
    measurements of the user's captures (empty without them)."""

    sensor: str
    profile: str
    settings: CardSettings
    measurements: tuple[Measurement, ...]
    references: str | None
    comparisons: tuple[Comparison, ...]
    captures: tuple[Measurement, ...] = ()
    capture_source: str | None = None

    def counts(self) -> dict[str, int]:
        """Verdicts of the figures read in their source: pass, differs, not measured (the counted
        ones), and by construction, not modelled (read, shown, not counted)."""
        out = {"pass": 0, "differs": 0, "not measured": 0, "by construction": 0, "not modelled": 0}
        for c in self.comparisons:
            if c.figure.counted:
                out[c.sim.verdict] += 1
        return out

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dictionary of the card (floats as they are; NaN as None)."""

        def clean(v: Any) -> Any:
            if isinstance(v, float):
                return None if not math.isfinite(v) else v
            if isinstance(v, dict):
                return {k: clean(x) for k, x in v.items()}
            if isinstance(v, (list, tuple)):
                return [clean(x) for x in v]
            return v

        comps = []
        for c in self.comparisons:
            f = c.figure
            comps.append(
                {
                    "metric": f.metric,
                    "scene": f.scene,
                    "bound": f.bound,
                    "value": f.value,
                    "per_m": f.per_m,
                    "tolerance": f.tolerance,
                    "distance_m": f.distance_m,
                    "distance_range_m": f.distance_range_m,
                    "angle_deg": f.angle_deg,
                    "part": f.part,
                    "source": f.source.key,
                    "verification": f.source.verification,
                    "quote": f.quote,
                    "sim": asdict(c.sim),
                    "captures": None if c.captures is None else asdict(c.captures),
                }
            )
        return clean(
            {
                "sensor": self.sensor,
                "profile": self.profile,
                "settings": asdict(self.settings),
                "references": self.references,
                "counts": self.counts(),
                "comparisons": comps,
                "measurements": [asdict(m) for m in self.measurements],
                "captures": [asdict(m) for m in self.captures],
                "capture_source": self.capture_source,
            }
        )


# -- judging ---------------------------------------------------------------------------------
def judge(figure: Figure, measured: Iterable[Measurement]) -> Judgement:
    """The figure against the measurements under it (same metric, scene, angle and part, a
    distance it covers): ``pass`` when every one agrees; the worst one is reported."""
    worst: tuple[float, Measurement] | None = None
    ok = True
    for m in measured:
        if (
            m.metric != figure.metric
            or m.part != figure.part
            or abs(m.angle_deg - figure.angle_deg) > 1e-9
            or not figure.covers(m.distance_m)
            or not math.isfinite(m.value)
        ):
            continue
        lim = figure.limit(m.distance_m)
        excess = {
            "max": m.value - lim,
            "min": lim - m.value,
            "max_abs": abs(m.value) - lim,
            "value": abs(m.value - lim) - float(figure.tolerance or 0.0),
        }[figure.bound]
        ok &= figure.judge(m.value, m.distance_m)
        if worst is None or excess > worst[0]:
            worst = (excess, m)
    if worst is None:
        return Judgement(None, None, None, "not measured")
    m = worst[1]
    return Judgement(m.distance_m, m.value, figure.limit(m.distance_m), "pass" if ok else "differs")


def profile_value(sensor: Sensor, parameter: str, where: str) -> Any:
    """The value of ``effect.parameter`` in the sensor's effects (the first effect of that
    type); a parameter the profile does not have is one ConfigError naming ``where``."""
    effect, _, name = parameter.partition(".")
    for e in sensor.effects:
        if e.name == effect and name in {f.name for f in fields(e)}:
            return getattr(e, name)
    have = ", ".join(e.name for e in sensor.effects) or "none"
    raise ConfigError(
        f"{where}: profile_parameter {parameter!r}: the profile {sensor.name} has no such effect "
        f"parameter (its effects: {have})"
    )


def qualify(
    figure: Figure, j: Judgement, sensor: Sensor, where: str = "reference file"
) -> Judgement:
    """The judgement of the simulated profile, made ``by construction`` or ``not modelled``
    where the profile could not have failed the figure (see the module's docstring)."""
    if figure.profile_parameter:
        value = profile_value(sensor, figure.profile_parameter, where)
        return replace(
            j,
            verdict="by construction",
            why=f"the profile's {figure.profile_parameter} = {value:g} comes from this figure's "
            "own "
            f"sentence ({figure.source.key})",
        )
    if figure.metric in SYSTEMATIC and not any(
        getattr(e, "systematic_error", False) for e in sensor.effects
    ):
        return replace(
            j,
            verdict="not modelled",
            why="no effect of the profile moves the mean depth: its bias is the noise's, not a "
            "model's",
        )
    return j


def report_card(
    sensor: Sensor | str,
    *,
    settings: CardSettings | None = None,
    seed: int | None = None,
    references: References | str | None = "shipped",
    captures: Any = None,
    context: Any = None,
) -> ReportCard:
    """The report card of ``sensor`` (a :class:`~genie_gl.Sensor` or a profile name/path).

    Parameters
    ----------
    settings : what to render (:class:`CardSettings`; default settings when None).
    seed : overrides ``settings.seed``.
    references : a :class:`References`, a reference file's path, ``"shipped"`` (the default:
        ``sensors/<profile name>.reference.yml`` when there is one) or None (no figures).
    captures : a :class:`~genie_gl.card.captures.Captures` of the user's own camera, measured
        and judged beside the profile.
    context : a GL context to render in (None: this process's shared one).
    """

    if isinstance(sensor, str):
        sensor = load_sensor(sensor)
    settings = settings or CardSettings()
    if seed is not None:
        settings = replace(settings, seed=int(seed))
    refs: References | None
    if isinstance(references, References) or references is None:
        refs = references
    elif references == "shipped":
        refs = load_references(sensor.name) if reference_path(sensor.name).is_file() else None
    else:
        refs = load_references(references)
    if refs is not None and refs.sensor != sensor.name:
        raise ConfigError(
            f"{refs.path}: $.sensor is {refs.sensor!r}, but the profile is {sensor.name!r}"
        )
    sim = measure(sensor, settings, references=refs, context=context)
    if not sim:
        raise RenderError(
            f"report card: nothing of {sensor.name} could be measured (every test scene came "
            "back without a return)"
        )
    yours: list[Measurement] = []
    if captures is not None:
        yours = measure_captures(captures, roi_fraction=settings.roi_fraction)
    comps = tuple(
        Comparison(
            f,
            qualify(f, judge(f, sim), sensor, refs.path if refs is not None else ""),
            judge(f, yours) if captures is not None else None,
        )
        for f in (refs.figures if refs is not None else ())
    )
    return ReportCard(
        sensor.name,
        str(sensor.profile or sensor.calibration or ""),
        settings,
        tuple(sim),
        None if refs is None else refs.path,
        comps,
        tuple(yours),
        None if captures is None else captures.source,
    )


__all__ = [
    "CardSettings",
    "Comparison",
    "Judgement",
    "Measurement",
    "ReportCard",
    "judge",
    "qualify",
    "report_card",
]
