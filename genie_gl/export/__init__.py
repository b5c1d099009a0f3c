"""Exports, one module per format, each registered in :mod:`genie_gl.export.registry`:
``gg.export(cloud, out_dir, format=...)`` for one cloud, ``genie dataset --format`` for
datasets (BOP: image datasets only)."""
from __future__ import annotations

import os
from pathlib import Path

from ..cloud.pointcloud import PointCloud
from ..errors import ConfigError
from . import semantickitti, ply, pcd, npz, bop  # noqa: F401, I001  (each registers its format, in this order)
from .registry import DATASET_FORMATS, DatasetFormat, SceneData, cloud_formats, get_format, register_format

FORMATS = cloud_formats()  # formats of one cloud: semantickitti, ply, pcd, npz


def export(cloud: PointCloud, out_dir: str | os.PathLike, format: str = "semantickitti", *,
           name: str = "cloud", sequence: int = 0, frame: int = 0) -> Path:
    """Write ``cloud`` under ``out_dir`` in ``format``; returns the main file written."""
    fmt = get_format(format, "export format")
    if fmt.write_cloud is None:
        raise ConfigError(f"export format {format!r} writes datasets of frames, not clouds (clouds: {', '.join(FORMATS)})")
    return fmt.write_cloud(cloud, Path(out_dir), name=name, sequence=sequence, frame=frame)


__all__ = ["DATASET_FORMATS", "DatasetFormat", "FORMATS", "SceneData", "export", "get_format", "register_format"]
