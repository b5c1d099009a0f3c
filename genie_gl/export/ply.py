"""Binary little-endian PLY with ``x y z`` (float), ``nx ny nz`` (when present), ``red green
blue`` (uchar), ``semantic`` and ``instance`` (int, i.e. int32): the types that plyfile,
CloudCompare and Open3D's tensor reader all keep (Open3D skips ``ushort`` and ``uint``).
Instance ids above 2**31 - 1 (rare: ids are per scene) are written as ``uint`` instead, so the
full uint32 range is kept (plyfile, CloudCompare), with a warning that Open3D skips them.
A scanner's cloud adds ``intensity`` (float), ``ring`` (ushort), ``time`` (double, s from the
scan start), ``return_number`` and ``returns`` (uchar)."""

from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np

from ..cloud.pointcloud import PointCloud
from ..outputs import atomic_write_bytes, check_replaceable

INT32_MAX = 2**31 - 1
PLY_TYPE = {
    "<f4": "float",
    "u1": "uchar",
    "<i4": "int",
    "<u4": "uint",
    "<u2": "ushort",
    "<f8": "double",
}
SCANNER_FIELDS = (
    ("intensity", "<f4"),
    ("ring", "<u2"),
    ("time", "<f8"),
    ("return_number", "u1"),
    ("returns", "u1"),
)
log = logging.getLogger(__name__)


def written_by_genie(path: Path) -> bool:
    """True when ``path`` is a PLY file genie-gl wrote (its header's comment)."""
    with open(path, "rb") as fh:
        return b"comment genie-gl point cloud" in fh.read(512)


def write(cloud: PointCloud, path: str | os.PathLike) -> Path:
    """Write ``cloud`` as binary PLY; an existing file is replaced only when genie-gl wrote it."""
    path = check_replaceable(path, written_by_genie, what="PLY point cloud")
    wide = bool(len(cloud)) and int(cloud.instance.max()) > INT32_MAX
    if (
        wide
    ):  # the full uint32 range kept (plyfile, CloudCompare); Open3D's tensor reader skips uint
        log.warning(
            "%s: instance ids above %d written as PLY uint, which Open3D's tensor reader skips",
            path,
            INT32_MAX,
        )
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if cloud.normal is not None:
        fields += [("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
    if cloud.rgb is not None:
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    fields += [("semantic", "<i4"), ("instance", "<u4" if wide else "<i4")]
    scanner = [(k, t) for k, t in SCANNER_FIELDS if getattr(cloud, k) is not None]
    fields += scanner
    rec = np.empty(len(cloud), dtype=fields)
    rec["x"], rec["y"], rec["z"] = cloud.xyz.T
    if cloud.normal is not None:
        rec["nx"], rec["ny"], rec["nz"] = cloud.normal.T
    if cloud.rgb is not None:
        rec["red"], rec["green"], rec["blue"] = cloud.rgb.T
    rec["semantic"], rec["instance"] = cloud.semantic, cloud.instance
    for k, _ in scanner:
        rec[k] = getattr(cloud, k)
    header = [
        "ply",
        "format binary_little_endian 1.0",
        "comment genie-gl point cloud; world = xyz + origin",
        "comment origin " + " ".join(f"{float(v):.17g}" for v in cloud.origin),
        f"element vertex {len(cloud)}",
    ]
    header += [f"property {PLY_TYPE[t]} {n}" for n, t in fields]
    header.append("end_header")
    return atomic_write_bytes(path, ("\n".join(header) + "\n").encode() + rec.tobytes())


def _write_cloud(
    cloud: PointCloud, out_dir: str | os.PathLike, *, name: str = "cloud", **_: object
) -> Path:
    return write(cloud, Path(out_dir) / f"{name}.ply")


from .registry import DatasetFormat, file_output, register_format, write_chunks  # noqa: E402

DATASET = register_format(
    DatasetFormat(
        "ply",
        "scenes",
        write_scene=write_chunks("ply", write),
        write_cloud=_write_cloud,
        cloud_outputs=file_output("ply"),
        bytes_per_point=35,
        description=__doc__.splitlines()[0],
    )
)
