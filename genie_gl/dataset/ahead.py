"""The next scene's layout, scene and placement, made in a helper process while this one is
captured.

One worker on two cores keeps the second core busy only inside llvmpipe and the numba
kernels: its layout, scene builder and placement (pure Python, about a fifth of a steady
scene) run on the main thread, on the critical path, with the other core idle. Where a
process may use a core more (:func:`~genie_gl.cloud.tally.spare_core`: one worker on two
cores, not each of two), :class:`Ahead` makes those three stages of scene i+1 in a helper
process while the worker captures, cuts and writes scene i.

What it hands over is exactly what the worker would have made: the same recipe
(:func:`make_parts`, also what :func:`~genie_gl.dataset.recipe.make` calls in-process), the
scene's own streams (seed, index), so every byte written is the same with and without it
(tested). Meshes come back as copies; each is swapped for the first copy of its content this
process received (:meth:`Ahead.take`), so what is cached per mesh (the planner's convexity
check) is computed once per mesh, not once per scene.

Time: the worker's layout, scene and placement stages become the time it waits for the parts
and unpacks them (a stage time that still adds up to the worker's wall time per scene); the
helper's own seconds and CPU seconds for them come with the parts (``ahead_s`` and
``cpu_s`` in the scene's record, the CPU time added to the scene's), so the benchmark shows
the work and where it ran. A helper that dies is reported once and the worker makes the
remaining scenes itself.
"""

from __future__ import annotations

import gc
import logging
import os
import signal
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool

from numba.core.compiler_lock import global_compiler_lock

from ..processes import die_with_parent, forked_pool
from ..scene.model import Mesh
from .recipe import Parts, make_parts
from .streams import SceneStreams
from .warmup import WARM_CAMERAS, WARM_SEED

log = logging.getLogger(__name__)

# -- the helper process ----------------------------------------------------------------------
_HELPER: dict = {}


def _compiler_free() -> bool:
    """Whether numba's compiler lock is free in this process. A fork copies only the forking
    thread: a lock another thread held at that moment stays held for good in the copy, and
    the helper's first kernel (placement's) would wait on it for ever."""
    lock = getattr(global_compiler_lock, "_lock", None)
    if lock is None or not hasattr(lock, "acquire"):
        return True
    if not lock.acquire(blocking=False):
        return False
    lock.release()
    return True


def _start(parent: int, inputs, seed: int, cameras: int) -> None:
    die_with_parent(parent)
    if not _compiler_free():  # the worker is told (the pool breaks) and makes the scenes itself
        raise RuntimeError("forked while another thread of the worker held numba's compiler lock")
    # Ctrl-C and SIGTERM reach the whole process group: the worker unwinds and ends the helper
    # (its pool's shutdown), which goes with it, not on its own, and says nothing
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    _HELPER.update(inputs=inputs, seed=seed, cameras=cameras)


def _warm() -> None:
    """The helper's warm-up: a throw-away scene's parts (:data:`~.warmup.WARM_SEED`), which
    build the assets and load the placement's kernels."""
    h = _HELPER
    make_parts(h["inputs"], SceneStreams(WARM_SEED, 0), min(WARM_CAMERAS, h["cameras"]))
    gc.freeze()


def _make(index: int) -> Parts:
    h = _HELPER
    return make_parts(h["inputs"], SceneStreams(h["seed"], index), h["cameras"])


class Ahead:
    """A helper process making the parts of a worker's scenes, one scene ahead.

    ``take(i)`` asks for the parts of ``upcoming(i)``, the next scene the worker will make
    (None: none), then returns scene i's, waiting for them if need be; None when they were
    not asked for (the first scene: the worker makes it while the helper makes the second)
    or the helper died: the caller makes them itself. Close it (or use it as a context
    manager) to end the helper.

    The helper is forked from the worker when this object is made, before the worker's
    warm-up (:mod:`.warmup`), and warms up on a throw-away scene of its own while the worker
    does: forked, it has the worker's imports (a spawned one spends about two seconds on
    them), and forked before the warm-up, it shares little memory that the worker then writes
    (each page the worker writes after a fork is copied: the frames' memory the warm-up
    maps would cost the first scene about 0.2 s). Forking is safe here, where the capture's
    workers are spawned: the helper draws nothing and runs no parallel kernel, so it needs
    none of the GL driver's or the kernels' threads, which a fork does not copy; it ends with
    ``os._exit``, running no exit handler of the worker's. A lock that another thread of the
    worker held at the fork stays held in the helper for good: it checks numba's compiler
    lock, which its work takes, and stops at once if it is held (the worker then makes its
    scenes itself); the output folder's lock it closes (:mod:`.manifest`)."""

    def __init__(self, inputs, seed: int, cameras: int, upcoming: Callable[[int], int | None]):
        self._upcoming = upcoming
        self._jobs: dict[int, Future] = {}
        self._meshes: dict[str, Mesh] = {}  # content digest -> the first copy received
        self._pool: ProcessPoolExecutor | None = None
        try:
            self._pool = forked_pool(1, _start, (os.getpid(), inputs, int(seed), int(cameras)))
            self._pool.submit(_warm)  # forks the helper
        except (RuntimeError, OSError) as exc:
            self._broken(exc)

    def submit(self, index: int) -> None:
        """Start making scene ``index``'s parts (nothing if under way, or if the helper died)."""
        if self._pool is None or index in self._jobs:
            return
        try:
            self._jobs[index] = self._pool.submit(_make, int(index))
        except (BrokenProcessPool, RuntimeError, OSError) as exc:
            self._broken(exc)

    def take(self, index: int) -> Parts | None:
        """Scene ``index``'s parts; None if they were not asked for or the helper died."""
        for stale in [i for i in self._jobs if i < index]:  # asked for, then found made: not needed
            self._jobs.pop(stale).cancel()
        nxt = self._upcoming(index)
        if nxt is not None:
            self.submit(nxt)
        job = self._jobs.pop(index, None)
        if job is None:
            return None
        try:
            parts = job.result()
        except BrokenProcessPool as exc:
            self._broken(exc)
            return None
        meshes = parts.scene.meshes
        for key, mesh in meshes.items():
            meshes[key] = self._meshes.setdefault(mesh.digest(), mesh)
        return parts

    def _broken(self, exc: BaseException) -> None:
        log.warning(
            "the helper process making scenes ahead stopped (%s); this worker makes the rest "
            "itself",
            str(exc) or type(exc).__name__,
        )
        self.close()

    def close(self) -> None:
        """End the helper (what it was making is dropped)."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
        self._jobs.clear()

    def __enter__(self) -> "Ahead":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
