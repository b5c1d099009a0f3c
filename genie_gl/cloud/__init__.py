"""Point clouds: unprojection, merging, sampling, chunking and cleaning."""

from .pointcloud import PointCloud
from .process import (
    chunks,
    choose_origin,
    frame_chunks,
    keep_cloud,
    origin_of,
    random_downsample,
    to_cloud,
    voxel_downsample,
)
from .tally import FrameTally
from .unproject import ray_table, unproject

__all__ = [
    "FrameTally",
    "PointCloud",
    "chunks",
    "choose_origin",
    "frame_chunks",
    "keep_cloud",
    "origin_of",
    "random_downsample",
    "ray_table",
    "to_cloud",
    "unproject",
    "voxel_downsample",
]
