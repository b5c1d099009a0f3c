"""A mobile map from scans: fused in the world, thinned to a voxel, cut into the paper's
chunks of 25,000 points (3DGENie §4.1.1: "each scene is cropped into smaller chunks, and
then random down-sampling to 25,000 points is performed on each")."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..capture.scan_record import Scan
from .pointcloud import PointCloud
from .process import chunks, voxel_downsample
from .scan_cloud import scans_cloud

CHUNK_POINTS = 25_000


def scan_map(
    scans: Sequence[Scan],
    *,
    voxel_m: float | None = 0.02,
    chunk_m: float = 6.0,
    points: int = CHUNK_POINTS,
    rng: np.random.Generator,
) -> list[tuple[tuple[int, int], PointCloud]]:
    """The scans' map cut into square (x, y) chunks of ``chunk_m`` holding at least ``points``
    points, each randomly down-sampled to exactly ``points`` (fewer: left out)."""
    cloud = scans_cloud(scans)
    if voxel_m:
        cloud = voxel_downsample(cloud, voxel_m)
    return chunks(cloud, chunk_m, min_points=points, max_points=points, rng=rng)


def class_shares(clouds: Sequence[PointCloud], classes: int = 10) -> np.ndarray:
    """(classes,) float64 share of the points of each semantic id 0..classes-1."""
    counts = np.zeros(classes, np.int64)
    for c in clouds:
        counts += np.bincount(np.minimum(c.semantic, classes - 1), minlength=classes)[:classes]
    return counts / max(int(counts.sum()), 1)
