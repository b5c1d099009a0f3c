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
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..frame import Frame
from .camera import Sensor

RenderFn = Callable[..., Frame]
DepthRenderFn = Callable[[Sensor, np.ndarray], np.ndarray]


def simulate(sensor: Sensor, pose: np.ndarray, *, render: RenderFn, rng: np.random.Generator) -> Frame:
    """Render ``sensor`` at ``pose`` (world_from_camera) and apply its effects in order."""
    normals = any(eff.needs_normals for eff in sensor.effects)
    kw = {"normals": True} if normals else {}
    if sensor.is_pinhole:
        frame = render(sensor, pose, **kw)
    else:
        from .distortion import distort, distortion_maps

        maps = distortion_maps(sensor)
        frame = distort(render(maps.render_sensor, pose, **kw), sensor, maps)

    def render_depth(view: Sensor, view_pose: np.ndarray) -> np.ndarray:
        return render(view, view_pose, depth_only=True).depth

    for eff in sensor.effects:
        if eff.needs_render:
            frame = eff.apply(frame, rng, render_depth=render_depth)
        else:
            frame = eff.apply(frame, rng)
    if normals:
        frame = frame.replace(normal=None)
    return frame
