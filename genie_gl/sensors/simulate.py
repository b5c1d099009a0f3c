"""From a pose to a realistic frame: decide the renders a sensor needs, then apply its effects.

``simulate(sensor, pose, render=..., rng=...)`` is what ``genie_gl.capture`` calls for each
camera. ``render(sensor, pose) -> Frame`` renders an ideal pinhole frame of any sensor (its
``dist`` ignored); effects that need another view (a wider field for lens distortion, the
second imager of a stereo pair) call it themselves. With no effects and no distortion the
result is ``render(sensor, pose)`` itself, bit for bit, and no RNG draw is made.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import ConfigError
from ..frame import Frame
from .camera import Sensor

RenderFn = Callable[[Sensor, np.ndarray], Frame]


def simulate(sensor: Sensor, pose: np.ndarray, *, render: RenderFn, rng: np.random.Generator) -> Frame:
    """Render ``sensor`` at ``pose`` (world_from_camera) and apply its effects in order."""
    if sensor.effects or not sensor.is_pinhole:
        raise ConfigError(f"sensor {sensor.name}: effects and lens distortion are not supported yet")
    return render(sensor, pose)
