"""A scanner rig along a trajectory: its raw scans (``--capture scans``) or the map fused from
them (``--capture scan-map``).

A scanner rig (``rigs/<name>.lidar.yml``: spinning heads, :mod:`genie_gl.motion.scanner_rig`)
is carried along the same trajectory as a camera rig (``--path``, ``--motion``,
``--duration-s``; the scene's own ``trajectory`` stream) and scans it head by head
(:func:`genie_gl.capture.scanning.iter_scans`, each scan its own random stream from the
scene's capture seed, so the bytes do not depend on ``--workers``).

- ``scans``: every scan written as the scanner formats write them
  (:data:`genie_gl.export.lidar_output.SCAN_FORMATS`): ``--format semantickitti`` gives KITTI
  sequences (deskewed scans with remission, ``poses.txt``, ``calib.txt``), ``rosbag`` a ROS 2
  bag of ``PointCloud2``, ``las`` the fused ``map.las``, ``e57`` a Data3D scan per scan,
  ``pcd`` / ``ply`` each scan raw.
- ``scan-map``: the scans fused in the world, thinned to ``--voxel-m`` and cut into
  ``--chunk-m`` chunks of exactly ``--points`` points (the paper's 25,000,
  :func:`genie_gl.cloud.scan_map.scan_map`), cleaned as every mode's chunks are and written in
  any point-cloud format. Its histogram shows the paper's real column beside it (Table 3).

Whether a rig is a scanner rig is its file's kind; a camera rig given to these modes, or a
scanner rig given to the camera modes, is refused naming the modes that take it.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import yaml

from ...capture.scanning import iter_scans
from ...cloud import keep_cloud
from ...cloud.balance import PAPER_REAL
from ...cloud.scan_map import scan_map
from ...errors import ConfigError
from ...export import get_format
from ...export.lidar_output import SCAN_FORMATS
from ...layout.estimate import layout_estimate
from ...limits import BYTES_PER_NODE, check_disk, check_memory, check_regions, memory_limit_bytes
from ...resources import resolve
from ...motion.paths import path_kind, read_waypoints
from ...motion.scanner_rig import SUFFIX, ScannerRig, load_scanner_rig, scanner_rig_file
from ..recipe import make_scene
from .base import Captured, CaptureMode, Estimate, register_mode, stamp
from .moving import TRAJECTORY_FILE, trajectory_of, write_trajectory

#: the dataset format -> the scanner format its scans are written in
SCAN_FORMAT_OF = {
    "semantickitti": "kitti",
    "rosbag": "rosbag",
    "las": "las",
    "e57": "e57",
    "pcd": "pcd",
    "ply": "ply",
}
#: bytes a worker holds per scan point (a :class:`~genie_gl.capture.scan_record.Scan`'s
#: arrays, ~92 B, and the writers' copies), an estimate from above
BYTES_PER_SCAN_POINT = 200


def scanner_rig_of(cfg) -> ScannerRig:
    """The run's scanner rig (``--rig``); refused when ``--rig`` names no scanner rig."""
    path = scanner_rig_file(cfg.rig)
    if path is None:
        raise ConfigError(
            f"--rig {cfg.rig!r:.60}: --capture {cfg.capture} takes a scanner rig "
            f"(rigs/<name>{SUFFIX} "
            f"or a *{SUFFIX} file); a camera rig's capture is --capture trajectory or mobile-map"
        )
    return load_scanner_rig(path)


