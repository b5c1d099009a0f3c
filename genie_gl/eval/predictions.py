"""Predictions written as SemanticKITTI ``.label`` files in the test set's own layout, so the
field's evaluator (semantic-kitti-api: ``auxiliary.np_ioueval.iouEval``, its
``evaluate_semantics.py``) reads them beside the ground truth:

- a SemanticKITTI set: ``OUT/sequences/NN/predictions/NNNNNN.label``, the layout the API's
  evaluation script takes as ``--predictions OUT``, labels in the set's own raw ids (each of our
  classes written as the smallest raw id the label map sends to it);
- a PLY or NPZ set: ``OUT/scenes/NNNN/cloud_XXX.label`` beside each cloud's name.

Each file is ``uint32`` little-endian, one per point in the scan's order, ``(instance << 16) |
class`` (the instance half 0 when no instance ids are given), written to a temporary name and
renamed.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..outputs import atomic_write_bytes
from .data import EvalSet


def label_path(out: Path, key: str, fmt: str) -> Path:
    """Where the prediction of the scan at ``key`` goes under ``out``."""
    parts = key.split("/")
    if fmt == "semantickitti":  # sequences/NN/NNNNNN
        return out / parts[0] / parts[1] / "predictions" / f"{parts[2]}.label"
    return out / "/".join(parts[:-1]) / f"{parts[-1]}.label"


def write(
    test: EvalSet,
    pred: np.ndarray,
    out: str | os.PathLike,
    instances: Sequence[np.ndarray] | None = None,
) -> list[Path]:
    """Write ``pred`` ((test.n_points,) our class ids, scans in order) as ``.label`` files,
    with ``instances`` (one (N_i,) array of ids below 2**16 per scan) in the upper half.

    Returns the paths, in scan order.
    """
    out = Path(out)
    inverse = test.label_map.inverse()
    if pred.size and int(pred.max()) >= len(inverse):
        inverse = np.concatenate(
            [inverse, np.arange(len(inverse), int(pred.max()) + 1, dtype=np.uint32)]
        )
    paths, start = [], 0
    for i, scan in enumerate(test.scans):
        p = pred[start : start + len(scan)]
        start += len(scan)
        raw = inverse[p.astype(np.int64)].astype("<u4")
        if instances is not None:
            raw = raw | (np.asarray(instances[i]).astype("<u4") << 16)
        paths.append(atomic_write_bytes(label_path(out, scan.key, test.format), raw.tobytes()))
    return paths


def read(test: EvalSet, out: str | os.PathLike) -> Sequence[np.ndarray]:
    """The raw labels written for each scan of ``test`` (uint32), in scan order."""
    out = Path(out)
    return [np.fromfile(label_path(out, s.key, test.format), dtype="<u4") for s in test.scans]
