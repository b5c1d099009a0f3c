"""From a pose to a realistic frame: decide the renders a sensor needs, then apply its effects.

``simulate(sensor, pose, render=..., rng=...)`` is what ``genie_gl.capture`` calls for each
camera. ``render(sensor, pose) -> Frame`` renders an ideal pinhole frame of any sensor (its
``dist`` ignored). A distorted sensor is rendered as a wider pinhole image and remapped; then
the sensor's effects run in order. With no effects and no distortion the result is
``render(sensor, pose)`` itself, bit for bit, and no RNG draw is made.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..frame import Frame
from .camera import Sensor

RenderFn = Callable[[Sensor, np.ndarray], Frame]


def simulate(sensor: Sensor, pose: np.ndarray, *, render: RenderFn, rng: np.random.Generator) -> Frame:
    """Render ``sensor`` at ``pose`` (world_from_camera) and apply its effects in order."""
    if sensor.is_pinhole:
        frame = render(sensor, pose)
    else:
        from .distortion import distort, distortion_maps

        maps = distortion_maps(sensor)
        frame = distort(render(maps.render_sensor, pose), sensor, maps)
    for eff in sensor.effects:
        frame = eff.apply(frame, rng)
    return frame
