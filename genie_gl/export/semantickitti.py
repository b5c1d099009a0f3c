"""SemanticKITTI: ``sequences/NN/velodyne/NNNNNN.bin``, ``labels/NNNNNN.label``, ``poses.txt``,
``calib.txt``, ``times.txt``, and a label-map YAML with SemanticKITTI's key names.

Points are written in the scan frame: the cloud's own frame (world minus its origin), and the
scan's pose (``poses.txt``) is the translation to the origin, so ``pose @ xyz`` is the world.
Labels: ``(instance << 16) | semantic`` as little-endian uint32.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import yaml

from ..cloud.pointcloud import PointCloud
from ._atomic import atomic_write_bytes, atomic_write_text

CLASSES = {0: "background", 1: "pallet", 2: "rack", 3: "car", 4: "jack", 5: "stillage", 6: "cabinet",
           7: "dolly", 8: "forklift", 9: "small_load_carrier"}
COLORS_RGB = {0: (170, 170, 160), 1: (141, 110, 99), 2: (94, 53, 177), 3: (229, 57, 53), 4: (240, 98, 146),
              5: (67, 160, 71), 6: (0, 137, 123), 7: (253, 216, 53), 8: (251, 140, 0), 9: (30, 136, 229)}


def label_map_yaml(counts: dict[int, int] | None = None) -> str:
    total = sum((counts or {}).values()) or 1
    data = {
        "name": "genie-gl",
        "labels": CLASSES,
        "color_map": {k: [c[2], c[1], c[0]] for k, c in COLORS_RGB.items()},  # BGR, as SemanticKITTI
        "content": {k: float((counts or {}).get(k, 0)) / total for k in CLASSES},
        "learning_map": {k: k for k in CLASSES},
        "learning_map_inv": {k: k for k in CLASSES},
        "learning_ignore": {k: k == 0 for k in CLASSES},
        "split": {"train": [], "valid": [], "test": []},
    }
    return yaml.safe_dump(data, sort_keys=False)


def pack_labels(semantic: np.ndarray, instance: np.ndarray) -> np.ndarray:
    """``(instance << 16) | semantic`` as '<u4' (instance ids above 65535 wrap: warn upstream)."""
    return ((instance.astype(np.uint32) & 0xFFFF) << 16 | semantic.astype(np.uint32)).astype("<u4")


def write(cloud: PointCloud, out_dir: str | os.PathLike, *, sequence: int = 0, frame: int = 0,
          time_s: float | None = None, digits: int = 2) -> Path:
    """Append ``cloud`` as scan ``frame`` of ``sequence`` under ``out_dir``; returns the .bin path."""
    root = Path(out_dir)
    seq = root / "sequences" / f"{sequence:0{digits}d}"
    scan = np.zeros((len(cloud), 4), "<f4")
    scan[:, :3] = cloud.xyz
    bin_path = atomic_write_bytes(seq / "velodyne" / f"{frame:06d}.bin", scan.tobytes())
    atomic_write_bytes(seq / "labels" / f"{frame:06d}.label", pack_labels(cloud.semantic, cloud.instance).tobytes())
    pose = np.eye(4)[:3]
    pose[:, 3] = cloud.origin
    lines = {}
    for name, line in (("poses.txt", " ".join(f"{v:.12e}" for v in pose.ravel())),
                       ("times.txt", f"{(frame if time_s is None else time_s):e}")):
        p = seq / name
        old = p.read_text().splitlines() if p.exists() else []
        old = (old + [""] * (frame + 1))[: max(len(old), frame + 1)]
        old[frame] = line
        lines[name] = "\n".join(old) + "\n"
        atomic_write_text(p, lines[name])
    eye = " ".join(f"{v:.12e}" for v in np.eye(4)[:3].ravel())
    atomic_write_text(seq / "calib.txt", "".join(f"{k}: {eye}\n" for k in ("P0", "P1", "P2", "P3", "Tr")))
    counts = dict(zip(*np.unique(cloud.semantic, return_counts=True)))
    cfg = root / "genie-gl.yaml"
    if not cfg.exists():
        atomic_write_text(cfg, label_map_yaml({int(k): int(v) for k, v in counts.items()}))
    return bin_path


def read(bin_path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read a scan back as the SemanticKITTI API does: (xyz, semantic, instance)."""
    bin_path = Path(bin_path)
    scan = np.fromfile(bin_path, dtype="<f4").reshape(-1, 4)
    label = np.fromfile(bin_path.parent.parent / "labels" / (bin_path.stem + ".label"), dtype="<u4")
    return scan[:, :3], label & 0xFFFF, label >> 16
