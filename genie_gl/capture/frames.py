"""``render`` (one frame through the lens, no effects) and ``capture`` (many poses, the
sensor's effects, the plan, the accuracy settings; all cores).

This is where the stages below meet: the renderer draws pinhole views, the lens resamples
them into the sensor's image, the supersampler renders edges finer, the plan culls what
cannot be seen and skips effects the view cannot call for, and ``simulate`` runs the
sensor's effects, each frame with its own generator.
"""

from __future__ import annotations

import dataclasses
import logging
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..validation.arguments import capture_arguments, check_pose, describe, expect
from ..errors import ConfigError
from ..frame import Frame
from ..limits import check_frames
from ..render.gl.context import GLContext
from ..render.rasters import resolve_raster
from ..render.renderer import Renderer
from ..scene.materials import MaterialTable
from ..scene.model import Scene
from ..sensors.accuracy import AccuracySettings
from ..sensors.camera import Sensor
from .lens import through_lens
from .planner import Plan
from .planner import plan as make_plan
from .pool import capture_in_workers
from .serial import capture_serial
from .settings import apply_to_sensor, level_of_detail, settings_for

log = logging.getLogger(__name__)


def render(
    scene: Scene,
    sensor: Sensor,
    pose: np.ndarray,
    *,
    backend: str | None = None,
    depth_only: bool = False,
    normals: bool = False,
    depth_precision: str = "float32",
    raster: str | None = None,
) -> Frame:
    """One frame of ``scene`` seen by ``sensor`` at ``pose`` (world_from_camera), through the
    sensor's lens, without its effects (:func:`capture` applies them).

    Creates and frees a GL context: to render many poses use :func:`capture`, or a
    :class:`~genie_gl.render.Renderer` with :func:`~genie_gl.capture.through_lens`.
    ``raster``: "cpu" or "gl" (None: the sensor's accuracy block, else the machine's default,
    :func:`~genie_gl.render.rasters.default_raster`).
    """
    expect(scene, Scene, "render: scene")
    expect(sensor, Sensor, "render: sensor")
    pose = check_pose(pose, "render: pose")
    raster = resolve_raster(raster or settings_for(sensor).raster, "render")
    with Renderer(scene, backend=backend, depth_precision=depth_precision, raster=raster) as r:
        return through_lens(r.render)(sensor, pose, depth_only=depth_only, normals=normals)


def capture(
    scene: Scene,
    sensor: Sensor,
    poses: Sequence[np.ndarray],
    *,
    seed: int,
    workers: int | None = 1,
    backend: str | None = None,
    depth_only: bool = False,
    depth_precision: str = "float32",
    plan: Plan | bool | None = True,
    accuracy: AccuracySettings | None = None,
    context: GLContext | None = None,
    on_frame: Callable[[Frame], None] | None = None,
    raster: str | None = None,
) -> list[Frame]:
    """Render ``poses`` and apply ``sensor``'s effects; frame i's noise depends on (seed, i) only.

    Parameters
    ----------
    scene, sensor : what to render and with which camera.
    poses : sequence of (4, 4) float64 world_from_camera.
    seed : int, seeds each pose's generator as ``SeedSequence([seed, i])``.
    workers : processes to render with (one GL context each); None = all cores. 1 renders in
        this process. The frames do not depend on it.
    backend : GL backend ("egl", "osmesa" or None).
    depth_only : skip the colour target (frames get ``rgb=None``).
    depth_precision : the GL raster's "float32", "depth24" or "reversed_z" (see :class:`Renderer`).
    plan : True (default): follow :func:`~genie_gl.capture.plan` of these poses (culling, far
        plane, effects skipped where the view cannot call for them; same output as running
        them); a :class:`~genie_gl.capture.Plan` of these poses; None: no plan (every effect
        decided on its frame, no culling). Each frame's ``meta["effects"]`` records what ran.
    accuracy : :class:`~genie_gl.sensors.accuracy.AccuracySettings`; None takes the profile's
        ``accuracy:`` block, else the defaults (supersampling, lens resampling, depth
        precision unless ``depth_precision`` is given, second-view scale, multipath samples,
        level of detail; tessellation is the scene's).
    context : a :class:`~genie_gl.render.GLContext` to render in (``workers=1`` only; e.g.
        :func:`~genie_gl.render.shared_context`, kept from scene to scene); None makes one.
    raster : "cpu" or "gl": which rasteriser draws; None: the accuracy settings' ``raster``,
        else the machine's default (:func:`~genie_gl.render.rasters.default_raster`: the
        exact CPU engine without a hardware GPU). The frames depend on it.
    on_frame : called with each frame, in pose order: with ``workers=1`` as soon as the frame
        is made, while the next ones render (``genie dataset`` starts counting its points per
        tile so); with workers, once all are back.
    """
    scene, sensor, poses, seed = capture_arguments(scene, sensor, poses, seed, Scene, Sensor)
    if on_frame is not None and not callable(on_frame):
        raise ConfigError(
            "capture: on_frame: expected a function taking a Frame (or None), got "
            f"{describe(on_frame)}"
        )
    check_frames(
        len(poses), sensor.width, sensor.height, "capture"
    )  # every frame is returned: all in memory
    prep = prepare(
        scene,
        sensor,
        poses,
        accuracy=accuracy,
        depth_precision=depth_precision,
        plan=plan,
        raster=raster,
    )
    n = len(prep.poses)
    workers = os.cpu_count() or 1 if workers is None else max(1, int(workers))
    workers = min(workers, n)
    if workers <= 1:
        with prep.renderer(scene, backend=backend, context=context) as r:
            return _said_if_empty(prep.frames(r, seed, depth_only, on_frame=on_frame), prep.sensor)
    frames = capture_in_workers(
        scene,
        prep.sensor,
        prep.poses,
        seed,
        workers,
        backend,
        prep.accuracy,
        depth_only,
        prep.depth_precision,
        prep.plan,
        prep.materials,
        prep.raster,
    )
    if on_frame is not None:
        for f in frames:
            on_frame(f)
    return _said_if_empty(frames, prep.sensor)


