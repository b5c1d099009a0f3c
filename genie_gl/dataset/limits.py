"""Size limits checked before any work: a run that cannot fit is refused up front with the
estimate and the option that raises the limit, never after minutes of work or a MemoryError.

- layout work: regions a scene's layout can make (each level's generators at their largest
  arguments, bounded by the hall's area: each generator says, ``Generator.bound``) plus the
  work they do besides (``random_rooms``' overlap tests / 10); limit ``--max-nodes``
  (default 2 000 000).
- frame size: each side at most :data:`MAX_SIDE` px (the GL texture limit of Mesa llvmpipe).
- memory: per worker, the frames of one scene (cameras x pixels x :data:`BYTES_PER_PIXEL`)
  plus the layout (:data:`BYTES_PER_NODE` per region), times the workers; limit
  ``--max-memory-gb`` (default: 80 % of the memory available now).
- disk: the points (or images) the run writes, as its format counts them
  (``DatasetFormat.scene_bytes``); limit ``--max-disk-gb`` (default: the
  free space of the ``--out`` file system).
"""
from __future__ import annotations

import math
import shutil
from dataclasses import dataclass
from pathlib import Path

from ..errors import LimitError
from ..export import get_format
from .config import DatasetConfig, available_memory_bytes

MAX_SIDE = 16384
BYTES_PER_PIXEL = 40   # depth f4 + ids u4 + semantic u2 + rgb 3 + normals/render targets
BYTES_PER_NODE = 2048  # layout arrays, scene instances, placement cover


@dataclass(frozen=True)
class Estimate:
    nodes: int
    layout_work: int
    pixels: int
    memory_bytes: int
    disk_bytes: int


def layout_estimate(strategy) -> tuple[int, int]:
    """(regions, work) a layout of ``strategy`` can make at most: each level's generators at
    their largest arguments (:meth:`~genie_gl.layout.generators.Generator.bound`), bounded by
    the hall's area, plus the work they do besides making regions."""
    W, H = strategy.root.width, strategy.root.height
    area = W * H
    nodes, work = 1, 1  # a level may split any region made so far: all of them are its parents
    for level in strategy.levels:
        if level == "merge" or not isinstance(level, dict):
            continue
        per_parent, area_cap = 1.0, math.inf
        for rule in level.values():
            bound = rule.generator.bound(W, H)
            per_parent = max(per_parent, bound.per_parent)
            if bound.min_area_m2 is not None:   # its regions tile at most twice the hall, plus the parents
                area_cap = min(area_cap, 2 * area / bound.min_area_m2 + 2 * nodes)
            work += int(bound.work) * nodes
        made = int(min(nodes * per_parent, area_cap, 1e18))
        nodes += made
        work += made
    return int(min(nodes, 1e18)), int(min(work, 1e18))


def estimate(cfg: DatasetConfig, strategy, sensor) -> Estimate:
    nodes, work = layout_estimate(strategy)
    pixels = int(sensor.width) * int(sensor.height)
    per_worker = cfg.cameras * pixels * BYTES_PER_PIXEL + nodes * BYTES_PER_NODE
    workers = min(cfg.workers, cfg.scenes)
    chunks = max(1.0, strategy.root.width / cfg.chunk_m + 1) * max(1.0, strategy.root.height / cfg.chunk_m + 1)
    points = min(chunks * cfg.points, cfg.cameras * pixels)   # a scene keeps at most its chunks' points
    disk = int(cfg.scenes * get_format(cfg.format).scene_bytes(points, cfg.cameras * pixels))
    return Estimate(nodes, work, pixels, int(per_worker * workers), int(disk))


def _gb(b: float) -> str:
    return f"{b / 1e9:.3g} GB"


def check_limits(cfg: DatasetConfig, strategy, sensor, out: Path) -> Estimate:
    """Refuse ``cfg`` with a :class:`LimitError` when its estimate exceeds a limit."""
    e = estimate(cfg, strategy, sensor)
    src = getattr(strategy, "source", "strategy")
    if e.layout_work > cfg.max_nodes:
        raise LimitError(f"{src}: a layout of this strategy can make up to {e.layout_work:.3g} regions (or overlap "
                         f"tests / 10), above the limit of {cfg.max_nodes:,}; lower its generators' counts or raise "
                         f"it with --max-nodes")
    if max(sensor.width, sensor.height) > MAX_SIDE:
        raise LimitError(f"--sensor {cfg.sensor}: {sensor.width}x{sensor.height} px frames; each side must be at most "
                         f"{MAX_SIDE} px (the GL texture limit)")
    mem_limit = cfg.max_memory_gb * 1e9 if cfg.max_memory_gb else 0.8 * available_memory_bytes()
    if e.memory_bytes > mem_limit:
        raise LimitError(f"estimated memory {_gb(e.memory_bytes)} ({min(cfg.workers, cfg.scenes)} workers x "
                         f"{cfg.cameras} cameras x {sensor.width}x{sensor.height} px x {BYTES_PER_PIXEL} B + "
                         f"{e.nodes:.3g} regions) exceeds {_gb(mem_limit)}; use fewer --workers or --cameras, a "
                         f"smaller sensor, or raise the limit with --max-memory-gb")
    probe = out if out.exists() else next((p for p in out.parents if p.exists()), Path("."))
    disk_limit = cfg.max_disk_gb * 1e9 if cfg.max_disk_gb else shutil.disk_usage(probe).free
    if e.disk_bytes > disk_limit:
        raise LimitError(f"--out {out}: the run would write about {_gb(e.disk_bytes)}, more than "
                         f"{_gb(disk_limit)} {'allowed' if cfg.max_disk_gb else 'free'}; make fewer --scenes or "
                         f"raise the limit with --max-disk-gb")
    return e
