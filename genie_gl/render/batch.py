"""``render`` (one ideal frame) and ``capture`` (many poses, sensor effects, all cores)."""
from __future__ import annotations

import dataclasses
import functools
import logging
import multiprocessing as mp
import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..checks import capture_arguments, check_pose, expect
from ..frame import Frame
from ..limits import check_frames
from ..processes import die_with_parent
from ..scene.model import Scene
from ..sensors.camera import Sensor
from .renderer import Renderer

log = logging.getLogger(__name__)


def render(scene: Scene, sensor: Sensor, pose: np.ndarray, *, backend: str | None = None,
           depth_only: bool = False, normals: bool = False, depth_precision: str = "float32") -> Frame:
    """One frame of ``scene`` seen by ``sensor`` at ``pose`` (world_from_camera), through the
    sensor's lens, without its effects (:func:`capture` applies them).

    Creates and frees a GL context: to render many poses use :class:`Renderer` or
    :func:`capture`.
    """
    expect(scene, Scene, "render: scene")
    expect(sensor, Sensor, "render: sensor")
    pose = check_pose(pose, "render: pose")
    with Renderer(scene, backend=backend, depth_precision=depth_precision) as r:
        return r.render(sensor, pose, depth_only=depth_only, normals=normals)


def silhouettes(renderer: Renderer, sensor: Sensor, pose: np.ndarray, ids: Sequence[int]) -> dict[int, np.ndarray]:
    """Full (unoccluded) silhouette of each instance in ``ids`` as ``sensor`` sees it at
    ``pose``: one render of the instance alone (through the lens model, for distorted sensors).
    Returns {id: (H, W) bool}."""
    out = {}
    for i in ids:   # Renderer.render renders a distorted sensor through its lens
        f = renderer.render(sensor, pose, depth_only=True, only=(int(i),))
        out[int(i)] = f.instance == int(i)
    return out


def limit_threads(threads: int) -> None:
    """Let this process use ``threads`` cores: llvmpipe's rasteriser threads (read when the
    driver loads, so call this before the first GL context of the process; an
    ``LP_NUM_THREADS`` already set wins) and numba's (the culling kernels)."""
    threads = max(1, int(threads))
    os.environ.setdefault("LP_NUM_THREADS", str(threads))
    import numba

    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))


