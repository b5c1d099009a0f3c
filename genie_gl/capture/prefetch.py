"""Each pose's main render served from :meth:`Renderer.frames`, so that frame i+1 renders
while the effects of frame i run."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..frame import Frame
from ..render.renderer import Renderer
from ..sensors.camera import Sensor
from .lens import through_lens


class Prefetched:
    """``render`` for :func:`~genie_gl.effects.simulate.simulate` that serves each pose's
    main render from :meth:`Renderer.frames` (frame i+1 renders while the effects of frame i
    run); any other render (an effect's extra view, a different sensor) goes to
    :meth:`Renderer.render`, through the lens for a distorted sensor.

    Parameters
    ----------
    renderer : the scene's renderer.
    sensor : the pinhole view of every main render.
    poses : (4, 4) float64 world_from_camera, in the order simulate asks for them.
    depth_only, normals, triangles : what the main renders draw.
    only : per pose, the plan's drawn ids (None: all).
    """

    def __init__(
        self,
        renderer: Renderer,
        sensor: Sensor,
        poses: Sequence[np.ndarray],
        depth_only: bool,
        normals: bool,
        only: Sequence[Any] | None = None,
        triangles: bool = False,
    ) -> None:
        self.renderer, self.sensor, self.poses = renderer, sensor, poses
        self.depth_only, self.normals, self.triangles = depth_only, normals, triangles
        self.only = [None] * len(poses) if only is None else list(only)
        self.frames = renderer.frames(
            sensor,
            poses,
            depth_only=depth_only,
            normals=normals,
            only=self.only,
            triangles=triangles,
        )
        self.next = 0
        self.render = through_lens(renderer.render)
        # a lens's frames are drawn by the renderer itself (its own pixel rays), or resampled
        self.draws_lenses = renderer.draws_lenses

    def _is_main(
        self,
        sensor: Sensor,
        pose: np.ndarray,
        depth_only: bool,
        normals: bool,
        only: Any,
        triangles: bool,
    ) -> bool:
        if (
            depth_only != self.depth_only
            or normals != self.normals
            or triangles != self.triangles
            or self.next >= len(self.poses)
        ):
            return False
        want_only = self.only[self.next]
        if (only is None) != (want_only is None) or (
            only is not None and not (only is want_only or np.array_equal(only, want_only))
        ):
            return False
        s = self.sensor
        same_sensor = sensor is s or (
            sensor.size == s.size
            and np.array_equal(sensor.K, s.K)
            and sensor.near_m == s.near_m
            and sensor.far_m == s.far_m
        )
        want = self.poses[self.next]
        return same_sensor and (pose is want or np.array_equal(pose, want))

    def __call__(
        self,
        sensor: Sensor,
        pose: np.ndarray,
        *,
        depth_only: bool | None = None,
        normals: bool = False,
        only: Any = None,
        triangles: bool = False,
    ) -> Frame:
        depth_only = self.depth_only if depth_only is None else depth_only
        if self._is_main(sensor, pose, depth_only, normals, only, triangles):
            self.next += 1
            return next(self.frames)
        extra = {"triangles": True} if triangles else {}
        return self.render(sensor, pose, depth_only=depth_only, normals=normals, only=only, **extra)
