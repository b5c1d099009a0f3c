"""Binary little-endian PLY with ``x y z`` (float), ``nx ny nz`` (when present), ``red green
blue`` (uchar), ``semantic`` and ``instance`` (int, i.e. int32): the types that plyfile,
CloudCompare and Open3D's tensor reader all keep (Open3D skips ``ushort`` and ``uint``)."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..cloud.pointcloud import PointCloud
from ..errors import ExportError
from ._atomic import atomic_write_bytes

INT32_MAX = 2**31 - 1
PLY_TYPE = {"<f4": "float", "u1": "uchar", "<i4": "int"}


def write(cloud: PointCloud, path: str | os.PathLike) -> Path:
    if len(cloud) and int(cloud.instance.max()) > INT32_MAX:
        raise ExportError(f"{path}: instance id {int(cloud.instance.max())} exceeds the PLY int range "
                          f"({INT32_MAX}); use npz, which keeps uint32")
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if cloud.normal is not None:
        fields += [("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
    if cloud.rgb is not None:
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    fields += [("semantic", "<i4"), ("instance", "<i4")]
    rec = np.empty(len(cloud), dtype=fields)
    rec["x"], rec["y"], rec["z"] = cloud.xyz.T
    if cloud.normal is not None:
        rec["nx"], rec["ny"], rec["nz"] = cloud.normal.T
    if cloud.rgb is not None:
        rec["red"], rec["green"], rec["blue"] = cloud.rgb.T
    rec["semantic"], rec["instance"] = cloud.semantic, cloud.instance
    header = ["ply", "format binary_little_endian 1.0",
              "comment genie-gl point cloud; world = xyz + origin",
              "comment origin " + " ".join(f"{float(v):.17g}" for v in cloud.origin),
              f"element vertex {len(cloud)}"]
    header += [f"property {PLY_TYPE[t]} {n}" for n, t in fields]
    header.append("end_header")
    return atomic_write_bytes(path, ("\n".join(header) + "\n").encode() + rec.tobytes())


def _write_cloud(cloud: PointCloud, out_dir: str | os.PathLike, *, name: str = "cloud", **_: object) -> Path:
    return write(cloud, Path(out_dir) / f"{name}.ply")


from .registry import DatasetFormat, register_format, write_chunks  # noqa: E402

DATASET = register_format(DatasetFormat("ply", "scenes", write_scene=write_chunks("ply", write),
                                        write_cloud=_write_cloud, description=__doc__.splitlines()[0]))
