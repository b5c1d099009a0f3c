"""What the modes of cameras that move share: a rig carried along a trajectory.

For each scene: a trajectory on its free floor (``--path``, ``--motion``, ``--duration-s``;
the scene's own ``trajectory`` stream), the rig (``--rig``, or ``--sensor`` alone on a body
at 10 Hz) recorded along it (:func:`genie_gl.capture.trajectory.record`, a window of frames
at a time, never the whole recording in memory), and a :class:`Tally` of what streams past.
Every scene folder also gets ``trajectory.txt``: the body's poses in TUM's
``t x y z qx qy qz qw`` (``evo`` reads it). What the recording becomes is the subclass's:
:mod:`.recording` hands it to a sequence writer, :mod:`.mobile_map` fuses it into a map.

A new rig (a spinning scanner, a panorama head) is a rig file: :func:`rig_of` loads it and
:func:`~genie_gl.capture.trajectory.record` fires its sensors; a rig that needs another kind
of capture is a mode of its own, registered beside these (:mod:`.base`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...capture.costs import add_totals, effect_totals, frame_costs
from ...capture.trajectory import WINDOW, record
from ...export import get_format
from ...layout.estimate import layout_estimate
from ...limits import BYTES_PER_NODE, BYTES_PER_PIXEL
from ...outputs import atomic_write_text
from ...render import shared_context
from ...errors import ConfigError
from ...resources import resolve
from ...effects.profile import load_sensor
from ...motion.paths import PATHS, make_trajectory, path_kind, read_waypoints
from ...motion.rig import Rig, load_rig
from ...motion.scanner_rig import scanner_rig_file
from ...motion.trajectory import quaternion_xyzw
from ..previews import write_recording_previews
from ..recipe import make_scene
from .base import Captured, CaptureMode, Estimate, stamp

SINGLE_RATE_HZ = 10.0  # --sensor alone: its frame rate on the body ...
SINGLE_PITCH_RAD = np.radians(10.0)  # ... tilted this far down
PREVIEW_FRAMES = 2
TRAJECTORY_FILE = "trajectory.txt"


def rig_of(cfg) -> Rig:
    """The rig of a run: ``--rig``, or ``--sensor`` alone on the body."""
    if cfg.rig:
        return load_rig(cfg.rig)
    return Rig.single(
        load_sensor(cfg.sensor), rate_hz=SINGLE_RATE_HZ, pitch_rad=float(SINGLE_PITCH_RAD)
    )


def trajectory_of(cfg, layout, scene, *, seed: int):
    kind = cfg.path if cfg.path in PATHS[:2] else "waypoints"
    return make_trajectory(
        layout,
        scene,
        kind,
        seed=seed,
        motion=cfg.motion,
        waypoints=cfg.path if kind == "waypoints" else None,
        duration_s=cfg.duration_s,
    )


def write_trajectory(trajectory, path: Path) -> None:
    """The body's poses as TUM's ``timestamp tx ty tz qx qy qz qw`` lines."""
    rows = []
    for t, T in zip(trajectory.times_s, trajectory.world_from_body):
        q = quaternion_xyzw(T[:3, :3])
        rows.append(f"{t:.6f} " + " ".join(f"{v:.9f}" for v in (*T[:3, 3], *q)))
    atomic_write_text(
        path,
        "# body (REP 103) in the world: timestamp tx ty tz qx qy qz qw\n"
        + "".join(r + "\n" for r in rows),
    )


@dataclass
class Tally:
    """Points per class, frames, and what every frame cost and what its effects did (the
    manifest's ``cost`` and ``effects``), counted as a recording streams past; ``seconds``:
    the time spent making the frames (rendering), apart from the time of whoever reads them."""

    counts: np.ndarray = field(default_factory=lambda: np.zeros(65536, np.int64))
    points: int = 0
    shots: int = 0
    preview: list = field(default_factory=list)
    cost_ms: dict = field(default_factory=dict)
    effects: dict = field(default_factory=dict)
    seconds: float = 0.0

    def watch(self, recording) -> Iterator:
        it = iter(recording)
        while True:
            t = time.perf_counter()
            try:
                shot, frame = next(it)
            except StopIteration:
                self.seconds += time.perf_counter() - t
                return
            ok = frame.depth > 0
            self.points += int(ok.sum())
            self.counts += np.bincount(frame.semantic[ok].ravel(), minlength=len(self.counts))
            self.shots += 1
            for k, v in frame_costs([frame]).items():
                self.cost_ms[k] = self.cost_ms.get(k, 0.0) + v
            add_totals(self.effects, effect_totals([frame]))
            if len(self.preview) < PREVIEW_FRAMES:
                self.preview.append(frame)
            self.seconds += time.perf_counter() - t
            yield shot, frame


@dataclass(eq=False)
class Ride:
    """A scene's rig, trajectory and recording stream (drawn from its streams)."""

    layout: Any
    scene: Any
    clock: dict[str, float]
    rig: Rig
    trajectory: Any
    tally: Tally
    stream: Iterator
    raster: str | None = (
        None  # the dataset's rasteriser (genie_gl.render.rasters), for the previews too
    )


class RigOnPath(CaptureMode):
    """A rig recorded along a trajectory; subclasses say what the recording becomes."""

    options: tuple[str, ...] = ("rig", "path", "motion", "duration_s")
    files = (TRAJECTORY_FILE,)

    def check(self, cfg) -> None:
        path_kind(cfg.path)
        if scanner_rig_file(cfg.rig) is not None:
            raise ConfigError(
                f"--rig {cfg.rig}: a scanner rig; its capture is --capture scans (its raw scans) "
                "or "
                f"scan-map (a map fused from them), not --capture {cfg.capture}"
            )

    def prepare(self, cfg, inputs) -> None:
        if path_kind(cfg.path) == "waypoints":
            read_waypoints(cfg.path)  # a bad waypoints file is refused before any work

    def input_files(self, cfg) -> dict[str, str]:
        """The rig's file and its sensors' files, the waypoints file."""
        files: dict[str, str] = {}
        if cfg.rig:
            files["rig"] = str(resolve(cfg.rig, "rigs", (".yaml", ".yml")))
            for s in rig_of(cfg).sensors:
                for key in ("profile", "calibration"):
                    if getattr(s.sensor, key):
                        files[f"rig {s.name} {key}"] = str(getattr(s.sensor, key))
        if Path(cfg.path).is_file():
            files["waypoints"] = cfg.path
        return files

    # -- the estimate: frames are --duration-s times the rig's summed rates; a worker holds
    # one window of them (WINDOW shots) and what the subclass adds (:meth:`held_bytes`)
    def held_bytes(self, cfg, strategy) -> tuple[float, str]:
        """Memory a worker holds besides the window of frames and the layout, and its words."""
        return 0.0, ""

    def written_points(self, cfg, strategy, frames: float, pixels: int) -> float:
        return frames * pixels

    def estimate(self, cfg, strategy, sensor) -> Estimate:
        nodes, work = layout_estimate(strategy)
        rig = rig_of(cfg)
        frames = cfg.duration_s * sum(s.rate_hz for s in rig.sensors)
        pixels = max(int(s.sensor.width) * int(s.sensor.height) for s in rig.sensors)
        held, held_what = self.held_bytes(cfg, strategy)
        per_worker = WINDOW * pixels * BYTES_PER_PIXEL + nodes * BYTES_PER_NODE + held
        points = self.written_points(cfg, strategy, frames, pixels)
        disk = cfg.scenes * get_format(cfg.format).scene_bytes(points, frames * pixels)
        workers = min(cfg.workers, cfg.scenes)
        what = (
            f"{workers} workers x a window of {WINDOW} frames of the rig + {nodes:.3g} regions"
            + held_what
        )
        return Estimate(
            nodes,
            work,
            pixels,
            int(per_worker * workers),
            int(disk),
            what,
            self.memory_fix,
            self.disk_fix,
        )

    memory_fix = "use fewer --workers"
    disk_fix = "make fewer --scenes"

    def ride(self, cfg, inputs, streams, fmt, accuracy, *, stage: Callable[[str], None]) -> Ride:
        """The layout, scene, trajectory and the rig's recording along it, streaming."""
        layout, scene, clock = make_scene(inputs, streams, stage=stage)
        stage("placement")
        rig = rig_of(cfg)
        trajectory = trajectory_of(cfg, layout, scene, seed=streams.trajectory_seed)
        stamp(clock, "placement")
        stage("capture")
        tally = Tally()
        stream = tally.watch(
            record(
                scene,
                rig,
                trajectory,
                seed=streams.capture_seed,
                depth_only=not fmt.colour,
                accuracy=accuracy,
                context=shared_context() if cfg.raster == "gl" else None,
                raster=cfg.raster,
            )
        )
        stamp(
            clock, "capture"
        )  # the recording's set-up (and its first window); the rest as it streams
        return Ride(layout, scene, clock, rig, trajectory, tally, stream, cfg.raster)

    def captured(self, ride: Ride, *, map_cloud=None, **fields) -> Captured:
        """The tail's record of ``ride`` (``fields``: the subclass's)."""
        tr, tally = ride.trajectory, ride.tally
        info = {
            "instances": len(ride.scene.instances),
            "trajectory": {
                "path": tr.meta.get("path"),
                "length_m": round(tr.length_m, 3),
                "duration_s": round(tr.duration_s, 3),
                "shots": tally.shots,
                "rig": ride.rig.name,
                "sensors": [s.name for s in ride.rig.sensors],
            },
        }
        return Captured(
            ride.layout,
            ride.scene,
            ride.clock,
            info=info,
            rig=ride.rig,
            trajectory=tr,
            tally=tally,
            costs=lambda: (dict(tally.cost_ms), tally.effects),
            previews=lambda folder, i: write_recording_previews(
                folder, i, ride.layout, tally.preview, tr, map_cloud, ride.scene, ride.raster
            ),
            **fields,
        )

    def write(self, fmt, data, folder: Path, got: Captured) -> None:
        self.write_recording(fmt, data, folder, got)
        write_trajectory(got.trajectory, folder / TRAJECTORY_FILE)

    def write_recording(self, fmt, data, folder: Path, got: Captured) -> None:
        fmt.write_scene(data, folder)