def _said_if_empty(frames: list[Frame], sensor: Sensor) -> list[Frame]:
    """``frames``, with a warning when not one of them has a return."""
    if frames and not any(bool((f.depth > 0).any()) for f in frames):
        log.warning(
            "capture: no point captured: none of the %d frames of sensor %s (%dx%d px, range %g-%g "
            "m) has a "
            "return",
            len(frames),
            sensor.name,
            sensor.width,
            sensor.height,
            sensor.near_m,
            sensor.far_m,
        )
    return frames


@dataclass(frozen=True, eq=False)
class Prepared:
    """What :func:`capture` settles before it renders: the sensor with its accuracy knobs
    set, the settings, the depth precision, the raster ("cpu" or "gl"), the poses ((4, 4) float64
    world_from_camera), the
    plan of those poses (None: no plan) and the material table the effects read. A caller
    that renders the poses in parts (a recording, window by window) prepares once and hands
    :meth:`frames` one renderer and each part's :meth:`part`."""

    sensor: Sensor
    accuracy: AccuracySettings
    depth_precision: str
    poses: list
    plan: Plan | None
    materials: MaterialTable | None
    raster: str = "gl"

    @property
    def renderer_key(self) -> tuple:
        """Captures with equal keys can share one :class:`Renderer` (raster, depth precision, level
        of detail)."""
        return self.raster, self.depth_precision, self.accuracy.lod_px

    def renderer(
        self, scene: Scene, *, backend: str | None = None, context: GLContext | None = None
    ) -> Renderer:
        """A renderer of ``scene`` as these settings ask (raster, depth precision, level of
        detail); ``context`` is used by the GL raster only."""
        return Renderer(
            scene,
            backend=backend,
            depth_precision=self.depth_precision,
            context=context if self.raster == "gl" else None,
            lod=level_of_detail(self.accuracy),
            raster=self.raster,
        )

    def part(self, start: int, stop: int) -> "Prepared":
        """Poses ``start:stop`` as a capture of their own (the plan's frames renumbered from 0)."""
        sub = None
        if self.plan is not None:
            frames = [
                dataclasses.replace(f, index=i) for i, f in enumerate(self.plan.frames[start:stop])
            ]
            sub = Plan(self.plan.sensor, frames, self.plan.materials)
        return dataclasses.replace(self, poses=self.poses[start:stop], plan=sub)

    def frames(
        self,
        renderer: Renderer,
        seed: int,
        depth_only: bool = False,
        on_frame: Callable[[Frame], None] | None = None,
    ) -> list[Frame]:
        """Every pose's frame, rendered with ``renderer`` in this process; frame i's noise from
        (seed, i); ``on_frame(frame)`` as each is made."""
        return capture_serial(
            renderer,
            self.sensor,
            self.poses,
            seed,
            range(len(self.poses)),
            self.accuracy,
            depth_only,
            self.plan,
            self.materials,
            on_frame,
        )


def prepare(
    scene: Scene,
    sensor: Sensor,
    poses: Sequence[np.ndarray],
    *,
    accuracy: AccuracySettings | None = None,
    depth_precision: str = "float32",
    plan: Plan | bool | None = True,
    raster: str | None = None,
) -> Prepared:
    """Settle a capture of ``poses`` (``gg.capture``'s arguments of the same names): the
    settings, the sensor they set, the plan (warning of frames with nothing in range) and the
    materials."""
    accuracy = settings_for(sensor, accuracy)
    sensor = apply_to_sensor(sensor, accuracy)
    if depth_precision == "float32":
        depth_precision = accuracy.depth_precision
    raster = resolve_raster(raster or accuracy.raster, "capture")
    poses = [np.asarray(p, dtype=np.float64) for p in poses]
    if plan is True:
        plan = make_plan(scene, sensor, poses)
    materials = None
    if plan is not None:
        materials = plan.materials
        for f in plan.frames:
            if f.empty:
                log.warning("capture: frame %d: %s (its cloud will be empty)", f.index, f.reason)
    elif any(e.needs_materials for e in sensor.effects):
        materials = MaterialTable.from_scene(scene)
    return Prepared(sensor, accuracy, depth_precision, poses, plan, materials, raster)
