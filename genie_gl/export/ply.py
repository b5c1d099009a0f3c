"""Binary little-endian PLY with ``x y z`` (float), ``red green blue`` (uchar), ``nx ny nz``
(when present), ``semantic`` (ushort) and ``instance`` (uint): reads in plyfile and Open3D."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..cloud.pointcloud import PointCloud
from ._atomic import atomic_write_bytes


def write(cloud: PointCloud, path: str | os.PathLike) -> Path:
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if cloud.normal is not None:
        fields += [("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
    if cloud.rgb is not None:
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    fields += [("semantic", "<u2"), ("instance", "<u4")]
    rec = np.empty(len(cloud), dtype=fields)
    rec["x"], rec["y"], rec["z"] = cloud.xyz.T
    if cloud.normal is not None:
        rec["nx"], rec["ny"], rec["nz"] = cloud.normal.T
    if cloud.rgb is not None:
        rec["red"], rec["green"], rec["blue"] = cloud.rgb.T
    rec["semantic"], rec["instance"] = cloud.semantic, cloud.instance
    ply_type = {"<f4": "float", "u1": "uchar", "<u2": "ushort", "<u4": "uint"}
    header = ["ply", "format binary_little_endian 1.0",
              "comment genie-gl point cloud; world = xyz + origin",
              "comment origin " + " ".join(repr(float(v)) for v in cloud.origin),
              f"element vertex {len(cloud)}"]
    header += [f"property {ply_type[t]} {n}" for n, t in fields]
    header.append("end_header")
    return atomic_write_bytes(path, ("\n".join(header) + "\n").encode() + rec.tobytes())
