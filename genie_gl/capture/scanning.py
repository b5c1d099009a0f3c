"""``gg.scan``: a scanner or a scanner rig along a trajectory (or standing still), scan by scan.

Each head scans whole revolutions from its ``offset_s`` after the trajectory's start until
the trajectory ends; each firing of each scan fires from the head's pose at the firing's
time, ``world_from_body(t) @ body_from_scanner`` (the trajectory interpolated: positions
linearly, rotations by slerp), so the scans carry the motion skew of a spinning head.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
from collections import deque
from collections.abc import Iterator
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np

from ..errors import ConfigError
from ..processes import die_with_parent, forked_pool
from ..scene.materials import MaterialTable
from ..scene.model import Scene
from ..sensors.beams import scan_beams, scan_starts
from ..sensors.scanner import Scanner
from ..motion.scanner_rig import ScannerRig
from ..motion.trajectory import Trajectory
from .scan import plan_scan, take_scan
from .scan_record import Scan

AHEAD = 4  # scans per worker made ahead of the one taken (bounds the memory they hold)


def scan_rng(seed: int, head_index: int, scan_index: int) -> np.random.Generator:
    """The generator of one scan: from (seed, head, scan), independent of the others."""
    return np.random.default_rng(
        np.random.SeedSequence([int(seed), int(head_index), int(scan_index)])
    )


def iter_scans(
    scene: Scene,
    rig: ScannerRig,
    trajectory: Trajectory | np.ndarray,
    *,
    seed: int,
    duration_s: float | None = None,
    scans: int | None = None,
    workers: int = 1,
) -> Iterator[Scan]:
    """Scans of every head of ``rig``, head by head, in time order.

    ``trajectory``: a :class:`Trajectory`, or a fixed (4, 4) world_from_body (then ``scans``
    revolutions per head, default 1). ``duration_s`` crops a trajectory. ``workers`` > 1
    makes the scans in that many processes (:func:`_in_workers`); the scans are the same,
    byte for byte, with any number."""
    table = MaterialTable.from_scene(scene)
    fixed = not isinstance(trajectory, Trajectory)
    if fixed:
        body = np.asarray(trajectory, np.float64)
        if body.shape != (4, 4) or not np.all(np.isfinite(body)):
            raise ConfigError(
                f"scan: expected a Trajectory or a (4, 4) world_from_body, got shape {body.shape}"
            )
        t0 = 0.0
    else:
        t0 = trajectory.start_s
        end = (
            trajectory.end_s
            if duration_s is None
            else min(trajectory.end_s, t0 + float(duration_s))
        )
    if int(workers) < 1:
        raise ConfigError(f"scan: workers must be at least 1, got {workers}")
    jobs: list[_Job] = []
    for k, head in enumerate(rig.heads):
        scanner = head.scanner
        plan = plan_scan(scene, scanner, table)
        if fixed:
            starts = (
                t0
                + head.offset_s
                + np.arange(1 if scans is None else int(scans)) * scanner.scan_period_s
            )
            pose_at = body @ head.body_from_scanner
        else:
            starts = scan_starts(scanner, t0, end, head.offset_s)
            if scans is not None:
                starts = starts[: int(scans)]
            pose_at = _pose_at(trajectory, head.body_from_scanner)
        jobs += [
            _Job(k, i, float(start), t0 + head.offset_s, pose_at, plan)
            for i, start in enumerate(starts)
        ]
    make = _Maker(scene, rig, table, int(seed))
    if int(workers) == 1 or len(jobs) < 3 or "fork" not in mp.get_all_start_methods():
        for job in jobs:
            yield make(job)
        return
    yield make(jobs[0])  # here: compiles the kernels and builds the engine's hierarchy once
    yield from _in_workers(make, jobs[1:], min(int(workers), len(jobs) - 1))


@dataclass(frozen=True)
class _Job:
    """One scan to make: head ``head`` (its index in the rig), scan ``index``, starting at
    ``start_s``, its clock from ``clock_s``, the head's pose (a (4, 4) or a function of
    times) and the scene's plan of the head's effects."""

    head: int
    index: int
    start_s: float
    clock_s: float
    pose_at: Any
    plan: dict


@dataclass(frozen=True)
class _Maker:
    """What every scan of one call shares; called with a :class:`_Job`, makes its scan."""

    scene: Scene
    rig: ScannerRig
    table: MaterialTable
    seed: int

    def __call__(self, job: _Job) -> Scan:
        head = self.rig.heads[job.head]
        beams = scan_beams(
            head.scanner, job.pose_at, job.start_s, index=job.index, clock_start_s=job.clock_s
        )
        return take_scan(
            self.scene,
            head.scanner,
            beams,
            rng=scan_rng(self.seed, job.head, job.index),
            table=self.table,
            plan=job.plan,
            head=head.name,
            head_index=job.head,
        )


_forked: dict[int, tuple[_Maker, list[_Job]]] = {}  # what forked workers find: call -> work


def _start_worker(parent: int) -> None:
    die_with_parent(parent)
    # Ctrl-C and SIGTERM reach the whole process group: the caller unwinds and ends the pool
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    numba.set_num_threads(1)  # a core per worker: the workers are the parallelism


def _run(key: int, i: int) -> Scan:
    make, jobs = _forked[key]
    return make(jobs[i])


def _in_workers(make: _Maker, jobs: list[_Job], workers: int) -> Iterator[Scan]:
    """The scans of ``jobs`` made in ``workers`` forked processes, in order, at most
    :data:`AHEAD` per worker made ahead of the one taken. Forked, a worker has the scene, its
    engine (hierarchy, clusters) and the compiled kernels of this process without copying
    them; each runs its kernels on one thread. A worker that dies is one error naming it."""
    key = id(jobs)
    _forked[key] = (make, jobs)
    try:
        pool = forked_pool(workers, _start_worker, (os.getpid(),))
        with pool:
            todo: deque = deque()
            nxt = 0
            for _ in range(len(jobs)):
                while nxt < len(jobs) and len(todo) < AHEAD * workers:
                    todo.append(pool.submit(_run, key, nxt))
                    nxt += 1
                try:
                    yield todo.popleft().result()
                except BrokenProcessPool as exc:
                    raise ConfigError(
                        f"scan: a worker process died making the scans ({exc}); try --workers 1"
                    ) from exc
    finally:
        _forked.pop(key, None)


def _pose_at(trajectory: Trajectory, body_from_scanner: np.ndarray):
    def pose_at(times: np.ndarray) -> np.ndarray:
        t = np.clip(times, trajectory.start_s, trajectory.end_s)
        return trajectory.at(t, then=body_from_scanner)

    return pose_at


def scan(
    scene: Scene,
    scanner_or_rig: Scanner | ScannerRig,
    trajectory: Trajectory | np.ndarray | None = None,
    *,
    seed: int = 0,
    duration_s: float | None = None,
    scans: int | None = None,
    workers: int = 1,
) -> list[Scan]:
    """Scans of a scanner (or every head of a rig) in ``scene``.

    Parameters
    ----------
    scene : the scene.
    scanner_or_rig : a :class:`Scanner` (one head at the body's origin) or a :class:`ScannerRig`.
    trajectory : a :class:`Trajectory` (scans until it ends, or ``duration_s``), a fixed (4, 4)
        world_from_body (``scans`` revolutions, default 1), or None (the identity pose).
    seed : int, the seed of every random draw (each scan its own stream).
    workers : int, processes making the scans (forked; each runs its kernels on one thread).
        The scans are the same, byte for byte, with any number; on 2 cores 2 make a walk
        1.3-1.5 times as fast as 1 (``docs/lidar.md``).

    Returns
    -------
    list[Scan], head by head, each head's scans in time order; an empty result is an error.
    """
    rig = (
        scanner_or_rig
        if isinstance(scanner_or_rig, ScannerRig)
        else ScannerRig.single(scanner_or_rig)
    )
    if not isinstance(rig, ScannerRig):
        raise ConfigError(
            f"scan: expected a Scanner or a ScannerRig, got {type(scanner_or_rig).__name__}"
        )
    out = list(
        iter_scans(
            scene,
            rig,
            np.eye(4) if trajectory is None else trajectory,
            seed=seed,
            duration_s=duration_s,
            scans=scans,
            workers=workers,
        )
    )
    if not out:
        raise ConfigError(
            "scan: the trajectory is shorter than one revolution of every head; no scan was made"
        )
    return out
