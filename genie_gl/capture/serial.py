"""The frames of a capture made in this process, one renderer, pose by pose."""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable, Sequence

import numpy as np

from ..frame import Frame
from ..render.renderer import Renderer
from ..scene.materials import MaterialTable
from ..sensors.accuracy import AccuracySettings
from ..sensors.camera import Sensor
from ..lens.distortion import lens_views
from ..effects.simulate import simulate
from .lens import through_lens
from .planner import Plan
from .prefetch import Prefetched
from .supersample import supersampled


def pose_rng(seed: int, index: int) -> np.random.Generator:
    """The generator of pose ``index`` of a capture seeded with ``seed``."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), int(index)]))


def capture_serial(
    renderer: Renderer,
    sensor: Sensor,
    poses: Sequence[np.ndarray],
    seed: int,
    indices: Sequence[int],
    accuracy: AccuracySettings,
    depth_only: bool = False,
    plan: Plan | None = None,
    materials: MaterialTable | None = None,
    on_frame: Callable[[Frame], None] | None = None,
) -> list[Frame]:
    """The frames ``indices`` of a capture, in this process, with ``renderer``: poses[k] is
    pose ``indices[k]`` of the capture (its generator and its frame plan). ``accuracy``: the
    supersampling, lens resampling and oversampling (the renderer carries its depth
    precision, the sensor's effects their own knobs). ``on_frame(frame)``: called with each
    frame, in order, as soon as it is made (while the next ones render)."""
    poses = [np.asarray(p, dtype=np.float64) for p in poses]
    normals = any(eff.needs_normals for eff in sensor.effects)
    triangles = False
    if sensor.is_pinhole or (renderer.draws_lenses and accuracy.resample == "exact"):
        view = sensor  # (a lens the renderer draws itself, each pixel's own ray)
    else:  # the pinhole view the lens is resampled from, with what its resampling needs
        views = lens_views(sensor, oversample=accuracy.oversample)
        view = views[0].render_sensor if len(views) == 1 else sensor  # cube faces: no prefetch
        resample = accuracy.resample
        triangles = resample == "exact"
        normals = (normals or resample == "plane") and not triangles
    frame_plans = None if plan is None else [plan.frames[i] for i in indices]
    only = None
    if frame_plans is not None:  # the plan's culling and far plane, as simulate asks for them
        only = [f.drawn for f in frame_plans]
        far = frame_plans[0].far_m if frame_plans else view.far_m
        if far < view.far_m:
            view = dataclasses.replace(view, far_m=far)
    if accuracy.supersample > 1:  # every render through the supersampler
        draw = supersampled(
            functools.partial(through_lens(renderer.render), depth_only=depth_only),
            accuracy.supersample,
        )
    else:
        draw = Prefetched(renderer, view, poses, depth_only, normals, only, triangles)
    # a sensor without effects never draws: its frames need no generator (~0.1 ms each to make)
    frames = []
    for k, i in enumerate(indices):
        frames.append(
            simulate(
                sensor,
                poses[k],
                render=draw,
                rng=pose_rng(seed, i) if sensor.effects else None,
                materials=materials,
                plan=None if frame_plans is None else frame_plans[k],
                resample=accuracy.resample,
                oversample=accuracy.oversample,
            )
        )
        if on_frame is not None:
            on_frame(frames[-1])
    return frames
