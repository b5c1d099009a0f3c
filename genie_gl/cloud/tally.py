"""Pass 1 of :func:`~genie_gl.cloud.process.frame_chunks`: each frame's points counted per
tile, its runs of pixels per tile kept (:mod:`.tile_runs`), frame by frame.

A frame's count depends on that frame alone (and on the cloud's origin and the tile size),
so it can start as soon as the frame is made: :class:`FrameTally` counts frames on a thread
of its own while the capture renders the next ones (``genie dataset`` hands it each frame
as the capture makes it), and :func:`frame_chunks` takes its counts when they are of the
same frames, origin and tile size. The kernels release the GIL; the counts are integers
summed in frame order, so they are the same on any number of threads.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Sequence
from concurrent.futures import Future, ThreadPoolExecutor

import numba
import numpy as np

from ..frame import Frame
from . import kernels
from .tile_runs import RUNNERS
from .unproject import _pose_rows, rays

WINDOW = 129  # a camera's points are counted in this many tiles a side around it first
RUN_ROOM = 4  # a frame's runs are kept up to one run per this many pixels (more: none kept)
MAX_TILES = 50_000_000  # a tile grid larger than this is a mistake (chunks far too small)

#: what pass 1 finds in a frame: (its runs as (i0, j0, runs) or None, i0, j0, counts)
Tally = tuple[tuple[int, int, np.ndarray] | None, int, int, np.ndarray]


def frame_inputs(f: Frame, origin: np.ndarray) -> tuple:
    """What both passes read of frame ``f``: its depth, ray tables, pose rows relative to
    ``origin`` and the kernels for its kind of ray table."""
    tx, ty = rays(f.sensor)
    separable = tx.shape[0] == 1
    return (
        np.ascontiguousarray(f.depth, np.float32),
        tx,
        ty,
        _pose_rows(f, origin),
        kernels.TILERS[separable],
        RUNNERS[separable],
    )


def too_small(size_m: float, extent_x_m: float, extent_y_m: float) -> ValueError:
    return ValueError(
        f"frame_chunks: tiles of {size_m} m are too small for the frames' extent "
        f"({extent_x_m:.0f} x {extent_y_m:.0f} m)"
    )


def tally_frame(f: Frame, args: tuple, origin: np.ndarray, size: float, room: np.ndarray) -> Tally:
    """Frame ``f``'s points per tile of ``size`` m: counted in the window of tiles around its
    camera, its runs written to ``room`` and copied out (None: it reached beyond the window,
    or had more runs than ``room`` holds; then counted over its exact extent)."""
    depth, tx, ty, M, (count, _, extent), (count_runs, _) = args
    i0, j0 = (np.floor((f.world_from_camera[:2, 3] - origin[:2]) / size)).astype(
        np.int64
    ) - WINDOW // 2
    counts = np.zeros((WINDOW, WINDOW), np.int64)
    outside, n_runs = count_runs(depth, tx, ty, M, size, i0, j0, counts, room)
    window = (int(i0), int(j0), room[:n_runs].copy()) if n_runs >= 0 and not outside else None
    if outside:  # points beyond the window: the exact extent
        i0, i1, j0, j1 = extent(depth, tx, ty, M, size)
        if (i1 - i0 + 1) * (j1 - j0 + 1) > MAX_TILES:
            raise too_small(size, (i1 - i0 + 1) * size, (j1 - j0 + 1) * size)
        counts = np.zeros((i1 - i0 + 1, j1 - j0 + 1), np.int64)
        count(depth, tx, ty, M, size, i0, j0, counts)
    return window, int(i0), int(j0), counts


def room_for(pixels: int) -> np.ndarray:
    """Room for the runs of a frame of ``pixels`` pixels."""
    return np.empty((pixels // RUN_ROOM + 1, 4), np.int32)


def tally_frames(
    frames: Sequence[Frame],
    inputs: Sequence[tuple],
    origin: np.ndarray,
    size: float,
    threads: int = 1,
) -> list[Tally]:
    """:func:`tally_frame` of every frame, on ``threads`` threads (each with its own room)."""
    pixels = max(f.depth.size for f in frames)
    threads = max(1, min(len(frames), int(threads)))
    if threads == 1:
        room = room_for(pixels)
        return [tally_frame(f, args, origin, size, room) for f, args in zip(frames, inputs)]
    local = threading.local()

    def one(f: Frame, args: tuple) -> Tally:
        room = getattr(local, "room", None)
        if room is None or len(room) < pixels // RUN_ROOM + 1:
            room = local.room = room_for(pixels)
        return tally_frame(f, args, origin, size, room)

    with ThreadPoolExecutor(threads) as pool:
        return list(pool.map(one, frames, inputs))


#: the interpreter's switch interval while a FrameTally counts: the drawing thread, back from
#: each compiled call that let the GIL go (culling, unpacking), waits at most this long for
#: it instead of the default 5 ms (``python docs/pipeline_parts.py``: with 5 ms the culling's
#: first kernel takes ~0.5 ms a frame against 0.02-0.04 ms, a dataset scene ~5 % longer)
SWITCH_INTERVAL_S = 0.0005
_switch = {"tallies": 0, "saved": None}
_switch_lock = threading.Lock()


def _hold_switch_interval(on: bool) -> None:
    """Count a tally in (``on``) or out; the first in sets :data:`SWITCH_INTERVAL_S` (if
    shorter than the interval in force), the last out puts the interval back."""
    with _switch_lock:
        if on:
            if _switch["tallies"] == 0:
                _switch["saved"] = sys.getswitchinterval()
                sys.setswitchinterval(min(_switch["saved"], SWITCH_INTERVAL_S))
            _switch["tallies"] += 1
        else:
            _switch["tallies"] -= 1
            if _switch["tallies"] == 0:
                sys.setswitchinterval(_switch["saved"])


def spare_core() -> bool:
    """Whether this process may use more than one core (numba's thread count, which
    :func:`~genie_gl.render.limit_threads` sets from the workers of a run): only then does
    counting frames on a thread beside the capture gain anything."""
    return numba.get_num_threads() > 1


class FrameTally:
    """Pass 1 of :func:`~genie_gl.cloud.process.frame_chunks` for frames handed to
    :meth:`add` as they are made, counted in order on a thread of this object's. While it
    counts (until :meth:`close`), the interpreter's switch interval is
    :data:`SWITCH_INTERVAL_S`. With ``inline``, each frame is counted by :meth:`add` itself,
    on the caller's thread, and the interval is left alone: for a capture whose frames other
    threads draw while the caller waits for them (the CPU raster's side by side frames), so
    the counting takes the caller's idle time instead of a third thread's turns.

    Parameters
    ----------
    size_m : the tile size the chunks will be cut with.
    origin : (3,) the cloud's origin (:func:`~genie_gl.cloud.process.origin_of` of the
        capture's poses: ``frame_chunks`` takes the counts only if its origin is this one).
    inline : count on the thread that calls :meth:`add` (no thread of its own).
    """

    def __init__(self, size_m: float, origin: np.ndarray, inline: bool = False) -> None:
        self.size = float(size_m)
        self.origin = np.asarray(origin, np.float64)
        self.frames: list[Frame] = []
        self._inputs: list[tuple] = []
        self._futures: list[Future] = []
        self._inline = bool(inline)
        self._open = True
        self._pool: ThreadPoolExecutor | None = (
            None if self._inline else ThreadPoolExecutor(1, thread_name_prefix="frame-tally")
        )
        self._room: np.ndarray | None = None
        if not self._inline:
            _hold_switch_interval(True)

    @property
    def inline(self) -> bool:
        """Whether frames are counted by :meth:`add` itself, on the caller's thread."""
        return self._inline

    def add(self, frame: Frame) -> None:
        """Start counting ``frame`` (the next frame of the capture); with ``inline``, count
        it now, on the calling thread (a capture whose frames are drawn by other threads
        while the caller waits: the CPU raster's)."""
        if not self._open:
            raise RuntimeError("FrameTally.add: the tally is closed")
        args = frame_inputs(frame, self.origin)
        self.frames.append(frame)
        self._inputs.append(args)
        if self._inline:
            done: Future = Future()
            try:
                done.set_result(self._count(frame, args))
            except Exception as e:  # (raised where the counts are taken, as from the thread)
                done.set_exception(e)
            self._futures.append(done)
            return
        assert self._pool is not None
        self._futures.append(self._pool.submit(self._count, frame, args))

    def _count(self, frame: Frame, args: tuple) -> Tally:
        if self._room is None or len(self._room) < frame.depth.size // RUN_ROOM + 1:
            self._room = room_for(frame.depth.size)
        return tally_frame(frame, args, self.origin, self.size, self._room)

    def matches(self, frames: Sequence[Frame], origin: np.ndarray, size: float) -> bool:
        """Whether these counts are of ``frames`` (the same objects, in order), ``origin`` and
        tile size ``size``."""
        return (
            float(size) == self.size
            and np.array_equal(np.asarray(origin, np.float64), self.origin)
            and len(frames) == len(self.frames)
            and all(a is b for a, b in zip(frames, self.frames))
        )

    def results(self) -> tuple[list[tuple], list[Tally]]:
        """(every frame's inputs, every frame's counts), once all are counted; closes the tally."""
        try:
            return self._inputs, [f.result() for f in self._futures]
        finally:
            self.close()

    def close(self) -> None:
        """Stop the thread (counts not yet made are dropped)."""
        if not self._open:
            return
        self._open = False
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
            _hold_switch_interval(False)

    def __enter__(self) -> "FrameTally":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
