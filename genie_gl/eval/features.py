"""Per-point geometric features for the classical model: eigenvalue features at several
neighbourhood sizes, density, height above the floor and the height of the column a point
stands in.

At each of ``SCALES`` (the k nearest neighbours, 10/20/50 by default; one k-d tree query of the
largest k with pgeof's nanoflann search) pgeof gives linearity, planarity, scattering,
verticality, the normal's z, length, surface, volume and curvature (Demantké et al. 2011;
Weinmann et al. 2015); beside them, the distance to the k-th neighbour (log: local density),
the point's height above its scan's floor, its height above the mean of its largest
neighbourhood and that neighbourhood's z spread, and for 2D cells of ``COLUMN_CELLS_M`` the
highest point's height above the floor, the point's depth below it and the cell's point count
(log). Features are computed per scan (a chunk is a scene's 12 m tile), so every point's
features depend on its own scan only, in any order and with any worker count.

The normal's x and y are left out: they say which way an object is turned, not what it is.
"""

from __future__ import annotations

import hashlib
from importlib.metadata import PackageNotFoundError, version
import json
import logging
import os
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

import pgeof
from tqdm import tqdm

from .data import Scan, group_of

log = logging.getLogger(__name__)

SCALES: tuple[int, ...] = (10, 20, 50)
COLUMN_CELLS_M: tuple[float, ...] = (0.5, 1.5)
EIGEN = (
    "linearity",
    "planarity",
    "scattering",
    "verticality",
    "normal_z",
    "length",
    "surface",
    "volume",
    "curvature",
)
_PGEOF_COLUMNS = (0, 1, 2, 3, 6, 7, 8, 9, 10)  # pgeof's 11 columns, less normal_x, normal_y
VERSION = 1  # bump when a feature changes: the on-disk cache keys on it


def names(scales: Sequence[int] = SCALES, cells: Sequence[float] = COLUMN_CELLS_M) -> list[str]:
    """Feature names, in column order."""
    out = [f"{e}_k{k}" for k in scales for e in EIGEN]
    out += [f"log_r_k{k}" for k in scales]
    out += ["height", "height_above_neighbours", "neighbour_z_std"]
    out += [
        f"{f}_{c:g}m" for c in cells for f in ("column_top", "below_column_top", "column_log_count")
    ]
    return out


HEIGHT_COLUMN = names().index("height")


def _columns(xy: np.ndarray, height: np.ndarray, cell: float) -> np.ndarray:
    """(N, 3): the cell's top height, the point's depth below it, log(1 + points in the cell)."""
    ij = np.floor(xy / cell).astype(np.int64)
    ij -= ij.min(0)
    key = ij[:, 0] * (int(ij[:, 1].max()) + 1) + ij[:, 1]
    _, inverse, count = np.unique(key, return_inverse=True, return_counts=True)
    top = np.full(len(count), -np.inf, np.float32)
    np.maximum.at(top, inverse, height)
    t = top[inverse]
    return np.stack([t, t - height, np.log1p(count[inverse]).astype(np.float32)], 1)


def scan_features(
    xyz: np.ndarray,
    height: np.ndarray,
    scales: Sequence[int] = SCALES,
    cells: Sequence[float] = COLUMN_CELLS_M,
) -> np.ndarray:
    """Features of one scan.

    Parameters
    ----------
    xyz : (N, 3) float32
        Points, metres (any frame with z up).
    height : (N,) float32
        Height above the floor, metres.

    Returns
    -------
    (N, len(names(scales, cells))) float32
    """
    xyz = np.ascontiguousarray(xyz, np.float32)
    n = len(xyz)
    k_max = int(max(scales))
    k = min(k_max, n)
    nn, d2 = pgeof.knn_search(xyz, xyz, k)
    if k < k_max:  # a scan smaller than the largest neighbourhood: repeat its farthest neighbour
        nn = np.concatenate([nn, np.repeat(nn[:, -1:], k_max - k, 1)], 1)
        d2 = np.concatenate([d2, np.repeat(d2[:, -1:], k_max - k, 1)], 1)
    ptr = np.arange(0, n * k_max + 1, k_max, dtype=np.uint32)
    eig = pgeof.compute_features_multiscale(
        xyz, np.ascontiguousarray(nn.ravel(), np.uint32), ptr, list(scales)
    )
    eig = eig[:, :, _PGEOF_COLUMNS]
    eig[:, :, 4] = np.abs(eig[:, :, 4])
    cols = [eig.reshape(n, -1)]
    cols.append(np.stack([0.5 * np.log(d2[:, kk - 1] + 1e-8) for kk in scales], 1))
    hn = height[nn]  # (N, k_max)
    cols.append(np.stack([height, height - hn.mean(1), hn.std(1)], 1))
    for c in cells:
        cols.append(_columns(xyz[:, :2], height, c))
    return np.concatenate(cols, 1).astype(np.float32)


