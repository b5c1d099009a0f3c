"""The limits of a dataset run (:mod:`genie_gl.limits`), checked before any work: a run that
cannot fit is refused up front with the estimate and the option that raises the limit, never
after minutes of work or a MemoryError.

- layout work: regions a scene's layout can make and the work of making them
  (:func:`genie_gl.layout.estimate.layout_estimate`, each generator's own bound); limit
  ``--max-nodes`` (default 2 000 000).
- frame size: each side at most :data:`MAX_SIDE` px (the GL texture limit of Mesa llvmpipe;
  the renderer checks its own context's).
- memory: per worker, the frames of one scene (cameras x pixels x :data:`BYTES_PER_PIXEL`)
  plus the layout (:data:`BYTES_PER_NODE` per region), times the workers, and one layout
  more for one worker's helper process (the next scene's, :mod:`genie_gl.dataset.ahead`); limit
  ``--max-memory-gb`` (default: 80 % of the memory available now).
- disk: the points (or images) the run writes, as its format counts them
  (``DatasetFormat.scene_bytes``); limit ``--max-disk-gb`` (default: the free space of the
  ``--out`` file system).
- a moving capture (``--capture trajectory|mobile-map``): its frames are ``--duration-s``
  times the rig's summed rates; a worker holds one window of them
  (:data:`genie_gl.capture.trajectory.WINDOW` shots) and, for a mobile-scan map, the map's
  bit set (one bit per ``--voxel-m`` voxel of the hall up to its ceiling); a trajectory
  writes every frame's points.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..capture.trajectory import WINDOW
from ..export import get_format
from ..layout.estimate import layout_estimate
from ..limits import (BYTES_PER_CLOUD_POINT, BYTES_PER_NODE, BYTES_PER_PIXEL, MAX_SIDE, check_disk, check_frame_side,
                      check_memory, check_regions, memory_limit_bytes)
from ..sensors.placement import ceiling_of
from .config import DatasetConfig
from .recording import rig_of

@dataclass(frozen=True)
class Estimate:
    nodes: int
    layout_work: int
    pixels: int
    memory_bytes: int
    disk_bytes: int


def estimate(cfg: DatasetConfig, strategy, sensor) -> Estimate:
    if cfg.capture != "static":
        return moving_estimate(cfg, strategy)
    nodes, work = layout_estimate(strategy)
    pixels = int(sensor.width) * int(sensor.height)
    per_worker = cfg.cameras * pixels * BYTES_PER_PIXEL + nodes * BYTES_PER_NODE
    if cfg.previews:   # a preview scene's frames are merged into one cloud as well
        per_worker += cfg.cameras * pixels * BYTES_PER_CLOUD_POINT
    workers = min(cfg.workers, cfg.scenes)
    helper = nodes * BYTES_PER_NODE if workers == 1 and cfg.scenes > 1 else 0
    chunks = max(1.0, strategy.root.width / cfg.chunk_m + 1) * max(1.0, strategy.root.height / cfg.chunk_m + 1)
    points = min(chunks * cfg.points, cfg.cameras * pixels)   # a scene keeps at most its chunks' points
    disk = int(cfg.scenes * get_format(cfg.format).scene_bytes(points, cfg.cameras * pixels))
    return Estimate(nodes, work, pixels, int(per_worker * workers + helper), int(disk))


def voxel_bytes(width_m: float, depth_m: float, height_m: float, voxel_m: float) -> float:
    """Bytes of a mobile-scan map's bit set over a ``width_m`` x ``depth_m`` x ``height_m`` box
    (:class:`genie_gl.cloud.fusion.VoxelMap`), as a float (no overflow however small the voxel)."""
    return float(np.prod([max(1.0, np.ceil(x / voxel_m)) for x in (width_m, depth_m, height_m)])) / 8.0


def moving_estimate(cfg: DatasetConfig, strategy) -> Estimate:
    """The estimate of a recording along a trajectory (``--capture trajectory|mobile-map``)."""
    nodes, work = layout_estimate(strategy)
    rig = rig_of(cfg)
    frames = cfg.duration_s * sum(s.rate_hz for s in rig.sensors)
    pixels = max(int(s.sensor.width) * int(s.sensor.height) for s in rig.sensors)
    per_worker = WINDOW * pixels * BYTES_PER_PIXEL + nodes * BYTES_PER_NODE
    root = strategy.root
    if cfg.capture == "mobile-map":   # the hall's box with the half metre the map keeps around it
        per_worker += voxel_bytes(root.width + 1, root.height + 1, ceiling_of(strategy.scene) + 1, cfg.voxel_m)
        chunks = max(1.0, root.width / cfg.chunk_m + 1) * max(1.0, root.height / cfg.chunk_m + 1)
        points = min(chunks * cfg.points, frames * pixels)
    else:
        points = frames * pixels
    disk = cfg.scenes * get_format(cfg.format).scene_bytes(points, frames * pixels)
    return Estimate(nodes, work, pixels, int(per_worker * min(cfg.workers, cfg.scenes)), int(disk))


def check_limits(cfg: DatasetConfig, strategy, sensor, out: Path) -> Estimate:
    """Refuse ``cfg`` with a :class:`LimitError` when its estimate exceeds a limit."""
    e = estimate(cfg, strategy, sensor)
    check_regions(e.layout_work, cfg.max_nodes, str(getattr(strategy, "source", "strategy")))
    check_frame_side(sensor.width, sensor.height, f"--sensor {cfg.sensor}", MAX_SIDE)
    workers = min(cfg.workers, cfg.scenes)
    if cfg.capture == "static":
        what, fix = (f"{workers} workers x {cfg.cameras} cameras x {sensor.width}x{sensor.height} px x "
                     f"{BYTES_PER_PIXEL} B + {e.nodes:.3g} regions"), "use fewer --workers or --cameras, a smaller sensor"
    else:
        what = f"{workers} workers x a window of {WINDOW} frames of the rig + {e.nodes:.3g} regions" + (
            f" + the map's bit set at --voxel-m {cfg.voxel_m:g}" if cfg.capture == "mobile-map" else "")
        fix = "use fewer --workers, a larger --voxel-m" if cfg.capture == "mobile-map" else "use fewer --workers"
    check_memory(e.memory_bytes, memory_limit_bytes(cfg.max_memory_gb), what, fix)
    check_disk(e.disk_bytes, out, f"--out {out}", max_disk_gb=cfg.max_disk_gb,
               fix="make fewer --scenes" + (", a shorter --duration-s" if cfg.capture == "trajectory" else ""))
    return e
