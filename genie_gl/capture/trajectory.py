"""A rig along a trajectory: which sensor fires when and where, and its frames, in time order.

Each rig sensor fires at its own rate (:meth:`~genie_gl.motion.rig.RigSensor.times`) over
the trajectory's span; a *shot* is one such firing, with the body's pose interpolated at its
time and the sensor's pose ``world_from_body(t) @ body_from_sensor``. :func:`record` renders
the shots as ``gg.capture`` does (lens, plan, accuracy settings, effects) a window at a time
and yields them in time order (then in the rig's sensor order), so a long recording never
holds more than one window of frames. The scene is uploaded once (one renderer per depth
precision and level of detail the rig's sensors ask for) and each sensor's shots are planned
once, for the whole recording. A shot's noise comes from ``(seed, sensor, window)``
and its place in the window: the same seed gives the same frames, bit for bit.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import ExitStack
from dataclasses import dataclass

import numpy as np

from ..validation.arguments import check_seed, expect
from ..frame import Frame
from ..scene.model import Scene
from ..motion.registration import MID_RANGE_M
from ..motion.rig import Rig
from ..motion.trajectory import Trajectory
from .frames import prepare
from .planner import plan

WINDOW = 48  # shots of one sensor rendered per capture call (a window of the recording)


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
    return [
        Shot(i, t, k, j, body[i], body[i] @ rig.sensors[k].body_from_sensor, float(dist[i]))
        for i, (t, k, j) in enumerate(rows)
    ]


def window_seed(seed: int, sensor: int, window: int) -> int:
    """The ``gg.capture`` seed of one sensor's shots in one window."""
    return int(np.random.SeedSequence([int(seed), int(sensor), int(window)]).generate_state(1)[0])


def record(
    scene,
    rig: Rig,
    trajectory: Trajectory,
    *,
    seed: int,
    depth_only: bool = False,
    accuracy=None,
    context=None,
    shots: list[Shot] | None = None,
    raster: str | None = None,
) -> Iterator[tuple[Shot, Frame]]:
    """Yield (shot, frame) for every shot of ``rig`` along ``trajectory`` over ``scene``, in
    time order; each frame's ``meta`` gains ``time_s``, ``rig_sensor`` and ``shot``.

    ``depth_only``, ``accuracy``, ``context`` and ``raster`` are ``gg.capture``'s; ``shots`` a
    subset of
    :func:`schedule` (default: all). The arguments are checked when it is called, before the
    first frame is asked for.
    """
    expect(scene, Scene, "record: scene")
    expect(rig, Rig, "record: rig")
    expect(trajectory, Trajectory, "record: trajectory")
    seed = check_seed(seed, "record: seed")
    return _recorded(
        scene,
        rig,
        trajectory,
        seed,
        depth_only,
        accuracy,
        context,
        schedule(rig, trajectory) if shots is None else shots,
        raster,
    )


def _recorded(
    scene,
    rig: Rig,
    trajectory: Trajectory,
    seed: int,
    depth_only: bool,
    accuracy,
    context,
    shots: list[Shot],
    raster: str | None = None,
) -> Iterator[tuple[Shot, Frame]]:
    mine = [[sh for sh in shots if sh.sensor == k] for k in range(len(rig))]
    # settled once per sensor for the whole recording: its settings and the plan of all its shots
    prep = [
        prepare(
            scene,
            s.sensor,
            [sh.world_from_camera for sh in mine[k]],
            accuracy=accuracy,
            raster=raster,
        )
        if mine[k]
        else None
        for k, s in enumerate(rig.sensors)
    ]
    done = [0] * len(rig)  # each sensor's shots rendered so far
    with ExitStack() as stack:
        # one per renderer key (depth precision, level of detail): the scene uploaded once
        renderers: dict = {}
        start = window = 0
        while start < len(shots):
            # a window: the next shots up to WINDOW of the busiest sensor
            stop = start
            seen = np.zeros(len(rig), np.int64)
            while stop < len(shots) and seen[shots[stop].sensor] < WINDOW:
                seen[shots[stop].sensor] += 1
                stop += 1
            frames: dict[int, Frame] = {}
            for k, s in enumerate(rig.sensors):
                if not seen[k]:
                    continue
                p = prep[k]
                if p.renderer_key not in renderers:
                    renderers[p.renderer_key] = stack.enter_context(
                        p.renderer(scene, context=context)
                    )
                part = p.part(done[k], done[k] + int(seen[k]))
                got = part.frames(
                    renderers[p.renderer_key], window_seed(seed, k, window), depth_only
                )
                for sh, f in zip(mine[k][done[k] : done[k] + int(seen[k])], got):
                    meta = dict(f.meta or {})
                    meta.update(time_s=sh.time_s, rig_sensor=s.name, shot=sh.index)
                    frames[sh.index] = f.replace(meta=meta)
                done[k] += int(seen[k])
            for sh in shots[start:stop]:
                yield sh, frames.pop(sh.index)
            start = stop
            window += 1


@dataclass(frozen=True, eq=False)
class RecordingPlan:
    """The plan of a recording: per rig sensor, the per-frame :class:`~genie_gl.Plan` of its
    shots (what each effect does, what is culled, the predicted cost) and, for a mobile-scan
    map, the registration error predicted at each shot (m at mid range; None: no model)."""

    shots: list
    plans: dict
    registration_sigma_m: np.ndarray | None = None

    @property
    def predicted_s(self) -> float:
        return sum(p.predicted_s for p in self.plans.values())

    def summary(self) -> str:
        lines = [
            f"recording: {len(self.shots)} shots of {len(self.plans)} sensors; predicted "
            f"{self.predicted_s:.2f} s"
        ]
        for name, p in self.plans.items():
            lines += ["  " + line for line in f"[{name}] {p.summary()}".splitlines()]
        if self.registration_sigma_m is not None and len(self.registration_sigma_m):
            s = self.registration_sigma_m
            lines.append(
                f"  registration error (predicted, at 3 m range): {1e3 * s[0]:.1f} mm at the "
                "start, "
                f"{1e3 * s[-1]:.1f} mm after {self.shots[-1].distance_m:.0f} m"
            )
        return "\n".join(lines)

    def to_dict(self) -> dict:
        out = {
            "shots": len(self.shots),
            "predicted_s": round(self.predicted_s, 3),
            "sensors": {k: p.to_dict() for k, p in self.plans.items()},
            "times_s": [round(s.time_s, 6) for s in self.shots],
        }
        if self.registration_sigma_m is not None:
            out["registration_sigma_m"] = [round(float(v), 6) for v in self.registration_sigma_m]
        return out


def plan_recording(scene, rig: Rig, trajectory: Trajectory, *, registration=None) -> RecordingPlan:
    """What recording ``rig`` along ``trajectory`` will do, frame by frame, before rendering:
    ``gg.plan`` of each sensor's shots, and ``registration`` (a
    :class:`~genie_gl.motion.registration.RegistrationError`) predicted at each shot."""
    shots = schedule(rig, trajectory)
    plans = {}
    for k, s in enumerate(rig.sensors):
        poses = [sh.world_from_camera for sh in shots if sh.sensor == k]
        if poses:
            plans[s.name] = plan(scene, s.sensor, poses)
    sigma = None
    if registration is not None:
        sigma = registration.sigma_m(np.array([sh.distance_m for sh in shots]), MID_RANGE_M)
    return RecordingPlan(shots, plans, sigma)
