"""Size limits, in one place, for every command and public function that can hit them.

A run that cannot fit is refused before any work, in one line giving the estimate, the limit
and the option (or argument) that raises it; never after minutes of work, never by a
MemoryError or a GL crash. The estimates are upper bounds of what the stages can make: a
layout's regions come from each generator's own bound (:meth:`Generator.max_children`), a
frame's memory from its pixels, a scene's instances from the USD file before they are read.

======================  ===================================  ===============================
limit                   default                              raised by
======================  ===================================  ===============================
layout regions / work   :data:`MAX_REGIONS` (2 000 000)      ``--max-nodes``, ``max_regions=``
cameras                 :data:`MAX_CAMERAS` (10 000)         (fixed)
instances of a scene    :data:`MAX_INSTANCES` (1 000 000)    ``max_instances=``
memory                  80 % of what is available now        ``--max-memory-gb``, ``max_memory_gb=``
disk                    the free space of ``--out``          ``--max-disk-gb``
frame side              what the GL context can allocate     (the GL driver)
label raster cells      :data:`MAX_RASTER_CELLS` (1e8)       a coarser ``--resolution``
======================  ===================================  ===============================
"""

from __future__ import annotations

import os
import resource
import shutil
from pathlib import Path

from .errors import LimitError

MAX_REGIONS = 2_000_000
MAX_CAMERAS = 10_000
MAX_INSTANCES = 1_000_000
MAX_DURATION_S = 3600.0  # a trajectory's seconds (frames = seconds x the rig's summed rates)
MAX_RASTER_CELLS = 100_000_000  # a layout's label raster: 100 M cells (~400 MB as int32)
#: a frame side no GL driver we know allocates beyond (Mesa llvmpipe's texture limit); the
#: renderer checks the real one of its context (``GLContext.max_side``)
MAX_SIDE = 16384
BYTES_PER_PIXEL = 40  # depth f4 + ids u4 + semantic u2 + rgb 3 + normals/render targets
BYTES_PER_NODE = 2048  # layout arrays, scene instances, placement cover
BYTES_PER_INSTANCE = 4096  # an instance in a Scene (transform, ids, material) and its draw data
BYTES_PER_POINT = 16  # xyz f4 + label u4 (SemanticKITTI); ply/pcd/npz a little more
BYTES_PER_CLOUD_POINT = (
    48  # a merged cloud in memory: xyz f4 x 3, ids, colour, normal, camera, and the merge
)
MEMORY_SHARE = 0.8  # of the memory available now, when no limit is given


def available_memory_bytes() -> int:
    """Memory this process may still use: MemAvailable from /proc/meminfo (or total RAM), and
    no more than its address-space limit (``RLIMIT_AS``) leaves, when one is set."""
    free = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    try:
        for line in open("/proc/meminfo"):
            if line.startswith("MemAvailable:"):
                free = int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft != resource.RLIM_INFINITY:
            used = next(
                (
                    int(line.split()[1]) * 1024
                    for line in open("/proc/self/status")
                    if line.startswith("VmSize:")
                ),
                0,
            )
            free = min(free, max(0, soft - used))
    except (OSError, ValueError):
        pass
    return free


def memory_limit_bytes(max_memory_gb: float | None = None) -> float:
    """The memory limit: ``max_memory_gb`` when given, else :data:`MEMORY_SHARE` of what is free."""
    return max_memory_gb * 1e9 if max_memory_gb else MEMORY_SHARE * available_memory_bytes()


def free_disk_bytes(path: str | os.PathLike) -> float:
    """Bytes free on the file system of ``path`` (its nearest existing folder)."""
    p = Path(path)
    probe = p if p.exists() else next((q for q in p.parents if q.exists()), Path("."))
    return float(shutil.disk_usage(probe).free)


def gb(b: float) -> str:
    return f"{b / 1e9:.3g} GB"


