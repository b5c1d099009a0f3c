"""Dataset scenes captured by cameras that move (``genie dataset --capture trajectory|mobile-map``).

For each scene: a trajectory on its free floor (``--path``, ``--motion``, ``--duration-s``;
the scene's own ``trajectory`` generator), the rig (``--rig``, or ``--sensor`` alone on a
body at 10 Hz) recorded along it, then

- ``trajectory``: the recording, streamed into the format's sequence writer (SemanticKITTI
  sequences, TUM RGB-D, a ROS 2 bag, E57), never held whole in memory;
- ``mobile-map``: the recording with a mobile scanner's registration error
  (``--registration``) fused into one map (``--voxel-m``) and cut into ``--chunk-m`` chunks of
  ``--points`` points, cleaned as static chunks are, and written in any point-cloud format.

Every scene folder also gets ``trajectory.txt``: the body's poses in TUM's
``t x y z qx qy qz qw`` (``evo`` reads it).
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..capture.costs import add_totals, effect_totals, frame_costs
from ..capture.mobile_map import registration_rng, with_registration
from ..capture.trajectory import record
from ..cloud import chunks, keep_cloud
from ..cloud.fusion import fuse
from ..outputs import atomic_write_text
from ..render import shared_context
from ..resources import resolve
from ..sensors import load_sensor
from ..sensors.paths import PATHS, make_trajectory
from ..sensors.registration import registration_of
from ..sensors.rig import Rig, load_rig
from ..sensors.trajectory import quaternion_xyzw
from .config import DatasetConfig
from .streams import SceneStreams

log = logging.getLogger(__name__)

SINGLE_RATE_HZ = 10.0         # --sensor alone: its frame rate on the body ...
SINGLE_PITCH_RAD = np.radians(10.0)   # ... tilted this far down
PREVIEW_FRAMES = 2


def rig_of(cfg: DatasetConfig):
    """The rig of a run: ``--rig``, or ``--sensor`` alone on the body."""
    if cfg.rig:
        return load_rig(cfg.rig)
    return Rig.single(load_sensor(cfg.sensor), rate_hz=SINGLE_RATE_HZ, pitch_rad=float(SINGLE_PITCH_RAD))


def recording_files(cfg: DatasetConfig) -> dict[str, str]:
    """Role -> path of the files a moving capture reads (rig, its sensors' files, waypoints)."""
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


def trajectory_of(cfg: DatasetConfig, layout, scene, *, seed: int):
    kind = cfg.path if cfg.path in PATHS[:2] else "waypoints"
    return make_trajectory(layout, scene, kind, seed=seed, motion=cfg.motion,
                           waypoints=cfg.path if kind == "waypoints" else None, duration_s=cfg.duration_s)


def write_trajectory(trajectory, path: Path) -> None:
    rows = []
    for t, T in zip(trajectory.times_s, trajectory.world_from_body):
        q = quaternion_xyzw(T[:3, :3])
        rows.append(f"{t:.6f} " + " ".join(f"{v:.9f}" for v in (*T[:3, 3], *q)))
    atomic_write_text(path, "# body (REP 103) in the world: timestamp tx ty tz qx qy qz qw\n"
                      + "".join(r + "\n" for r in rows))


@dataclass
class Tally:
    """Points per class, frames, and what every frame cost and what its effects did (the
    manifest's ``cost`` and ``effects``), counted as a recording streams past."""

    counts: np.ndarray = field(default_factory=lambda: np.zeros(65536, np.int64))
    points: int = 0
    shots: int = 0
    preview: list = field(default_factory=list)
    cost_ms: dict = field(default_factory=dict)
    effects: dict = field(default_factory=dict)

    def watch(self, recording):
        for shot, frame in recording:
            ok = frame.depth > 0
            self.points += int(ok.sum())
            self.counts += np.bincount(frame.semantic[ok].ravel(), minlength=len(self.counts))
            self.shots += 1
            for k, v in frame_costs([frame]).items():
                self.cost_ms[k] = self.cost_ms.get(k, 0.0) + v
            add_totals(self.effects, effect_totals([frame]))
            if len(self.preview) < PREVIEW_FRAMES:
                self.preview.append(frame)
            yield shot, frame


@dataclass
class Moving:
    """What a moving capture hands the export stage."""

    rig: Any
    trajectory: Any
    tally: Tally
    recording: Any = None        # trajectory: the (Shot, Frame) stream, consumed by the writer
    kept: list = field(default_factory=list)       # mobile-map: the cleaned chunks
    map_cloud: Any = None
    extra: dict = field(default_factory=dict)


def capture_moving(cfg: DatasetConfig, layout, scene, streams: SceneStreams, fmt, accuracy,
                   stage, t: dict[str, float]) -> Moving:
    """The trajectory and the recording (trajectory) or the fused map's chunks (mobile-map),
    drawn from the scene's ``streams`` (trajectory, capture, cloud)."""
    stage("placement")
    rig = rig_of(cfg)
    trajectory = trajectory_of(cfg, layout, scene, seed=streams.trajectory_seed)
    t["placement"] = time.perf_counter()
    stage("capture")
    seed = streams.capture_seed
    tally = Tally()
    stream = tally.watch(record(scene, rig, trajectory, seed=seed, depth_only=not fmt.colour, accuracy=accuracy,
                                context=shared_context() if cfg.raster == "gl" else None, raster=cfg.raster))
    if cfg.capture == "trajectory":
        t["capture"] = t["cloud"] = time.perf_counter()   # rendered as the writer reads it (export)
        return Moving(rig, trajectory, tally, recording=stream)
    b = scene.bounds()
    b[0] -= 0.5
    b[1] += 0.5
    moved = with_registration(stream, trajectory, registration_of(cfg.registration), rng=registration_rng(seed))
    times: list[float] = []

    def frames():
        for shot, frame in moved:
            times.append(shot.time_s)
            yield frame

    cloud = fuse(frames(), bounds=b, voxel_m=cfg.voxel_m)
    t["capture"] = time.perf_counter()
    stage("cloud")
    kept = []
    tally.counts[:] = 0
    for key, tile in chunks(cloud, cfg.chunk_m, min_points=1, max_points=cfg.points, rng=streams.rng("cloud")):
        if keep_cloud(tile, min_points=cfg.min_points, min_labelled_share=cfg.min_labelled_share)[0]:
            kept.append((key, tile))
            np.add.at(tally.counts, tile.semantic, 1)
    if not kept:   # as for standing cameras: the scene is written without chunks, and said so
        log.warning("a mobile-scan map of %d points gave no chunk of %d+ points with a %g labelled share "
                    "(a longer --duration-s sees more)", len(cloud), cfg.min_points, cfg.min_labelled_share)
    tally.points = len(cloud)
    t["cloud"] = time.perf_counter()
    return Moving(rig, trajectory, tally, kept=kept, map_cloud=cloud,
                  extra={"frame_times_s": np.asarray(times, np.float64) - trajectory.start_s})


def stats_of(moving: Moving) -> dict[str, Any]:
    tr = moving.trajectory
    return {"trajectory": {"path": tr.meta.get("path"), "length_m": round(tr.length_m, 3),
                           "duration_s": round(tr.duration_s, 3), "shots": moving.tally.shots,
                           "rig": moving.rig.name, "sensors": [s.name for s in moving.rig.sensors]}}
