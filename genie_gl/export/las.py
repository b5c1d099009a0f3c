"""LAS 1.4, point data record format 6 (7 with colour), written with ``laspy`` (FORMATS.md §5.3
and §8): what mobile-scan maps are handed on in.

- ``X, Y, Z``: scaled integers (0.1 mm) with the offsets at the cloud's origin, so the file
  holds world coordinates exactly to 0.1 mm wherever the site lies;
- ``classification`` (8 bits, 0-255 in these formats): the semantic id; an id above 255 is
  refused; ``instance_id``: an extra-bytes dimension, uint32;
- ``point_source_id``: the frame that saw the point (``PointCloud.camera``), 0 if unknown;
- ``gps_time``: the second it was seen on the recording's clock, when a time per frame is
  known (a mobile-scan map), else 0; red/green/blue (16 bits: 8-bit colour x 257) when known.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..cloud.pointcloud import PointCloud
from ..errors import ConfigError, ExportError
from ..outputs import check_replaceable, written

SCALE_M = 1e-4
SOFTWARE = "genie-gl"  # the header's generating software of the files written here


def _laspy():
    try:
        import laspy
    except ImportError as exc:
        raise ConfigError(
            f"--format las needs the laspy package: pip install 'genie-gl[sequences]' ({exc})"
        ) from None
    return laspy


def write(
    cloud: PointCloud, path: str | os.PathLike, *, frame_times_s: np.ndarray | None = None
) -> Path:
    """``cloud`` as one LAS 1.4 file; ``frame_times_s[k]``: the time of frame k (gps_time)."""
    laspy = _laspy()
    path = check_replaceable(
        path, las_is_ours, what="LAS point cloud"
    )  # a user's file stays as it is
    if len(cloud) and int(cloud.semantic.max()) > 255:
        raise ExportError(
            f"LAS classification holds ids 0-255, got semantic id {int(cloud.semantic.max())}"
        )
    header = laspy.LasHeader(point_format=7 if cloud.rgb is not None else 6, version="1.4")
    header.generating_software = SOFTWARE  # how a later run knows the file as its own
    header.scales = np.full(3, SCALE_M)
    header.offsets = np.asarray(cloud.origin, np.float64)
    header.add_extra_dim(
        laspy.ExtraBytesParams(
            name="instance_id", type=np.uint32, description="genie-gl instance id"
        )
    )
    las = laspy.LasData(header)
    world = cloud.world_xyz
    las.x, las.y, las.z = world[:, 0], world[:, 1], world[:, 2]
    las.classification = cloud.semantic.astype(np.uint8)
    las.instance_id = cloud.instance
    if cloud.camera is not None:
        las.point_source_id = cloud.camera
        if frame_times_s is not None:
            las.gps_time = np.asarray(frame_times_s, np.float64)[cloud.camera]
    if cloud.rgb is not None:
        rgb = cloud.rgb.astype(np.uint16) * 257
        las.red, las.green, las.blue = rgb[:, 0], rgb[:, 1], rgb[:, 2]
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp.las")
    path.parent.mkdir(parents=True, exist_ok=True)
    with written(path, tmp):
        las.write(str(tmp))
        tmp.replace(path)
    return path


def las_is_ours(path: Path) -> bool:
    """True when ``path`` is a LAS file :func:`write` wrote (its header's generating software)."""
    with _laspy().open(str(path)) as f:
        return str(f.header.generating_software).startswith(SOFTWARE)


def read(path: str | os.PathLike) -> PointCloud:
    """A LAS file written here, back as a PointCloud (origin = the header's offsets)."""
    las = _laspy().read(str(path))
    origin = np.asarray(las.header.offsets, np.float64)
    xyz = np.stack(
        [
            np.asarray(las.x) - origin[0],
            np.asarray(las.y) - origin[1],
            np.asarray(las.z) - origin[2],
        ],
        1,
    )
    rgb = None
    if "red" in las.point_format.dimension_names:
        rgb = (np.stack([las.red, las.green, las.blue], 1) // 257).astype(np.uint8)
    return PointCloud(
        xyz.astype(np.float32),
        np.asarray(las.classification, np.uint16),
        np.asarray(las.instance_id, np.uint32),
        origin,
        rgb,
        camera=np.asarray(las.point_source_id, np.uint16),
    )


def _write_scene(data, folder: Path) -> None:
    times = (data.extra or {}).get("frame_times_s")
    folder.mkdir(parents=True, exist_ok=True)
    for j, (_, tile) in enumerate(data.chunks):
        write(tile, folder / f"cloud_{j:03d}.las", frame_times_s=times)


def _write_cloud(
    cloud: PointCloud, out_dir: str | os.PathLike, *, name: str = "cloud", **_: object
) -> Path:
    return write(cloud, Path(out_dir) / f"{name}.las")


from .registry import DatasetFormat, file_output, register_format  # noqa: E402

DATASET = register_format(
    DatasetFormat(
        "las",
        "scenes",
        write_scene=_write_scene,
        write_cloud=_write_cloud,
        cloud_outputs=file_output("las"),
        description="LAS 1.4 (format 6/7): semantic id in classification, instance id in extra "
        "bytes",
    )
)
