"""NumPy ``.npz``: every PointCloud array under its own name (``origin`` included)."""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from ..cloud.pointcloud import PointCloud
from ..outputs import atomic_write_bytes, check_replaceable


FIELDS = ("xyz", "origin", "semantic", "instance", "rgb", "normal", "camera")


def written_by_genie(path: Path) -> bool:
    """True when ``path`` is a cloud genie-gl wrote: an .npz of a PointCloud's arrays and no
    other."""
    with np.load(path) as z:
        return {"xyz", "origin", "semantic", "instance"} <= set(z.files) <= set(FIELDS)


def write(cloud: PointCloud, path: str | os.PathLike) -> Path:
    """Write ``cloud``'s arrays as .npz; an existing file is replaced only when genie-gl wrote
    it."""
    path = check_replaceable(path, written_by_genie, what="NPZ point cloud")
    arrays = {k: getattr(cloud, k) for k in FIELDS if getattr(cloud, k) is not None}
    buf = io.BytesIO()
    np.savez(buf, **arrays)  # uncompressed: same input, same bytes
    return atomic_write_bytes(path, buf.getvalue())


def read(path: str | os.PathLike) -> PointCloud:
    with np.load(path) as z:
        return PointCloud(**{k: z[k] for k in z.files})


def _write_cloud(
    cloud: PointCloud, out_dir: str | os.PathLike, *, name: str = "cloud", **_: object
) -> Path:
    return write(cloud, Path(out_dir) / f"{name}.npz")


from .registry import DatasetFormat, file_output, register_format, write_chunks  # noqa: E402

DATASET = register_format(
    DatasetFormat(
        "npz",
        "scenes",
        write_scene=write_chunks("npz", write),
        write_cloud=_write_cloud,
        cloud_outputs=file_output("npz"),
        bytes_per_point=40,
        description=__doc__.splitlines()[0],
    )
)
