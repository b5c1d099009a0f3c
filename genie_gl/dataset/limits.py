"""The limits of a dataset run (:mod:`genie_gl.limits`), checked before any work: a run that
cannot fit is refused up front with the estimate and the option that raises the limit, never
after minutes of work or a MemoryError.

- layout work: regions a scene's layout can make and the work of making them
  (:func:`genie_gl.layout.estimate.layout_estimate`, each generator's own bound); limit
  ``--max-nodes`` (default 2 000 000).
- frame size: each side at most :data:`MAX_SIDE` px (the GL texture limit of Mesa llvmpipe;
  the renderer checks its own context's).
- memory: per worker, the frames of one scene (cameras x pixels x :data:`BYTES_PER_PIXEL`)
  plus the layout (:data:`BYTES_PER_NODE` per region), times the workers; limit
  ``--max-memory-gb`` (default: 80 % of the memory available now).
- disk: the points (or images for BOP) the run writes; limit ``--max-disk-gb`` (default: the
  free space of the ``--out`` file system).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..export import get_format
from ..layout.estimate import layout_estimate
from ..limits import (BYTES_PER_CLOUD_POINT, BYTES_PER_NODE, BYTES_PER_PIXEL, MAX_SIDE, check_disk, check_frame_side,
                      check_memory, check_regions, memory_limit_bytes)
from .config import DatasetConfig

BOP_BYTES_PER_PIXEL = 4  # 16-bit depth + RGB + masks, PNG-compressed


@dataclass(frozen=True)
class Estimate:
    nodes: int
    layout_work: int
    pixels: int
    memory_bytes: int
    disk_bytes: int


def estimate(cfg: DatasetConfig, strategy, sensor) -> Estimate:
    nodes, work = layout_estimate(strategy)
    pixels = int(sensor.width) * int(sensor.height)
    per_worker = cfg.cameras * pixels * BYTES_PER_PIXEL + nodes * BYTES_PER_NODE
    if cfg.previews:   # a preview scene's frames are merged into one cloud as well
        per_worker += cfg.cameras * pixels * BYTES_PER_CLOUD_POINT
    workers = min(cfg.workers, cfg.scenes)
    if cfg.format == "bop":
        disk = cfg.scenes * cfg.cameras * pixels * BOP_BYTES_PER_PIXEL
    else:
        chunks = max(1.0, strategy.root.width / cfg.chunk_m + 1) * max(1.0, strategy.root.height / cfg.chunk_m + 1)
        disk = int(cfg.scenes * min(chunks * cfg.points, cfg.cameras * pixels) * get_format(cfg.format).bytes_per_point)
    return Estimate(nodes, work, pixels, int(per_worker * workers), int(disk))


def check_limits(cfg: DatasetConfig, strategy, sensor, out: Path) -> Estimate:
    """Refuse ``cfg`` with a :class:`LimitError` when its estimate exceeds a limit."""
    e = estimate(cfg, strategy, sensor)
    check_regions(e.layout_work, cfg.max_nodes, str(getattr(strategy, "source", "strategy")))
    check_frame_side(sensor.width, sensor.height, f"--sensor {cfg.sensor}", MAX_SIDE)
    workers = min(cfg.workers, cfg.scenes)
    check_memory(e.memory_bytes, memory_limit_bytes(cfg.max_memory_gb),
                 f"{workers} workers x {cfg.cameras} cameras x {sensor.width}x{sensor.height} px x {BYTES_PER_PIXEL} B "
                 f"+ {e.nodes:.3g} regions", "use fewer --workers or --cameras, a smaller sensor")
    check_disk(e.disk_bytes, out, f"--out {out}", max_disk_gb=cfg.max_disk_gb, fix="make fewer --scenes")
    return e
