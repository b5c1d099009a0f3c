"""Instance ids from per-point classes, on the CPU: each thing class of a scan clustered in
space with scikit-learn's DBSCAN, and the two baselines the clustering is judged against.

- :func:`cluster` (the instance model): per scan and per thing class, DBSCAN on the points'
  xyz (``eps_m``, ``min_samples``); a point DBSCAN leaves as noise joins the cluster of its
  nearest clustered point of the same class (none: the class is one instance). Given the
  model's predicted classes it is the panoptic model; given the true classes it shows what the
  clustering alone loses (every panoptic error then comes from it; not a strict upper bound: a
  wrong class can happen to cut two touching objects apart).
- :func:`one_per_class` (the floor): each thing class of a scan is one instance.

DBSCAN's radius is chosen per thing class by :func:`tune` on training scans (their true classes
and instances; never the test set): the radius of :data:`EPS_GRID_M` with the best PQ.

Stuff (:data:`.panoptic.STUFF`) gets instance 0. Ids are 1, 2, ... per scan, unique across
classes, below 2**16 (SemanticKITTI's labels hold 16 bits); DBSCAN is deterministic, so the
same classes give the same ids.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree
from sklearn.cluster import DBSCAN

from ..errors import ConfigError
from .panoptic import STUFF, PanopticCounts, panoptic_scores, stuff_free

MAX_ID = 0xFFFF


EPS_GRID_M = (0.05, 0.1, 0.2, 0.3)  # the radii :func:`tune` tries
TUNE_SCANS = 16  # training scans :func:`tune` looks at (evenly spread)


@dataclass(frozen=True)
class ClusterParams:
    """DBSCAN's settings: the neighbourhood radius (m; per class in ``eps_by_class``, pairs of
    (class, radius), else ``eps_m``) and the points a core point needs within it (itself
    included)."""

    eps_m: float = 0.2
    min_samples: int = 4
    eps_by_class: tuple[tuple[int, float], ...] = ()

    def __post_init__(self) -> None:
        if (
            not self.eps_m > 0
            or self.min_samples < 1
            or any(not e > 0 for _, e in self.eps_by_class)
        ):
            raise ConfigError(
                f"cluster settings: radii > 0 and min_samples >= 1 expected, got {self}"
            )

    def eps(self, c: int) -> float:
        return dict(self.eps_by_class).get(int(c), self.eps_m)


def _dbscan(xyz: np.ndarray, eps_m: float, min_samples: int) -> np.ndarray:
    lab = DBSCAN(eps=eps_m, min_samples=min_samples, algorithm="kd_tree").fit_predict(xyz)
    noise = lab < 0
    if noise.all():
        return np.zeros(len(xyz), np.int64)
    if noise.any():
        _, j = cKDTree(xyz[~noise]).query(xyz[noise], k=1)
        lab[noise] = lab[~noise][j]
    return lab.astype(np.int64)


def cluster(
    xyz: np.ndarray,
    sem: np.ndarray,
    params: ClusterParams = ClusterParams(),
    stuff: Iterable[int] = STUFF,
) -> np.ndarray:
    """Instance ids of one scan's points.

    Parameters
    ----------
    xyz : (N, 3) float, metres
    sem : (N,) int, the points' classes (-1: unlabelled, left at 0)
    params : DBSCAN's settings

    Returns
    -------
    (N,) uint32, 0 for stuff and unlabelled points.
    """
    xyz = np.asarray(xyz, np.float64)
    sem = np.asarray(sem).astype(np.int64)
    if xyz.shape != (len(sem), 3):
        raise ConfigError(
            f"cluster: (N, 3) points for N classes expected, got {xyz.shape} and {sem.shape}"
        )
    out = np.zeros(len(sem), np.uint32)
    stuff = set(int(s) for s in stuff)
    next_id = 1
    for c in np.unique(sem):
        if c < 0 or int(c) in stuff:
            continue
        idx = np.flatnonzero(sem == c)
        lab = _dbscan(xyz[idx], params.eps(int(c)), params.min_samples)
        uniq, lab = np.unique(lab, return_inverse=True)
        out[idx] = np.minimum(
            next_id + lab, MAX_ID
        )  # beyond 65535 clusters in a scan the last share an id
        next_id = min(next_id + len(uniq), MAX_ID)
    return out


def one_per_class(sem: np.ndarray, stuff: Iterable[int] = STUFF) -> np.ndarray:
    """Instance ids of one scan when each thing class is one instance: (N,) uint32, the class
    id + 1 (0 for stuff and unlabelled points)."""
    sem = np.asarray(sem).astype(np.int64)
    out = np.where(sem >= 0, sem + 1, 0).astype(np.uint32)
    out[np.isin(sem, np.asarray(list(stuff), np.int64))] = 0
    return out


def scan_instances(
    xyz: Sequence[np.ndarray],
    sem: Sequence[np.ndarray],
    method: str = "cluster",
    params: ClusterParams = ClusterParams(),
    stuff: Iterable[int] = STUFF,
) -> list[np.ndarray]:
    """Instance ids of each scan (``method``: ``cluster`` or ``one_per_class``)."""
    if method == "cluster":
        return [cluster(x, s, params, stuff) for x, s in zip(xyz, sem, strict=True)]
    if method == "one_per_class":
        return [one_per_class(s, stuff) for s in sem]
    raise ConfigError(f"instances: unknown method {method!r} (cluster or one_per_class)")


def tune(
    xyz: Sequence[np.ndarray],
    sem: Sequence[np.ndarray],
    inst: Sequence[np.ndarray],
    n_classes: int,
    *,
    grid: Sequence[float] = EPS_GRID_M,
    min_samples: int = 4,
    max_scans: int = TUNE_SCANS,
    stuff: Iterable[int] = STUFF,
) -> ClusterParams:
    """DBSCAN's radius per thing class: of ``grid``, the one whose clusters of the true classes
    reach the best PQ on (at most ``max_scans``, evenly spread) training scans; ties go to the
    smaller radius, a class with no segment keeps the middle of the grid.

    Parameters
    ----------
    xyz, sem, inst : one (N_i, 3) / (N_i,) / (N_i,) array per scan: points (m), true classes, true
    ids
    """
    if not len(xyz):
        raise ConfigError("cluster tuning: no training scan")
    pick = np.unique(np.linspace(0, len(xyz) - 1, min(max_scans, len(xyz))).round().astype(int))
    stuff = tuple(stuff)
    present = sorted({int(c) for i in pick for c in np.unique(sem[i]) if c >= 0})
    things = [c for c in present if c not in stuff]
    best: dict[int, tuple[float, float]] = {}
    for eps in grid:
        p = ClusterParams(eps_m=float(eps), min_samples=min_samples)
        counts = PanopticCounts(n_classes)
        for i in pick:
            s = np.asarray(sem[i]).astype(np.int64)
            counts.add(s, stuff_free(s, inst[i], stuff), s, cluster(xyz[i], s, p, stuff), things)
        scores = panoptic_scores(counts, things or [0], np.ones(n_classes), stuff)
        for c in things:
            if c not in best or scores.pq[c] > best[c][0]:
                best[c] = (float(scores.pq[c]), float(eps))
    return ClusterParams(
        eps_m=float(grid[len(grid) // 2]),
        min_samples=min_samples,
        eps_by_class=tuple((c, e) for c, (_, e) in sorted(best.items())),
    )