def gb_pair(need: float, limit: float) -> tuple[str, str]:
    """``need`` and ``limit`` (bytes) in GB with as many digits as it takes to tell them apart
    (a need above its limit never reads "10.2 GB exceeds 10.2 GB")."""
    for digits in range(3, 16):
        a, b = f"{need / 1e9:.{digits}g} GB", f"{limit / 1e9:.{digits}g} GB"
        if a != b:
            return a, b
    return f"{need:.0f} B", f"{limit:.0f} B"


def check_regions(work: int, limit: int, where: str, *, option: str = "--max-nodes") -> None:
    """Refuse a layout whose estimated regions (or overlap tests / 10) exceed ``limit``."""
    if work > limit:
        raise LimitError(
            f"{where}: a layout of this strategy can make up to {work:.3g} regions (or overlap "
            "tests "
            f"/ 10), above the limit of {limit:,}; lower its generators' counts or raise it with "
            f"{option}"
        )


def check_instances(count: int, limit: int, where: str, *, option: str = "max_instances=") -> None:
    """Refuse a scene of more than ``limit`` instances, before they are made."""
    if count > limit:
        raise LimitError(
            f"{where}: {count:,} instances, above the limit of {limit:,} (about "
            f"{gb(count * BYTES_PER_INSTANCE)} of memory); raise it with {option}"
        )


def _raise(option: str | None) -> str:
    return f", or raise the limit with {option}" if option else ""


def check_memory(
    need: float, limit: float, what: str, fix: str, *, option: str | None = "--max-memory-gb"
) -> None:
    """Refuse work whose estimated memory ``need`` (bytes) exceeds ``limit`` (bytes); ``what``
    says how it was estimated, ``fix`` what to lower, ``option`` what raises the limit."""
    if need > limit:
        shown, allowed = gb_pair(need, limit)
        raise LimitError(
            f"estimated memory {shown} ({what}) exceeds {allowed}{' allowed' if option else ''}; "
            f"{fix}{_raise(option)}"
        )


def frames_bytes(cameras: int, width: int, height: int) -> int:
    """Memory of ``cameras`` frames of ``width`` x ``height`` pixels held at once."""
    return int(cameras) * int(width) * int(height) * BYTES_PER_PIXEL


def check_frames(
    cameras: int,
    width: int,
    height: int,
    where: str,
    *,
    max_memory_gb: float | None = None,
    extra_bytes: float = 0.0,
    option: str | None = None,
) -> None:
    """Refuse ``cameras`` frames of a ``width`` x ``height`` sensor kept in memory together
    (a capture returns them all) when they exceed the memory limit."""
    check_frame_side(width, height, where)
    need = frames_bytes(cameras, width, height) + extra_bytes
    check_memory(
        need,
        memory_limit_bytes(max_memory_gb),
        f"{cameras} cameras x {width}x{height} px x {BYTES_PER_PIXEL} B",
        f"{where}: use fewer cameras or a smaller sensor",
        option=option,
    )


def check_frame_side(
    width: int,
    height: int,
    where: str,
    max_side: int = MAX_SIDE,
    why: str = "the GL texture limit of this driver",
) -> None:
    """Refuse a frame whose side exceeds ``max_side`` px (the renderer passes its context's)."""
    if max(width, height) > max_side:
        raise LimitError(
            f"{where}: {width}x{height} px frames; each side must be at most {max_side} px ({why})"
        )


def check_disk(
    need: float,
    out: str | os.PathLike,
    where: str,
    *,
    max_disk_gb: float | None = None,
    fix: str = "write less",
    option: str | None = "--max-disk-gb",
) -> None:
    """Refuse a run that would write ``need`` bytes under ``out`` when that is more than the
    limit (``max_disk_gb``, else the free space of its file system)."""
    limit = max_disk_gb * 1e9 if max_disk_gb else free_disk_bytes(out)
    if need > limit:
        shown, allowed = gb_pair(need, limit)
        raise LimitError(
            f"{where}: the run would write about {shown}, more than {allowed} "
            f"{'allowed' if max_disk_gb else 'free'}; {fix}{_raise(option)}"
        )
