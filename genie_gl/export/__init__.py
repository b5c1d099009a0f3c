"""Exports, one module per format, each registered in :mod:`genie_gl.export.registry`:
``gg.export(cloud, out_dir, format=...)`` for one cloud, ``genie dataset --format`` for
datasets (BOP: image datasets only; TUM RGB-D and ROS 2 bags: a rig's recordings along a
trajectory only)."""

from __future__ import annotations

import os
from pathlib import Path

from ..validation.arguments import expect, whole_number
from ..errors import ExportError
from ..cloud.pointcloud import PointCloud
from ..errors import ConfigError
from ..outputs import claim_folder
from . import semantickitti, semantickitti_sequence, ply, pcd, npz, bop, e57, las, tum, rosbag  # noqa: F401, I001  (each registers its format, in this order)
from .registry import (
    DATASET_FORMATS,
    DatasetFormat,
    SceneData,
    cloud_formats,
    get_format,
    register_format,
)

FORMATS = cloud_formats()  # formats of one cloud: semantickitti, ply, pcd, npz, e57, las
MAX_FRAME = 999_999  # SemanticKITTI's scan names have six digits


def file_name(name: object, where: str) -> str:
    """``name`` when it is a plain file name (no folder in it, not ``.`` or ``..``): what a
    writer may join to its folder; a :class:`ConfigError` naming ``where`` otherwise."""
    if not isinstance(name, str):
        raise ConfigError(f"{where}: expected a file name (a string), got {type(name).__name__}")
    text = name.strip()
    if (
        not text
        or text in (".", "..")
        or "/" in name
        or "\\" in name
        or "\0" in name
        or os.path.isabs(name)
    ):
        raise ConfigError(
            f"{where}: {name!r}: expected a plain file name (no folder, no '/', not '.' or '..'); "
            "the file goes into out_dir"
        )
    if len(name.encode()) > 200:
        raise ConfigError(f"{where}: {name[:40]!r}...: a name of at most 200 bytes")
    return name


def export(
    cloud: PointCloud,
    out_dir: str | os.PathLike,
    format: str = "semantickitti",
    *,
    name: str = "cloud",
    sequence: int = 0,
    frame: int = 0,
) -> Path:
    """Write ``cloud`` under ``out_dir`` in ``format``; returns the main file written.

    ``out_dir`` may hold the user's own files: they are kept, and a name the format must write
    that is taken by one of them is refused (:mod:`genie_gl.outputs`); ``out_dir/manifest.json``
    records what genie-gl wrote there."""
    expect(cloud, PointCloud, "export: cloud")
    name = file_name(name, "export: name")
    sequence = whole_number(sequence, "export: sequence", 0, 99)  # SemanticKITTI's folders: 00-99
    frame = whole_number(frame, "export: frame", 0, MAX_FRAME)  # and its scans: 000000-999999
    if not isinstance(out_dir, (str, os.PathLike)):
        raise ConfigError(f"export: out_dir: expected a folder name, got {type(out_dir).__name__}")
    if not len(cloud):
        raise ExportError(
            f"export to {out_dir}: the cloud holds no point; nothing was written (did any camera "
            "see "
            "a surface?)"
        )
    fmt = get_format(format, "export format")
    if fmt.write_cloud is None:
        raise ConfigError(
            f"export format {format!r} writes datasets of frames, not clouds (clouds: "
            f"{', '.join(FORMATS)})"
        )
    bad = cloud.non_finite()
    if bad:
        raise ExportError(
            f"export to {out_dir}: {bad} of the cloud's {len(cloud)} points have NaN or infinite "
            "coordinates; nothing was written (drop them: cloud.select(cloud.finite()))"
        )
    folder = claim_folder(
        out_dir, "export", fmt.cloud_outputs(name), option="out_dir", reserve=True
    )
    with folder.abandoning():  # a failed export leaves nothing it wrote
        path = fmt.write_cloud(cloud, folder.path, name=name, sequence=sequence, frame=frame)
        folder.finish({"format": format, "last": {"name": name, "points": len(cloud)}})
    return path


__all__ = [
    "DATASET_FORMATS",
    "DatasetFormat",
    "FORMATS",
    "SceneData",
    "export",
    "get_format",
    "register_format",
]
