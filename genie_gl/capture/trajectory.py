"""A rig along a trajectory: which sensor fires when and where, and its frames, in time order.

Each rig sensor fires at its own rate (:meth:`~genie_gl.sensors.rig.RigSensor.times`) over
the trajectory's span; a *shot* is one such firing, with the body's pose interpolated at its
time and the sensor's pose ``world_from_body(t) @ body_from_sensor``. :func:`record` renders
the shots through ``gg.capture`` (lens, plan, accuracy settings, effects) a window at a time
and yields them in time order (then in the rig's sensor order), so a long recording never
holds more than one window of frames. A shot's noise comes from ``(seed, sensor, window)``
and its place in the window: the same seed gives the same frames, bit for bit.
"""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from ..frame import Frame
from ..sensors.rig import Rig
from ..sensors.trajectory import Trajectory

WINDOW = 48   # shots of one sensor rendered per capture call (a window of the recording)


@dataclass(frozen=True, eq=False)
class Shot:
    """One frame of a recording.

    index : int, place in the recording (time order, then the rig's sensor order);
    time_s : float64 seconds on the trajectory's clock; sensor : int, index into ``rig.sensors``;
    frame : int, the sensor's own frame count; world_from_body, world_from_camera : (4, 4)
    float64 true poses (OpenCV camera frame); distance_m : path length travelled so far.
    """

    index: int
    time_s: float
    sensor: int
    frame: int
    world_from_body: np.ndarray
    world_from_camera: np.ndarray
    distance_m: float


def schedule(rig: Rig, trajectory: Trajectory) -> list[Shot]:
    """Every shot of ``rig`` along ``trajectory``, in time order (then sensor order)."""
    rows = []
    for k, s in enumerate(rig.sensors):
        for j, t in enumerate(s.times(trajectory.start_s, trajectory.end_s)):
            rows.append((float(t), k, j))
    rows.sort()
    if not rows:
        return []
    times = np.array([r[0] for r in rows])
    body = trajectory.at(times)
    dist = trajectory.distance_at(times)
    return [Shot(i, t, k, j, body[i], body[i] @ rig.sensors[k].body_from_sensor, float(dist[i]))
            for i, (t, k, j) in enumerate(rows)]


def window_seed(seed: int, sensor: int, window: int) -> int:
    """The ``gg.capture`` seed of one sensor's shots in one window."""
    return int(np.random.SeedSequence([int(seed), int(sensor), int(window)]).generate_state(1)[0])


def record(scene, rig: Rig, trajectory: Trajectory, *, seed: int, depth_only: bool = False, accuracy=None,
           context=None, shots: list[Shot] | None = None) -> Iterator[tuple[Shot, Frame]]:
    """Yield (shot, frame) for every shot of ``rig`` along ``trajectory`` over ``scene``, in
    time order; each frame's ``meta`` gains ``time_s``, ``rig_sensor`` and ``shot``.

    ``depth_only``, ``accuracy`` and ``context`` are ``gg.capture``'s; ``shots`` a subset of
    :func:`schedule` (default: all).
    """
    from ..render import capture

    shots = schedule(rig, trajectory) if shots is None else shots
    per = max(1, WINDOW)
    start = 0
    window = 0
    while start < len(shots):
        # a window: the next shots up to WINDOW of the busiest sensor
        stop = start
        seen = np.zeros(len(rig), np.int64)
        while stop < len(shots) and seen[shots[stop].sensor] < per:
            seen[shots[stop].sensor] += 1
            stop += 1
        part = shots[start:stop]
        frames: dict[int, Frame] = {}
        for k, s in enumerate(rig.sensors):
            mine = [sh for sh in part if sh.sensor == k]
            if not mine:
                continue
            got = capture(scene, s.sensor, [sh.world_from_camera for sh in mine], seed=window_seed(seed, k, window),
                          workers=1, depth_only=depth_only, accuracy=accuracy, context=context)
            for sh, f in zip(mine, got):
                meta = dict(f.meta or {})
                meta.update(time_s=sh.time_s, rig_sensor=s.name, shot=sh.index)
                frames[sh.index] = f.replace(meta=meta)
        for sh in part:
            yield sh, frames.pop(sh.index)
        start = stop
        window += 1
