"""``render`` (one ideal frame) and ``capture`` (many poses, sensor effects, all cores)."""
from __future__ import annotations

import functools
import logging
import multiprocessing as mp
import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..frame import Frame
from ..scene.model import Scene
from ..sensors.camera import Sensor
from .renderer import Renderer

log = logging.getLogger(__name__)


def render(scene: Scene, sensor: Sensor, pose: np.ndarray, *, backend: str | None = None,
           depth_only: bool = False, normals: bool = False) -> Frame:
    """One ideal pinhole frame of ``scene`` seen by ``sensor`` at ``pose`` (world_from_camera).

    Creates and frees a GL context: to render many poses use :class:`Renderer` or
    :func:`capture`.
    """
    with Renderer(scene, backend=backend) as r:
        return r.render(sensor, pose, depth_only=depth_only, normals=normals)


def silhouettes(renderer: Renderer, sensor: Sensor, pose: np.ndarray, ids: Sequence[int]) -> dict[int, np.ndarray]:
    """Full (unoccluded) silhouette of each instance in ``ids`` as ``sensor`` sees it at
    ``pose``: one render of the instance alone (through the lens model, for distorted sensors).
    Returns {id: (H, W) bool}."""
    out = {}
    for i in ids:
        if sensor.is_pinhole:
            f = renderer.render(sensor, pose, depth_only=True, only=(int(i),))
        else:
            from ..sensors.distortion import distort, distortion_maps

            maps = distortion_maps(sensor)
            f = distort(renderer.render(maps.render_sensor, pose, depth_only=True, only=(int(i),)), sensor, maps)
        out[int(i)] = f.instance == int(i)
    return out


def pose_rng(seed: int, index: int) -> np.random.Generator:
    """The generator of pose ``index`` of a capture seeded with ``seed``."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), int(index)]))


def _capture_serial(renderer: Renderer, sensor: Sensor, poses: Sequence[np.ndarray], seed: int,
                    indices: Sequence[int], depth_only: bool = False, plan: Any = None,
                    materials: Any = None) -> list[Frame]:
    from ..sensors.simulate import simulate  # effects live in the sensors stage

    render = functools.partial(renderer.render, depth_only=depth_only)
    return [simulate(sensor, np.asarray(poses[k], dtype=np.float64), render=render,
                     rng=pose_rng(seed, i), materials=materials,
                     plan=None if plan is None else plan.frames[i]) for k, i in enumerate(indices)]


# -- process pool: one GL context per worker --------------------------------------------------
_WORKER: dict[str, Any] = {}


def _worker_init(scene: Scene, backend: str | None, lp_threads: int) -> None:
    if backend is None and os.environ.get("GENIE_GL_BACKEND"):  # inherited from the CLI's process
        from .context import set_default_backend

        set_default_backend(os.environ["GENIE_GL_BACKEND"])
    # llvmpipe reads LP_NUM_THREADS when the driver loads; the parent's context is untouched.
    os.environ.setdefault("LP_NUM_THREADS", str(lp_threads))
    _WORKER["renderer"] = Renderer(scene, backend=backend)


def _worker_render(job: tuple) -> list[Frame]:
    sensor, poses, seed, indices, depth_only, plan, materials = job
    return _capture_serial(_WORKER["renderer"], sensor, poses, seed, indices, depth_only, plan, materials)


def capture(scene: Scene, sensor: Sensor, poses: Sequence[np.ndarray], *, seed: int,
            workers: int | None = 1, backend: str | None = None, depth_only: bool = False,
            plan: Any = True) -> list[Frame]:
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
    plan : True (default): follow :func:`genie_gl.plan` of these poses (culling, far plane,
        effects skipped where the view cannot call for them; same output as running them);
        a :class:`~genie_gl.plan.Plan` of these poses; None: no plan (every effect decided
        on its frame, no culling). Each frame's ``meta["effects"]`` records what ran.
    """
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
        with Renderer(scene, backend=backend) as r:
            return _capture_serial(r, sensor, poses, seed, range(n), depth_only, plan, materials)
    chunks = [list(range(w, n, workers)) for w in range(workers)]
    lp_threads = max(1, (os.cpu_count() or 1) // workers)
    ctx = mp.get_context("spawn")
    with ctx.Pool(workers, initializer=_worker_init, initargs=(scene, backend, lp_threads)) as pool:
        parts = pool.map(_worker_render, [(sensor, [poses[i] for i in c], seed, c, depth_only, plan, materials)
                                          for c in chunks])
    frames: list[Frame | None] = [None] * n
    for c, part in zip(chunks, parts):
        for i, f in zip(c, part):
            frames[i] = f
    return frames  # type: ignore[return-value]
