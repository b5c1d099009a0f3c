"""A mobile-scan map: frames fused in the world frame, one point per voxel.

A mobile scanner's registered map holds its points at a roughly even density, whatever how
often an area was seen; here every frame is unprojected at its (estimated) pose and a point is
kept only when its voxel (``voxel_m``, the map's density) holds none yet: the first point seen
of each voxel, in frame order, then pixel order. Voxels are marked in a bit set over the
scene's bounds, so a map of any number of frames costs one bit per voxel of the hall and its
kept points; a compiled pass per frame tests and marks each point's voxel in pixel order
(linear in the frame's points, no sort). The map is then cut into chunks like any cloud
(:func:`.process.chunks`).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from ..validation.arguments import expect
from ..errors import ConfigError, LimitError
from ..frame import Frame
from ..jit import njit
from ..limits import check_memory, memory_limit_bytes
from .pointcloud import PointCloud
from .unproject import unproject

MAX_VOXELS = 2**34  # a bit set larger than 2 GB: the voxel is too small for the hall
MAX_FRAMES = 65535  # PointCloud.camera is uint16


@njit(cache=True, nogil=True, boundscheck=False)
def _first_in_voxel(xyz, shift, voxel, dims, bits):  # pragma: no cover - compiled
    """One pass over the points in order: the indices of those whose voxel of the grid
    (``floor((xyz + shift) / voxel)``, ``dims`` voxels) held no point yet, each marking its
    voxel in the bit set ``bits`` as it is taken, and the number of points outside the grid."""
    take = np.empty(xyz.shape[0], np.int64)
    m = 0
    outside = 0
    for p in range(xyz.shape[0]):
        i = np.int64(np.floor((np.float64(xyz[p, 0]) + shift[0]) / voxel))
        j = np.int64(np.floor((np.float64(xyz[p, 1]) + shift[1]) / voxel))
        k = np.int64(np.floor((np.float64(xyz[p, 2]) + shift[2]) / voxel))
        if i < 0 or j < 0 or k < 0 or i >= dims[0] or j >= dims[1] or k >= dims[2]:
            outside += 1
            continue
        key = (i * dims[1] + j) * dims[2] + k
        bit = np.uint8(1 << (key & 7))
        if bits[key >> 3] & bit == 0:
            bits[key >> 3] |= bit
            take[m] = p
            m += 1
    return take[:m], outside


class VoxelMap:
    """Fuses frames one at a time.

    Parameters
    ----------
    bounds : (2, 3) float64 world box the map may hold (points outside are dropped, counted
        in ``dropped``); origin : (3,) float64 of the map's float32 coordinates; voxel_m : float.
    """

    def __init__(self, bounds: np.ndarray, voxel_m: float, origin: np.ndarray) -> None:
        if not voxel_m > 0:
            raise ConfigError(f"map voxel: expected > 0 m, got {voxel_m}")
        self.lo = np.asarray(bounds[0], np.float64)
        extent = np.asarray(bounds[1], np.float64) - self.lo
        cells = [max(1.0, float(np.ceil(x / voxel_m))) for x in extent]  # floats: no int64 overflow
        voxels = float(np.prod(cells))
        where = (
            f"map voxel {voxel_m:g} m over the {np.round(extent, 1).tolist()} m scene ({voxels:.3g}"
            " voxels)"
        )
        if voxels > MAX_VOXELS:
            raise LimitError(
                f"{where}: above the limit of {MAX_VOXELS:.3g} voxels; use a larger voxel"
            )
        check_memory(
            voxels / 8,
            memory_limit_bytes(),
            f"{where}, one bit each",
            "use a larger voxel",
            option=None,
        )
        self.dims = np.array(cells, np.int64)
        self.voxel_m, self.origin = float(voxel_m), np.asarray(origin, np.float64)
        self.bits = np.zeros((int(np.prod(self.dims)) + 7) // 8, np.uint8)
        self.parts: list[PointCloud] = []
        self.frames = 0
        self.seen = 0
        self.dropped = 0

    def add(self, frame: Frame) -> int:
        """Fuse ``frame`` (at its ``world_from_camera``); returns how many points it added."""
        expect(frame, Frame, f"fuse: frames[{self.frames}]")
        if self.frames >= MAX_FRAMES:
            raise ConfigError(
                f"a mobile-scan map holds at most {MAX_FRAMES} frames; use a shorter trajectory or "
                "lower frame rates"
            )
        c = unproject(frame, origin=self.origin, camera_index=self.frames)
        self.frames += 1
        self.seen += len(c)
        take, outside = _first_in_voxel(
            c.xyz, self.origin - self.lo, self.voxel_m, self.dims, self.bits
        )
        self.dropped += int(outside)
        if len(take):
            self.parts.append(c.select(take))
        return len(take)

    def cloud(self) -> PointCloud:
        """The map so far (empty: a ConfigError, as an empty result is)."""
        if not self.parts:
            raise ConfigError(
                "the mobile-scan map is empty: no frame saw anything inside the scene"
            )
        keep = ("xyz", "semantic", "instance", "rgb", "camera")
        parts = [
            PointCloud(**{k: getattr(p, k) for k in keep}, origin=p.origin) for p in self.parts
        ]
        return PointCloud.concatenate(parts)


def fuse(
    frames: Iterable[Frame],
    *,
    bounds: np.ndarray,
    voxel_m: float = 0.02,
    origin: np.ndarray | None = None,
) -> PointCloud:
    """The frames' points fused in the world frame, one per ``voxel_m`` voxel (the first seen),
    within ``bounds`` (2, 3); ``camera`` is each point's frame index."""
    given = bounds
    try:
        bounds = np.asarray(bounds, np.float64)
    except (TypeError, ValueError):
        bounds = np.zeros(0)
    if bounds.shape != (2, 3) or not np.isfinite(bounds).all() or not (bounds[1] > bounds[0]).all():
        raise ConfigError(
            "fuse: bounds: expected a (2, 3) box [[xmin, ymin, zmin], [xmax, ymax, zmax]] of "
            "finite "
            f"numbers, max above min, got {given!r:.80}"
        )
    origin = np.round(bounds.mean(0) / 100.0) * 100.0 + 0.0 if origin is None else origin
    m = VoxelMap(bounds, voxel_m, origin)
    for f in frames:
        m.add(f)
    return m.cloud()
