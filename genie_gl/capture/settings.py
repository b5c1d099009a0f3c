"""The accuracy settings of a capture, handed to the parts that read them.

:class:`~genie_gl.sensors.accuracy.AccuracySettings` is one typed record from the edge (a
profile's ``accuracy:`` block, ``--accuracy FILE``, a caller's argument) to here; this module
says which part takes which field: the renderer its depth precision and level of detail, the lens its resampling
and oversampling, the supersampler its factor, the scene builder its tessellation, and each
effect the knobs it declares (:attr:`~genie_gl.sensors.effect.Effect.accuracy_knobs`).
"""
from __future__ import annotations

import dataclasses
from typing import Any

from ..render.lod import LevelOfDetail
from ..sensors.accuracy import AccuracySettings
from ..sensors.camera import Sensor


def settings_for(sensor: Sensor, accuracy: AccuracySettings | None = None) -> AccuracySettings:
    """The settings a capture uses: ``accuracy``, else the profile's ``accuracy:`` block
    (``sensor.meta["accuracy"]``), else the defaults."""
    if accuracy is not None:
        return accuracy
    return sensor.meta.get("accuracy") or AccuracySettings()


def apply_to_sensor(sensor: Sensor, settings: AccuracySettings) -> Sensor:
    """``sensor`` with the effect-level knobs set: the stereo shadow's method and second-view
    scale and the samples of every multipath model that takes ``samples`` (``multipath``,
    ``tof_multipath``)."""
    effects = []
    for eff in sensor.effects:
        names = {f.name for f in dataclasses.fields(eff)} if dataclasses.is_dataclass(eff) else set()
        if getattr(eff, "name", "") == "stereo_shadow" and "scale" in names and settings.shadow_scale is not None:
            eff = dataclasses.replace(eff, scale=float(settings.shadow_scale))
        if getattr(eff, "name", "") == "stereo_shadow" and "method" in names and settings.shadow is not None:
            eff = dataclasses.replace(eff, method=settings.shadow)
        if ("multipath" in getattr(eff, "name", "") and "samples" in names
                and settings.multipath_samples is not None):
            eff = dataclasses.replace(eff, samples=int(settings.multipath_samples))
        effects.append(eff)
    return dataclasses.replace(sensor, effects=tuple(effects))


def simulate_options(settings: AccuracySettings | None) -> dict[str, Any]:
    """The keywords of :func:`~genie_gl.sensors.simulate.simulate` that carry ``settings``: the
    lens resampling and the wide render's oversampling (those set)."""
    if settings is None:
        return {}
    wanted = {"resample": settings.resample, "oversample": settings.oversample}
    return {k: v for k, v in wanted.items() if v is not None}


def renderer_options(settings: AccuracySettings | None) -> dict[str, Any]:
    """The :class:`~genie_gl.render.Renderer` keywords ``settings`` ask for: ``depth_precision``
    (float32 is the renderer's default and asks for nothing) and ``lod`` (level of detail,
    when ``lod_px`` is set)."""
    if settings is None:
        return {}
    out: dict[str, Any] = {}
    if settings.depth_precision != "float32":
        out["depth_precision"] = settings.depth_precision
    if settings.lod_px is not None:
        out["lod"] = LevelOfDetail(below_px=float(settings.lod_px))
    return out


def segments_option(settings: AccuracySettings | None) -> dict[str, Any]:
    """``{"segments": n}`` for the scene builder or USD reader when ``settings`` sets a
    tessellation (segments per circle of curved parts), else nothing."""
    if settings is None or settings.tessellation is None:
        return {}
    return {"segments": int(settings.tessellation)}
