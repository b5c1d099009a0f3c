"""PCL's PCD v0.7, binary: ``x y z`` (F), ``rgb`` (U, 0x00RRGGBB as PCL packs it), ``label``
(U, PCL's PointXYZL field) and ``instance`` (U); a scanner's cloud adds the fields of the
Velodyne driver's clouds (LIDAR.md §9.5): ``intensity`` (F 4, reflectivity 0-1), ``ring``
(U 2), ``time`` (F 4, s from the scan start), then ``return_number`` and ``returns`` (U 1).
The header holds only PCD keys and plain numbers; the cloud's float64 origin (world = xyz +
origin) is in a ``#`` comment line."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..cloud.pointcloud import PointCloud
from ..outputs import atomic_write_bytes, check_replaceable


# a scanner's fields, when the cloud has them: (name, PCD type, numpy type)
SCANNER_FIELDS = (
    ("intensity", "F", "<f4"),
    ("ring", "U", "<u2"),
    ("time", "F", "<f4"),
    ("return_number", "U", "u1"),
    ("returns", "U", "u1"),
)


def written_by_genie(path: Path) -> bool:
    """True when ``path`` is a PCD file genie-gl wrote (its header's comment)."""
    with open(path, "rb") as fh:
        return b"genie-gl point cloud" in fh.read(256)


def write(cloud: PointCloud, path: str | os.PathLike) -> Path:
    """Write ``cloud`` as binary PCD; an existing file is replaced only when genie-gl wrote it."""
    path = check_replaceable(path, written_by_genie, what="PCD point cloud")
    n = len(cloud)
    names, types = ["x", "y", "z"], ["F", "F", "F"]
    dtype = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if cloud.rgb is not None:
        names.append("rgb")
        types.append("U")
        dtype.append(("rgb", "<u4"))  # noqa: E702
    names += ["label", "instance"]
    types += ["U", "U"]  # noqa: E702
    dtype += [("label", "<u4"), ("instance", "<u4")]
    scanner = [(k, t, d) for k, t, d in SCANNER_FIELDS if getattr(cloud, k) is not None]
    names += [k for k, _, _ in scanner]
    types += [t for _, t, _ in scanner]  # noqa: E702
    dtype += [(k, d) for k, _, d in scanner]
    rec = np.empty(n, dtype=dtype)
    rec["x"], rec["y"], rec["z"] = cloud.xyz.T
    if cloud.rgb is not None:
        c = cloud.rgb.astype(np.uint32)
        rec["rgb"] = (c[:, 0] << 16) | (c[:, 1] << 8) | c[:, 2]
    rec["label"], rec["instance"] = cloud.semantic, cloud.instance
    for k, _, _ in scanner:
        rec[k] = getattr(cloud, k)
    origin = " ".join(f"{float(v):.17g}" for v in cloud.origin)
    sizes = " ".join(str(np.dtype(d).itemsize) for _, d in dtype)
    header = (
        f"# .PCD v0.7 - genie-gl point cloud; world = xyz + origin {origin}\nVERSION 0.7\n"
        f"FIELDS {' '.join(names)}\nSIZE {sizes}\nTYPE {' '.join(types)}\n"
        f"COUNT {' '.join('1' for _ in names)}\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n"
        f"POINTS {n}\nDATA binary\n"
    )
    return atomic_write_bytes(path, header.encode() + rec.tobytes())


def _write_cloud(
    cloud: PointCloud, out_dir: str | os.PathLike, *, name: str = "cloud", **_: object
) -> Path:
    return write(cloud, Path(out_dir) / f"{name}.pcd")


from .registry import DatasetFormat, file_output, register_format, write_chunks  # noqa: E402

DATASET = register_format(
    DatasetFormat(
        "pcd",
        "scenes",
        write_scene=write_chunks("pcd", write),
        write_cloud=_write_cloud,
        cloud_outputs=file_output("pcd"),
        bytes_per_point=24,
        description=__doc__.splitlines()[0],
    )
)
