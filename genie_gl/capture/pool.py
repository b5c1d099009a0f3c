"""A capture spread over worker processes, one GL context each (spawned, never forked: a
forked child cannot render through its parent's EGL driver threads)."""

from __future__ import annotations

import multiprocessing as mp
import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..frame import Frame
from ..processes import die_with_parent, pool_started
from ..render.gl.context import default_backend
from ..render.lod import LevelOfDetail
from ..render.renderer import Renderer
from ..render.threads import limit_threads
from ..scene.materials import MaterialTable
from ..scene.model import Scene
from ..sensors.accuracy import AccuracySettings
from ..sensors.camera import Sensor
from .planner import Plan
from .serial import capture_serial
from .settings import level_of_detail

_WORKER: dict[str, Any] = {}


def _worker_init(
    scene: Scene,
    backend: str | None,
    lp_threads: int,
    depth_precision: str = "float32",
    lod: LevelOfDetail | None = None,
    raster: str = "gl",
) -> None:
    die_with_parent()
    # llvmpipe reads LP_NUM_THREADS when the driver loads; the parent's context is untouched.
    limit_threads(lp_threads)
    _WORKER["renderer"] = Renderer(
        scene, backend=backend, depth_precision=depth_precision, lod=lod, raster=raster
    )


def _worker_render(job: tuple) -> list[Frame]:
    sensor, poses, seed, indices, accuracy, depth_only, plan, materials = job
    return capture_serial(
        _WORKER["renderer"], sensor, poses, seed, indices, accuracy, depth_only, plan, materials
    )


def capture_in_workers(
    scene: Scene,
    sensor: Sensor,
    poses: Sequence[np.ndarray],
    seed: int,
    workers: int,
    backend: str | None,
    accuracy: AccuracySettings,
    depth_only: bool,
    depth_precision: str,
    plan: Plan | None,
    materials: MaterialTable | None,
    raster: str = "gl",
) -> list[Frame]:
    """The frames of ``poses`` made by ``workers`` processes, pose i by worker i mod workers
    (the frames do not depend on the split: each has its own generator)."""
    n = len(poses)
    chunks = [list(range(w, n, workers)) for w in range(workers)]
    lp_threads = max(1, (os.cpu_count() or 1) // workers)
    backend = backend or default_backend()  # the parent's choice, handed to each worker
    ctx = mp.get_context("spawn")
    initargs = (scene, backend, lp_threads, depth_precision, level_of_detail(accuracy), raster)
    with pool_started(
        lambda: ctx.Pool(workers, initializer=_worker_init, initargs=initargs)
    ) as pool:
        parts = pool.map(
            _worker_render,
            [
                (sensor, [poses[i] for i in c], seed, c, accuracy, depth_only, plan, materials)
                for c in chunks
            ],
        )
    frames: list[Frame | None] = [None] * n
    for c, part in zip(chunks, parts):
        for i, f in zip(c, part):
            frames[i] = f
    return frames  # type: ignore[return-value]
