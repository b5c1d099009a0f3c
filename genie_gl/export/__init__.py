"""Exports, one module per format: ``gg.export(cloud, out_dir, format=...)``."""
from __future__ import annotations

import os
from pathlib import Path

from ..cloud.pointcloud import PointCloud
from ..errors import ConfigError, did_you_mean
from . import npz, pcd, ply, semantickitti

FORMATS = ("semantickitti", "ply", "pcd", "npz")


def export(cloud: PointCloud, out_dir: str | os.PathLike, format: str = "semantickitti", *,
           name: str = "cloud", sequence: int = 0, frame: int = 0) -> Path:
    """Write ``cloud`` under ``out_dir`` in ``format``; returns the main file written."""
    out = Path(out_dir)
    if format == "semantickitti":
        return semantickitti.write(cloud, out, sequence=sequence, frame=frame)
    if format == "ply":
        return ply.write(cloud, out / f"{name}.ply")
    if format == "pcd":
        return pcd.write(cloud, out / f"{name}.pcd")
    if format == "npz":
        return npz.write(cloud, out / f"{name}.npz")
    raise ConfigError(f"unknown export format {format!r}{did_you_mean(format, FORMATS)} (known: {', '.join(FORMATS)})")


__all__ = ["FORMATS", "export"]


# ``genie_gl.export`` is both this package and the public function ``gg.export(cloud, ...)``
# (DESIGN.md): the package forwards calls to :func:`export`, as ``genie_gl.render`` does.
import sys as _sys  # noqa: E402
import types as _types  # noqa: E402


class _CallableModule(_types.ModuleType):
    def __call__(self, *args, **kwargs):
        return export(*args, **kwargs)


_sys.modules[__name__].__class__ = _CallableModule