def pose_rng(seed: int, index: int) -> np.random.Generator:
    """The generator of pose ``index`` of a capture seeded with ``seed``."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), int(index)]))


class _Prefetched:
    """``render`` for :func:`simulate` that serves each pose's main render from
    :meth:`Renderer.frames` (frame i+1 renders while the effects of frame i run); any other
    render (an effect's extra view, a different sensor) goes to :meth:`Renderer.render`."""

    def __init__(self, renderer: Renderer, sensor: Sensor, poses: Sequence[np.ndarray], depth_only: bool,
                 normals: bool, only: Sequence[Any] | None = None) -> None:
        self.renderer, self.sensor, self.poses = renderer, sensor, poses
        self.depth_only, self.normals = depth_only, normals
        self.only = [None] * len(poses) if only is None else list(only)   # the plan's drawn ids per pose
        self.frames = renderer.frames(sensor, poses, depth_only=depth_only, normals=normals, only=self.only)
        self.next = 0

    def _is_main(self, sensor: Sensor, pose: np.ndarray, depth_only: bool, normals: bool, only: Any) -> bool:
        if depth_only != self.depth_only or normals != self.normals or self.next >= len(self.poses):
            return False
        want_only = self.only[self.next]
        if (only is None) != (want_only is None) or (
                only is not None and not (only is want_only or np.array_equal(only, want_only))):
            return False
        s = self.sensor
        same_sensor = sensor is s or (sensor.size == s.size and np.array_equal(sensor.K, s.K)
                                      and sensor.near_m == s.near_m and sensor.far_m == s.far_m)
        want = self.poses[self.next]
        return same_sensor and (pose is want or np.array_equal(pose, want))

    def __call__(self, sensor: Sensor, pose: np.ndarray, *, depth_only: bool | None = None, normals: bool = False,
                 only: Any = None) -> Frame:
        depth_only = self.depth_only if depth_only is None else depth_only
        if self._is_main(sensor, pose, depth_only, normals, only):
            self.next += 1
            return next(self.frames)
        return self.renderer.render(sensor, pose, depth_only=depth_only, normals=normals, only=only)


def _capture_serial(renderer: Renderer, sensor: Sensor, poses: Sequence[np.ndarray], seed: int,
                    indices: Sequence[int], depth_only: bool = False, plan: Any = None,
                    materials: Any = None, accuracy: Any = None) -> list[Frame]:
    from ..sensors.simulate import simulate  # effects live in the sensors stage

    poses = [np.asarray(p, dtype=np.float64) for p in poses]
    normals = any(eff.needs_normals for eff in sensor.effects)
    if sensor.is_pinhole:
        view = sensor
    else:  # the pinhole view the lens is resampled from (the default, exact, needs its normals)
        from ..sensors.distortion import lens_views

        views = lens_views(sensor, oversample=None if accuracy is None else accuracy.oversample)
        view = views[0].render_sensor if len(views) == 1 else sensor   # cube faces: no prefetch
        normals = True
    frame_plans = None if plan is None else [plan.frames[i] for i in indices]
    only = None
    if frame_plans is not None:   # the plan's culling and far plane, as simulate asks for them
        only = [f.drawn for f in frame_plans]
        far = frame_plans[0].far_m if frame_plans else view.far_m
        if far < view.far_m:
            view = dataclasses.replace(view, far_m=far)
    if accuracy is not None and accuracy.supersample > 1:   # every render through the supersampler
        from .supersample import supersampled

        render = supersampled(functools.partial(renderer.render, depth_only=depth_only), accuracy.supersample)
    else:
        render = _Prefetched(renderer, view, poses, depth_only, normals, only)
    from ..accuracy import simulate_options

    opts = simulate_options(accuracy)
    return [simulate(sensor, poses[k], render=render, rng=pose_rng(seed, i), materials=materials,
                     plan=None if frame_plans is None else frame_plans[k], **opts) for k, i in enumerate(indices)]


# -- process pool: one GL context per worker --------------------------------------------------
_WORKER: dict[str, Any] = {}


def _worker_init(scene: Scene, backend: str | None, lp_threads: int, depth_precision: str = "float32") -> None:
    die_with_parent()
    if backend is None and os.environ.get("GENIE_GL_BACKEND"):  # inherited from the CLI's process
        from .context import set_default_backend

        set_default_backend(os.environ["GENIE_GL_BACKEND"])
    # llvmpipe reads LP_NUM_THREADS when the driver loads; the parent's context is untouched.
    limit_threads(lp_threads)
    _WORKER["renderer"] = Renderer(scene, backend=backend, depth_precision=depth_precision)


def _worker_render(job: tuple) -> list[Frame]:
    sensor, poses, seed, indices, depth_only, plan, materials, accuracy = job
    return _capture_serial(_WORKER["renderer"], sensor, poses, seed, indices, depth_only, plan, materials, accuracy)


def capture(scene: Scene, sensor: Sensor, poses: Sequence[np.ndarray], *, seed: int,
            workers: int | None = 1, backend: str | None = None, depth_only: bool = False,
            depth_precision: str = "float32", plan: Any = True, accuracy: Any = None,
            context: Any = None) -> list[Frame]:
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
    depth_precision : "float32", "depth24" or "reversed_z" (see :class:`Renderer`).
    plan : True (default): follow :func:`genie_gl.plan` of these poses (culling, far plane,
        effects skipped where the view cannot call for them; same output as running them);
        a :class:`~genie_gl.plan.Plan` of these poses; None: no plan (every effect decided
        on its frame, no culling). Each frame's ``meta["effects"]`` records what ran.
    accuracy : :class:`genie_gl.accuracy.AccuracySettings`; None takes the profile's
        ``accuracy:`` block, else the defaults (supersampling, lens resampling, depth
        precision unless ``depth_precision`` is given, second-view scale, multipath samples;
        tessellation is the scene's).
    context : a :class:`~genie_gl.render.GLContext` to render in (``workers=1`` only; e.g.
        :func:`~genie_gl.render.shared_context`, kept from scene to scene); None makes one.
    """
    from ..accuracy import apply_to_sensor
    from .supersample import settings_for

    scene, sensor, poses, seed = capture_arguments(scene, sensor, poses, seed, Scene, Sensor)
    check_frames(len(poses), sensor.width, sensor.height, "capture")   # every frame is returned: all in memory
    accuracy = settings_for(sensor, accuracy)
    sensor = apply_to_sensor(sensor, accuracy)
    if depth_precision == "float32":
        depth_precision = accuracy.depth_precision
    poses = [np.asarray(p, dtype=np.float64) for p in poses]
    n = len(poses)
    if plan is True:
        from ..plan import plan as make_plan

        plan = make_plan(scene, sensor, poses)
    materials = None
    if plan is not None:
        materials = plan.materials
        for f in plan.frames:
            if f.empty:
                log.warning("capture: frame %d: %s (its cloud will be empty)", f.index, f.reason)
    elif any(e.needs_materials for e in sensor.effects):
        from ..scene.materials import MaterialTable

        materials = MaterialTable.from_scene(scene)
    workers = os.cpu_count() or 1 if workers is None else max(1, int(workers))
    workers = min(workers, n)
    if workers <= 1:
        with Renderer(scene, backend=backend, depth_precision=depth_precision, context=context) as r:
            return _said_if_empty(_capture_serial(r, sensor, poses, seed, range(n), depth_only, plan, materials,
                                                  accuracy), sensor)
    chunks = [list(range(w, n, workers)) for w in range(workers)]
    lp_threads = max(1, (os.cpu_count() or 1) // workers)
    ctx = mp.get_context("spawn")
    with ctx.Pool(workers, initializer=_worker_init, initargs=(scene, backend, lp_threads, depth_precision)) as pool:
        parts = pool.map(_worker_render, [(sensor, [poses[i] for i in c], seed, c, depth_only, plan, materials,
                                           accuracy)
                                          for c in chunks])
    frames: list[Frame | None] = [None] * n
    for c, part in zip(chunks, parts):
        for i, f in zip(c, part):
            frames[i] = f
    return _said_if_empty(frames, sensor)  # type: ignore[arg-type]


def _said_if_empty(frames: list[Frame], sensor: Sensor) -> list[Frame]:
    """``frames``, with a warning when not one of them has a return."""
    if frames and not any(bool((f.depth > 0).any()) for f in frames):
        log.warning("capture: no point captured: none of the %d frames of sensor %s (%dx%d px, range %g-%g m) has a "
                    "return", len(frames), sensor.name, sensor.width, sensor.height, sensor.near_m, sensor.far_m)
    return frames