class ScannerOnPath(CaptureMode):
    """A scanner rig's scans along a trajectory; subclasses say what the scans become."""

    options: tuple[str, ...] = ("rig", "path", "motion", "duration_s")
    files = (TRAJECTORY_FILE,)

    def check(self, cfg) -> None:
        path_kind(cfg.path)
        if not cfg.rig:
            raise ConfigError(
                f"--capture {self.name}: needs --rig, a scanner rig (rigs/<name>{SUFFIX})"
            )

    def prepare(self, cfg, inputs) -> None:
        scanner_rig_of(cfg)  # a bad rig file is refused before any work
        if path_kind(cfg.path) == "waypoints":
            read_waypoints(cfg.path)

    def input_files(self, cfg) -> dict[str, str]:
        """The rig's file and its heads' profiles, the waypoints file."""
        rig_file = scanner_rig_file(cfg.rig)
        files = {"rig": str(rig_file)}
        scanner_rig_of(cfg)  # checked: its heads' profiles resolve as the loader resolves them
        for k, head in enumerate(yaml.safe_load(rig_file.read_text())["heads"]):
            beside = rig_file.parent / head["profile"]
            files[f"rig head {k} profile"] = str(
                beside if beside.is_file() else resolve(head["profile"], "sensors", (SUFFIX,))
            )
        if Path(cfg.path).is_file():
            files["waypoints"] = cfg.path
        return files

    def points_per_scene(self, cfg) -> float:
        """Points the rig returns along ``--duration-s``, at most (every beam, every return)."""
        rig = scanner_rig_of(cfg)
        return cfg.duration_s * sum(
            h.scanner.points_per_second * (2 if h.scanner.returns == "dual" else 1)
            for h in rig.heads
        )

    def written_points(self, cfg, strategy, points: float) -> float:
        return points

    def estimate(self, cfg, strategy, sensor) -> Estimate:
        nodes, work = layout_estimate(strategy)
        points = self.points_per_scene(cfg)
        workers = min(cfg.workers, cfg.scenes)
        per_worker = points * BYTES_PER_SCAN_POINT + nodes * BYTES_PER_NODE
        disk = cfg.scenes * get_format(cfg.format).scene_bytes(
            self.written_points(cfg, strategy, points), 0
        )
        what = f"{workers} workers x {points:.3g} scan points of the rig + {nodes:.3g} regions"
        return Estimate(
            nodes,
            work,
            0,
            int(per_worker * workers),
            int(disk),
            what,
            "use fewer --workers, a shorter --duration-s",
            "make fewer --scenes, a shorter --duration-s",
        )

    def check_limits(self, cfg, strategy, sensor, out: Path) -> Estimate:
        e = self.estimate(cfg, strategy, sensor)  # no frame: no frame side to check
        check_regions(e.layout_work, cfg.max_nodes, str(getattr(strategy, "source", "strategy")))
        check_memory(
            e.memory_bytes, memory_limit_bytes(cfg.max_memory_gb), e.memory_what, e.memory_fix
        )
        check_disk(e.disk_bytes, out, f"--out {out}", max_disk_gb=cfg.max_disk_gb, fix=e.disk_fix)
        return e

    def scan(self, cfg, inputs, streams, *, stage: Callable[[str], None]):
        """The scene, its trajectory and every scan of the rig along it."""
        layout, scene, clock = make_scene(inputs, streams, stage=stage)
        stage("placement")
        rig = scanner_rig_of(cfg)
        trajectory = trajectory_of(cfg, layout, scene, seed=streams.trajectory_seed)
        stamp(clock, "placement")
        stage("capture")
        scans = list(iter_scans(scene, rig, trajectory, seed=streams.capture_seed))
        stamp(clock, "capture")
        if not scans or not sum(len(s) for s in scans):
            raise ConfigError(
                f"--capture {self.name}: the rig's {len(scans)} scans along the trajectory hold no "
                f"point (a longer --duration-s scans more)"
            )
        info = {
            "instances": len(scene.instances),
            "trajectory": {
                "path": trajectory.meta.get("path"),
                "length_m": round(trajectory.length_m, 3),
                "duration_s": round(trajectory.duration_s, 3),
                "shots": len(scans),
                "rig": rig.name,
                "heads": [h.name for h in rig.heads],
            },
        }
        return layout, scene, clock, rig, trajectory, scans, info

    def write(self, fmt, data, folder: Path, got: Captured) -> None:
        self.write_scans(fmt, data, folder, got)
        write_trajectory(got.trajectory, folder / TRAJECTORY_FILE)

    def write_scans(self, fmt, data, folder: Path, got: Captured) -> None:
        fmt.write_scene(data, folder)


def _counts(semantic: np.ndarray) -> np.ndarray:
    return np.bincount(semantic, minlength=65536).astype(np.int64)


class Scans(ScannerOnPath):
    name = "scans"
    description = "a scanner rig's raw scans along a trajectory"
    rank = 3

    def takes(self, fmt) -> bool:
        return fmt.name in SCAN_FORMAT_OF

    def curates(self, fmt) -> bool:
        return False  # raw scans are written as they are: nothing to sub-sample

    def finish(self, fmt) -> Callable | None:
        return None  # each scene folder is whole (the KITTI label map is beside its sequences)

    def capture(
        self, cfg, inputs, streams, fmt, *, stage: Callable[[str], None], ahead=None
    ) -> Captured:
        layout, scene, clock, rig, trajectory, scans, info = self.scan(
            cfg, inputs, streams, stage=stage
        )
        stamp(clock, "cloud")
        counts = _counts(np.concatenate([s.semantic for s in scans]))
        return Captured(
            layout,
            scene,
            clock,
            counts=counts,
            points=int(counts.sum()),
            shots=len(scans),
            info=info,
            rig=rig,
            trajectory=trajectory,
            extra={"scans": scans},
        )

    def write_scans(self, fmt, data, folder: Path, got: Captured) -> None:
        write, _ = SCAN_FORMATS[SCAN_FORMAT_OF[fmt.name]]
        write(got.extra["scans"], folder)


class ScanMap(ScannerOnPath):
    name = "scan-map"
    description = "a map fused from a scanner rig's scans, in chunks of --points points"
    rank = 4
    options = (*ScannerOnPath.options, "voxel_m")

    def takes(self, fmt) -> bool:
        return fmt.write_scene is not None and fmt.chunks

    def reference(self) -> dict[int, float] | None:
        return PAPER_REAL

    def written_points(self, cfg, strategy, points: float) -> float:
        root = strategy.root
        n = max(1.0, root.width / cfg.chunk_m + 1) * max(1.0, root.height / cfg.chunk_m + 1)
        return min(n * cfg.points, points)

    def capture(
        self, cfg, inputs, streams, fmt, *, stage: Callable[[str], None], ahead=None
    ) -> Captured:
        layout, scene, clock, rig, trajectory, scans, info = self.scan(
            cfg, inputs, streams, stage=stage
        )
        stage("cloud")
        kept = [
            (key, tile)
            for key, tile in scan_map(
                scans,
                voxel_m=cfg.voxel_m,
                chunk_m=cfg.chunk_m,
                points=cfg.points,
                rng=streams.rng("cloud"),
            )
            if keep_cloud(
                tile, min_points=cfg.min_points, min_labelled_share=cfg.min_labelled_share
            )[0]
        ]
        stamp(clock, "cloud")
        counts = np.zeros(65536, np.int64)
        for _, tile in kept:
            counts += _counts(tile.semantic)
        return Captured(
            layout,
            scene,
            clock,
            kept=kept,
            counts=counts,
            points=int(sum(len(s) for s in scans)),
            shots=len(scans),
            info=info,
            rig=rig,
            trajectory=trajectory,
        )


SCANS = register_mode(Scans())
SCAN_MAP = register_mode(ScanMap())