def _one(args: tuple[np.ndarray, np.ndarray, tuple[int, ...], tuple[float, ...]]) -> np.ndarray:
    return scan_features(*args)


def _code_version() -> str:
    """genie-gl's and pgeof's versions: a new release may compute a feature differently."""
    found = []
    for dist in ("genie-gl", "pgeof"):
        try:
            found.append(version(dist))
        except PackageNotFoundError:
            found.append("?")
    return f"genie-gl {found[0]}, pgeof {found[1]}, features {VERSION}"


def _key(scan: Scan, scales: Sequence[int], cells: Sequence[float]) -> str:
    """The cache name of a scan's features: a hash of everything they depend on (the points
    as read, with their pose, calibration, origin and floor: :attr:`Scan.digest`), the
    settings and the code's version; never of a file's name, size or time."""
    text = json.dumps(
        [_code_version(), [int(k) for k in scales], [float(c) for c in cells], scan.digest]
    )
    return hashlib.sha256(text.encode()).hexdigest()[:40]


def scans_features(
    scans: Sequence[Scan],
    *,
    workers: int = 1,
    cache: str | os.PathLike | None = None,
    scales: Sequence[int] = SCALES,
    cells: Sequence[float] = COLUMN_CELLS_M,
    progress: bool = False,
) -> np.ndarray:
    """Features of every point of ``scans``, in order: (sum of N, F) float32.

    ``workers`` processes share the scans (the result does not depend on it); with ``cache``,
    a folder, each scan's array is kept there under a hash of its points as read (the scan,
    its pose and calibration, its origin and floor), the settings and the code's version, and
    read back the next time.
    """
    width = len(names(scales, cells))
    parts: list[np.ndarray | None] = [None] * len(scans)
    paths: list[Path | None] = [None] * len(scans)
    todo = []
    for i, scan in enumerate(scans):
        if cache is not None:
            paths[i] = Path(cache) / f"{_key(scan, scales, cells)}.npy"
            if paths[i].exists():
                try:
                    arr = np.load(paths[i], allow_pickle=False)
                except (OSError, ValueError, EOFError):  # a damaged cache file: computed again
                    arr = None
                if arr is not None and arr.shape == (len(scan), width) and arr.dtype == np.float32:
                    parts[i] = arr
                    continue
        todo.append(i)
    bar = None
    if progress and todo:
        bar = tqdm(total=len(todo), desc="features", unit="scan", leave=False)
    jobs = [(scans[i].xyz, scans[i].height, tuple(scales), tuple(cells)) for i in todo]
    results = (
        ProcessPoolExecutor(workers).map(_one, jobs, chunksize=max(1, len(jobs) // (8 * workers)))
        if workers > 1 and len(jobs) > 1
        else map(_one, jobs)
    )
    for i, arr in zip(todo, results):
        parts[i] = arr
        if paths[i] is not None:
            p = paths[i]
            p.parent.mkdir(parents=True, exist_ok=True)
            tmp = p.with_name(f".{p.name}.{os.getpid()}.tmp")
            with open(tmp, "wb") as fh:
                np.save(fh, arr)
            tmp.replace(p)
        if bar is not None:
            bar.update()
    if bar is not None:
        bar.close()
    if not parts:
        return np.zeros((0, width), np.float32)
    return np.concatenate(parts, 0)


class PointTable:
    """The points of some scans as a model sees them: classes, scene groups and (computed on
    first use, cached) features.

    Attributes
    ----------
    scans : list[Scan]
    labels : (N,) int16
        Classes after the protocol's class map; -1 unlabelled.
    groups : (N,) int32
        Index of each point's scene (sequence or scene folder) among ``scans``' scenes.
    """

    def __init__(
        self,
        scans: Sequence[Scan],
        *,
        class_map: np.ndarray | None = None,
        workers: int = 1,
        cache: str | os.PathLike | None = None,
        progress: bool = False,
    ) -> None:
        self.scans = list(scans)
        lab = np.concatenate([s.label for s in self.scans]) if self.scans else np.zeros(0, np.int16)
        if class_map is not None:
            lab = np.where(lab >= 0, class_map[np.maximum(lab, 0)], -1).astype(np.int16)
        self.labels = lab
        keys = [group_of(s) for s in self.scans]
        ids = {k: i for i, k in enumerate(dict.fromkeys(keys))}
        self.groups = np.repeat(
            np.array([ids[k] for k in keys], np.int32), [len(s) for s in self.scans]
        )
        self._features: np.ndarray | None = None
        self._opts = {"workers": workers, "cache": cache, "progress": progress}

    def __len__(self) -> int:
        return len(self.labels)

    @property
    def features(self) -> np.ndarray:
        if self._features is None:
            self._features = scans_features(self.scans, **self._opts)
        return self._features
