"""The accuracy settings of a capture, handed to the parts that read them.

:class:`~genie_gl.sensors.accuracy.AccuracySettings` is one typed record from the edge (a
profile's ``accuracy:`` block, ``--accuracy FILE``, a caller's argument) to where each field
is read: the renderer its ``depth_precision`` and level of detail (``lod_px``, made into a
:class:`~genie_gl.render.lod.LevelOfDetail` here), the lens its ``resample`` and ``oversample``,
the supersampler its ``supersample``, the scene builder its ``tessellation``, and each effect
the knobs it declares (:attr:`~genie_gl.effects.base.Effect.accuracy_knobs`), set here.
"""

from __future__ import annotations

import dataclasses

from ..render.lod import LevelOfDetail
from ..sensors.accuracy import AccuracySettings
from ..sensors.camera import Sensor


def settings_for(sensor: Sensor, accuracy: AccuracySettings | None = None) -> AccuracySettings:
    """The settings a capture uses: ``accuracy``, else the profile's ``accuracy:`` block
    (``sensor.accuracy``), else the defaults."""
    if accuracy is not None:
        return accuracy
    return sensor.accuracy or AccuracySettings()


def apply_to_sensor(sensor: Sensor, settings: AccuracySettings) -> Sensor:
    """``sensor`` with each effect's accuracy knobs set from ``settings`` (those not None),
    as the effect declares them (:attr:`~genie_gl.effects.base.Effect.accuracy_knobs`:
    the stereo shadow's ``scale`` and ``method``, the ToF multipath's ``samples``, ...); a
    value takes the type of the parameter it sets."""
    effects = []
    for eff in sensor.effects:
        changes = {
            param: type(getattr(eff, param))(value)
            for knob, param in eff.accuracy_knobs.items()
            if (value := getattr(settings, knob)) is not None
        }
        effects.append(dataclasses.replace(eff, **changes) if changes else eff)
    return dataclasses.replace(sensor, effects=tuple(effects))


def level_of_detail(settings: AccuracySettings | None) -> LevelOfDetail | None:
    """The renderer's :class:`~genie_gl.render.lod.LevelOfDetail` that ``settings.lod_px``
    asks for (instances that look fewer than ``lod_px`` pixels across drawn simplified), or
    None (off, the default)."""
    if settings is None or settings.lod_px is None:
        return None
    return LevelOfDetail(below_px=float(settings.lod_px))
