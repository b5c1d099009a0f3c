"""From a pose to a realistic frame: decide the renders a sensor needs, then apply its effects.

``simulate(sensor, pose, render=..., rng=...)`` is what ``genie_gl.capture`` calls for each
camera. ``render(sensor, pose, *, depth_only=False, normals=False) -> Frame`` renders an ideal
pinhole frame of a pinhole camera, as :meth:`Renderer.render` does. A distorted sensor is
rendered through its lens (:func:`.distortion.render_through_lens`: pinhole views, resampled
with ``resample`` / ``oversample``); then the sensor's effects
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


def simulate(sensor: Sensor, pose: np.ndarray, *, render: RenderFn, rng: np.random.Generator,
             resample: str = "exact", oversample: float | None = None) -> Frame:
    """Render ``sensor`` at ``pose`` (world_from_camera) and apply its effects in order.

    ``resample`` and ``oversample``: how a distorted sensor's image is made from its pinhole
    views (see :mod:`.distortion`; ignored for a pinhole sensor)."""
    normals = any(eff.needs_normals for eff in sensor.effects)
    kw = {"normals": True} if normals else {}
    if sensor.is_pinhole:
        frame = render(sensor, pose, **kw)
    else:
        from .distortion import render_through_lens

        frame = render_through_lens(render, sensor, pose, resample=resample, oversample=oversample, **kw)

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
