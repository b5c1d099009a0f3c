"""Merging, down-sampling, chunking and cleaning of clouds (paper §3.4.2)."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..frame import Frame
from .pointcloud import PointCloud
from .unproject import unproject

FAR = 1.0e4  # beyond this distance from the world origin, clouds get a float64 origin


def choose_origin(frames: Sequence[Frame]) -> np.ndarray:
    """Zero, unless the cameras are far from the world origin: then their mean, rounded to 1 m."""
    centres = np.array([f.world_from_camera[:3, 3] for f in frames])
    if len(centres) == 0 or np.abs(centres).max() < FAR:
        return np.zeros(3)
    return np.round(centres.mean(0))


def voxel_downsample(cloud: PointCloud, voxel_m: float) -> PointCloud:
    """Keep the first point (in order) of each occupied voxel of size ``voxel_m``."""
    keys = np.floor(cloud.xyz / voxel_m).astype(np.int64)
    keys -= keys.min(0)
    dims = keys.max(0) + 1
    flat = (keys[:, 0] * dims[1] + keys[:, 1]) * dims[2] + keys[:, 2]
    _, first = np.unique(flat, return_index=True)
    return cloud.select(np.sort(first))


def random_downsample(cloud: PointCloud, n: int, *, rng: np.random.Generator) -> PointCloud:
    """Exactly ``n`` points drawn without replacement (all points, in order, if fewer)."""
    if len(cloud) <= n:
        return cloud
    return cloud.select(np.sort(rng.choice(len(cloud), n, replace=False)))


def to_cloud(frames: Sequence[Frame], *, voxel_m: float | None = None, max_points: int | None = None,
             rng: np.random.Generator | None = None, origin: np.ndarray | None = None) -> PointCloud:
    """Merge frames into one world-frame cloud with semantic, instance, colour, normal, camera.

    voxel_m : optional voxel down-sampling; max_points : random down-sampling to at most that
    many points (needs ``rng``).
    """
    if not frames:
        raise ValueError("to_cloud: no frames")
    origin = choose_origin(frames) if origin is None else np.asarray(origin, np.float64)
    cloud = PointCloud.concatenate([unproject(f, origin=origin, camera_index=i) for i, f in enumerate(frames)])
    if voxel_m:
        cloud = voxel_downsample(cloud, voxel_m)
    if max_points is not None:
        if rng is None:
            raise ValueError("to_cloud: max_points needs an rng (numpy.random.Generator)")
        cloud = random_downsample(cloud, max_points, rng=rng)
    return cloud


def chunks(cloud: PointCloud, size_m: float, *, min_points: int = 1) -> list[tuple[tuple[int, int], PointCloud]]:
    """Crop the cloud into square (x, y) tiles of ``size_m``; returns ((i, j), tile) pairs in
    (i, j) order, each tile's points in their original order."""
    if len(cloud) == 0:
        return []
    ij = np.floor(cloud.xyz[:, :2] / size_m).astype(np.int64)
    lo = ij.min(0)
    span = int(ij[:, 1].max() - lo[1]) + 1
    flat = (ij[:, 0] - lo[0]) * span + (ij[:, 1] - lo[1])  # one integer per tile: a fast 1-D sort
    order = np.argsort(flat, kind="stable")
    uniq, starts = np.unique(flat[order], return_index=True)
    ends = np.append(starts[1:], len(order))
    out = []
    for key, a, b in zip(uniq, starts, ends):
        if b - a >= min_points:
            out.append(((int(key // span + lo[0]), int(key % span + lo[1])), cloud.select(order[a:b])))
    return out


def keep_cloud(cloud: PointCloud, *, min_points: int = 1000, min_labelled_share: float = 0.05,
               background: int = 0) -> tuple[bool, str]:
    """The paper's cleaning: drop clouds with too few points, too small a labelled share, or
    background only. Returns (keep, reason)."""
    if len(cloud) < min_points:
        return False, f"{len(cloud)} points < {min_points}"
    share = float((cloud.semantic != background).mean())
    if share == 0:
        return False, "background only"
    if share < min_labelled_share:
        return False, f"labelled share {share:.3f} < {min_labelled_share}"
    return True, "ok"
