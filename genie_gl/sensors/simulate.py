"""From a pose to a realistic frame: decide the renders a sensor needs, then apply its effects.

``simulate(sensor, pose, render=..., rng=...)`` is what ``genie_gl.capture`` calls for each
camera. ``render(sensor, pose, *, depth_only=False, normals=False) -> Frame`` renders an ideal
pinhole frame of any sensor (its ``dist`` ignored), as :meth:`Renderer.render` does. A
distorted sensor is rendered as a wider pinhole image and remapped; then the sensor's effects
run in order. Effects that declare ``needs_normals`` get the frame rendered with normals (the
normals are dropped from the result again); effects that declare ``needs_render`` also get
``render_depth(sensor, pose) -> (H, W) float32``, a depth-only render from any pose. With no
effects and no distortion the result is ``render(sensor, pose)`` itself, bit for bit, and no
RNG draw is made.

``resample`` and ``oversample`` go to the distortion module where it takes them. Every frame's
``meta["cost_ms"]`` holds what making it cost, in milliseconds: ``render`` (the pinhole
render, supersampling included), ``distortion`` (the remap) and one entry per effect, named
``effect:<name>`` (an effect's second-view render counts as the effect's); an ideal pinhole
frame (no effects) carries none, as it is the render's own frame.
"""
from __future__ import annotations

import inspect
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from ..frame import Frame
from .camera import Sensor

RenderFn = Callable[..., Frame]
DepthRenderFn = Callable[[Sensor, np.ndarray], np.ndarray]


def _accepted(fn: Callable, wanted: dict[str, Any]) -> dict[str, Any]:
    """The keyword arguments of ``wanted`` that ``fn`` takes (and that are set)."""
    params = inspect.signature(fn).parameters
    return {k: v for k, v in wanted.items() if k in params and v is not None}


def simulate(sensor: Sensor, pose: np.ndarray, *, render: RenderFn, rng: np.random.Generator,
             resample: str = "exact", oversample: float | None = None) -> Frame:
    """Render ``sensor`` at ``pose`` (world_from_camera) and apply its effects in order."""
    normals = any(eff.needs_normals for eff in sensor.effects)
    kw = {"normals": True} if normals else {}
    cost: dict[str, float] = {}
    t0 = time.perf_counter()
    if sensor.is_pinhole:
        frame = render(sensor, pose, **kw)
        cost["render"] = 1e3 * (time.perf_counter() - t0)
    else:
        from .distortion import distort, distortion_maps

        knobs = {"resample": resample, "oversample": oversample}
        maps = distortion_maps(sensor, **_accepted(distortion_maps, knobs))
        wide = render(maps.render_sensor, pose, **kw)
        t1 = time.perf_counter()
        frame = distort(wide, sensor, maps, **_accepted(distort, knobs))
        cost["render"], cost["distortion"] = 1e3 * (t1 - t0), 1e3 * (time.perf_counter() - t1)

    def render_depth(view: Sensor, view_pose: np.ndarray) -> np.ndarray:
        return render(view, view_pose, depth_only=True).depth

    for eff in sensor.effects:
        t = time.perf_counter()
        if eff.needs_render:
            frame = eff.apply(frame, rng, render_depth=render_depth)
        else:
            frame = eff.apply(frame, rng)
        key = f"effect:{eff.name}"
        cost[key] = cost.get(key, 0.0) + 1e3 * (time.perf_counter() - t)
    if normals:
        frame = frame.replace(normal=None)
    if not sensor.effects and sensor.is_pinhole:
        return frame  # the ideal frame itself
    return frame.replace(meta={**(frame.meta or {}), "cost_ms": cost})
