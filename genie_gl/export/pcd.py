"""PCL's PCD, binary: ``x y z rgb`` (packed float as PCL has it) ``label instance``."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..cloud.pointcloud import PointCloud
from ._atomic import atomic_write_bytes


def write(cloud: PointCloud, path: str | os.PathLike) -> Path:
    n = len(cloud)
    names, sizes, types, dtype = ["x", "y", "z"], [4, 4, 4], ["F", "F", "F"], [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if cloud.rgb is not None:
        names.append("rgb"); sizes.append(4); types.append("U"); dtype.append(("rgb", "<u4"))
    names += ["label", "instance"]; sizes += [4, 4]; types += ["U", "U"]
    dtype += [("label", "<u4"), ("instance", "<u4")]
    rec = np.empty(n, dtype=dtype)
    rec["x"], rec["y"], rec["z"] = cloud.xyz.T
    if cloud.rgb is not None:
        c = cloud.rgb.astype(np.uint32)
        rec["rgb"] = (c[:, 0] << 16) | (c[:, 1] << 8) | c[:, 2]
    rec["label"], rec["instance"] = cloud.semantic, cloud.instance
    ox, oy, oz = cloud.origin
    header = (f"# .PCD v0.7 - genie-gl; world = xyz + origin ({ox!r} {oy!r} {oz!r})\nVERSION 0.7\n"
              f"FIELDS {' '.join(names)}\nSIZE {' '.join(map(str, sizes))}\nTYPE {' '.join(types)}\n"
              f"COUNT {' '.join('1' for _ in names)}\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n"
              f"POINTS {n}\nDATA binary\n")
    return atomic_write_bytes(path, header.encode() + rec.tobytes())
