"""``gg.export_scans``: a recording's scans into a folder, in one of the scanner formats.

- ``kitti``: ``sequences/NN`` per head (head k is sequence k), deskewed scans with remission,
  ``poses.txt``, ``calib.txt``, ``times.txt`` (:mod:`.lidar_sequences`), ``genie-gl.yaml``
  (the label map);
- ``rosbag``: ``bag/``, one ``PointCloud2`` topic per head with the driver's fields;
- ``las``: ``map.las``, every scan fused in the world (LAS 1.4, point format 6);
- ``e57``: ``scans.e57``, a Data3D scan per scan;
- ``pcd`` / ``ply``: ``<head>/NNNNNN.pcd|ply``, each scan raw (as the driver gives it) with
  intensity, ring, time and returns.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from ..capture.scan_record import Scan
from ..cloud.scan_cloud import scan_cloud
from ..errors import ConfigError, ExportError, did_you_mean
from ..outputs import atomic_write_text, claim_folder
from . import pcd, ply
from .lidar_files import write_scans_e57, write_scans_las
from .lidar_sequences import write_kitti_sequence, write_scan_bag
from .semantickitti import label_map_yaml


def _kitti(scans: Sequence[Scan], out: Path) -> list[Path]:
    heads = sorted({s.head_index for s in scans})
    if len(heads) > 100:
        raise ExportError("SemanticKITTI sequences are two digits: at most 100 heads")
    paths = []
    for k in heads:
        paths += write_kitti_sequence(
            [s for s in scans if s.head_index == k], out / "sequences" / f"{k:02d}"
        )
    sem = np.concatenate([s.semantic for s in scans])
    counts = dict(zip(*np.unique(sem, return_counts=True)))
    atomic_write_text(
        out / "genie-gl.yaml", label_map_yaml(counts, {"train": heads, "valid": [], "test": []})
    )
    return paths


def _per_scan(ext: str, write: Callable) -> Callable[[Sequence[Scan], Path], list[Path]]:
    def go(scans: Sequence[Scan], out: Path) -> list[Path]:
        return [write(scan_cloud(s, "raw"), out / s.head / f"{s.index:06d}.{ext}") for s in scans]

    return go


SCAN_FORMATS: dict[str, tuple[Callable[[Sequence[Scan], Path], list[Path]], tuple[str, ...]]] = {
    "kitti": (_kitti, ("sequences", "genie-gl.yaml")),
    "rosbag": (lambda scans, out: [write_scan_bag(scans, out / "bag")], ("bag",)),
    "las": (lambda scans, out: [write_scans_las(scans, out / "map.las")], ("map.las",)),
    "e57": (lambda scans, out: [write_scans_e57(scans, out / "scans.e57")], ("scans.e57",)),
    "pcd": (_per_scan("pcd", pcd.write), ()),
    "ply": (_per_scan("ply", ply.write), ()),
}


def export_scans(
    scans: Sequence[Scan], out_dir: str | os.PathLike, format: str = "kitti"
) -> list[Path]:
    """Write ``scans`` under ``out_dir`` in ``format`` (one of :data:`SCAN_FORMATS`); returns
    the files written. The user's own files in ``out_dir`` are kept; ``manifest.json``
    records what genie-gl wrote."""
    if format not in SCAN_FORMATS:
        raise ConfigError(
            f"scan format {format!r}: unknown{did_you_mean(format, SCAN_FORMATS)}; expected one of "
            f"{', '.join(SCAN_FORMATS)}"
        )
    if not scans or not sum(len(s) for s in scans):
        raise ExportError(f"export to {out_dir}: the scans hold no point; nothing was written")
    write, names = SCAN_FORMATS[format]
    heads = sorted({s.head for s in scans})
    folder = claim_folder(
        out_dir,
        "scan",
        names + (tuple(heads) if format in ("pcd", "ply") else ()),
        option="out_dir",
        reserve=True,
    )
    with folder.abandoning():  # a failed export leaves nothing it wrote
        paths = write(scans, folder.path)
        folder.finish(
            {
                "format": format,
                "scans": len(scans),
                "points": int(sum(len(s) for s in scans)),
                "heads": {h: sorted({s.scanner.name for s in scans if s.head == h}) for h in heads},
            }
        )
    return paths
