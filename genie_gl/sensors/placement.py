"""Sensor placement by a genetic algorithm over the layout's label raster (paper §3.4.1).

A sensor covers a disc of fixed radius on the floor; a chromosome is the list of the disc
centres (indices into candidate positions on a grid); fitness is the weighted area of the
union of the discs (weights per region type; background 0 by default). Elitism keeps the best
chromosome, so the best fitness never decreases across generations. The result becomes camera
poses: each camera at ``mount_height_m`` above its disc's centre, turned towards the weighted
centroid of what its disc covers and tilted down to it.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError
from ..layout.model import Layout
from . import coverage


@dataclass(frozen=True, eq=False)
class Placement:
    """What the search found: disc centres (n, 2) in metres, coverage share, fitness history."""

    centres: np.ndarray
    coverage: float
    history: list[float] = field(default_factory=list)


class CoverageProblem:
    """Weighted coverage of a label raster by discs at candidate positions."""

    def __init__(self, layout: Layout, radius_m: float, resolution_m: float = 0.5, step_m: float = 1.0,
                 weights: dict[str, float] | None = None) -> None:
        if radius_m <= 0:
            raise ConfigError(f"placement: radius_m must be > 0, got {radius_m}")
        r = layout.label_raster(resolution_m)
        types = r.type_names
        w_type = np.array([(weights or {}).get(t, 0.0 if layout.region_types[t].asset_group is None else 1.0)
                           for t in types] + [0.0])
        self.weight = w_type[r.labels].ravel()            # label -1 -> last entry, 0
        H, W = r.labels.shape
        x0, y0 = r.origin_xy
        self.px = np.stack(np.meshgrid(x0 + (np.arange(W) + 0.5) * resolution_m,
                                       y0 + (np.arange(H) + 0.5) * resolution_m), -1).reshape(-1, 2)
        bx, by, bw, bh = layout.bounds
        cx = np.arange(bx + step_m / 2, bx + bw, step_m)
        cy = np.arange(by + step_m / 2, by + bh, step_m)
        self.candidates = np.stack(np.meshgrid(cx, cy), -1).reshape(-1, 2)
        keep = self.weight > 0
        self.px, self.weight = self.px[keep], self.weight[keep]
        index = np.full(H * W, -1, np.int64)
        index[keep] = np.arange(int(keep.sum()))
        # which weighted cells each candidate's disc covers, as a sparse matrix (CSR)
        self.indptr, self.indices = coverage.disc_cells(self.candidates[:, 0].copy(), self.candidates[:, 1].copy(),
                                                        index.reshape(H, W), float(x0), float(y0),
                                                        float(resolution_m), float(radius_m))
        self.total = float(self.weight.sum()) or 1.0
        self._stamp, self._mark = np.zeros(len(self.weight), np.int64), 0

    @property
    def cover(self) -> np.ndarray:
        """(candidates, weighted cells) bool: the discs as a dense matrix (for inspection)."""
        dense = np.zeros((len(self.candidates), len(self.weight)), bool)
        rows = np.repeat(np.arange(len(self.candidates)), np.diff(self.indptr))
        dense[rows, self.indices] = True
        return dense

    def fitnesses(self, population: np.ndarray) -> np.ndarray:
        """Covered weight share of each chromosome (rows of candidate indices)."""
        w, self._mark = coverage.union_weights(np.ascontiguousarray(population, np.int64), self.indptr,
                                               self.indices, self.weight, self._stamp, self._mark)
        return w / self.total

    def fitness(self, chrom: np.ndarray) -> float:
        return float(self.fitnesses(np.asarray(chrom).reshape(1, -1))[0])


def genetic_placement(problem: CoverageProblem, n: int, *, rng: np.random.Generator, population: int = 32,
                      generations: int = 150, mutation: float = 0.05, seed_greedy: bool = True) -> Placement:
    """Maximise covered weight with ``n`` discs; tournament selection, uniform crossover,
    point mutation and one elite. ``seed_greedy`` puts the greedy solution in the first
    population, so the result is never worse than the greedy baseline."""
    m = len(problem.candidates)
    if n < 1 or m == 0:
        raise ConfigError(f"placement: need n >= 1 sensors and a non-empty layout (n={n})")
    pop = rng.integers(0, m, (population, n))
    if seed_greedy:
        pop[0] = greedy_indices(problem, n)
    fit = problem.fitnesses(pop)
    history = [float(fit.max())]
    for _ in range(generations):
        elite = pop[fit.argmax()].copy()
        a, b = rng.integers(0, population, (2, population))
        parents = np.where((fit[a] >= fit[b])[:, None], pop[a], pop[b])
        mates = parents[rng.permutation(population)]
        child = np.where(rng.random((population, n)) < 0.5, parents, mates)
        mut = rng.random((population, n)) < mutation
        child[mut] = rng.integers(0, m, int(mut.sum()))
        child[0] = elite
        pop = child
        fit = problem.fitnesses(pop)
        history.append(float(fit.max()))
    best = pop[fit.argmax()]
    return Placement(problem.candidates[best], float(fit.max()), history)


def greedy_indices(problem: CoverageProblem, n: int) -> np.ndarray:
    """Candidate indices chosen greedily: each adds the most new weight."""
    return coverage.greedy(int(n), problem.indptr, problem.indices, problem.weight)


def greedy_placement(problem: CoverageProblem, n: int) -> Placement:
    """Baseline: add, n times, the disc that covers the most new weight."""
    chosen = greedy_indices(problem, n)
    return Placement(problem.candidates[chosen], problem.fitness(chosen))


def random_placement(problem: CoverageProblem, n: int, *, rng: np.random.Generator) -> Placement:
    """Baseline: n candidate positions drawn uniformly."""
    chosen = rng.integers(0, len(problem.candidates), n)
    return Placement(problem.candidates[chosen], problem.fitness(chosen))


def poses_from_centres(problem: CoverageProblem, centres: np.ndarray, radius_m: float,
                       mount_height_m: float) -> list[np.ndarray]:
    """world_from_camera poses: above each centre, looking at the weighted centroid it covers."""
    from .pose import look_at

    poses = []
    for c in centres:
        inside = ((problem.px - c) ** 2).sum(1) <= radius_m ** 2
        if inside.any():
            target = (problem.px[inside] * problem.weight[inside, None]).sum(0) / problem.weight[inside].sum()
        else:
            target = c
        d = target - c
        if np.linalg.norm(d) < 0.3 * radius_m:  # nothing to turn to: look outwards at half radius
            d = np.array([1.0, 0.0]) if np.linalg.norm(d) < 1e-9 else d / np.linalg.norm(d)
            target = c + 0.5 * radius_m * d
        poses.append(look_at([c[0], c[1], mount_height_m], [target[0], target[1], 0.0]))
    return poses


def place_sensors(layout: Layout, sensor=None, n: int = 8, seed: int = 0, *, radius_m: float = 6.0,
                  mount_height_m: float = 3.5, method: str = "genetic",
                  weights: dict[str, float] | None = None) -> list[np.ndarray]:
    """Place ``n`` cameras over ``layout``; returns (4, 4) float64 world_from_camera poses."""
    problem = CoverageProblem(layout, radius_m, weights=weights)
    rng = np.random.default_rng(seed)
    if method == "genetic":
        result = genetic_placement(problem, n, rng=rng)
    elif method == "greedy":
        result = greedy_placement(problem, n)
    elif method == "random":
        result = random_placement(problem, n, rng=rng)
    else:
        raise ConfigError(f"placement method {method!r} is unknown; expected genetic, greedy or random")
    return poses_from_centres(problem, result.centres, radius_m, mount_height_m)
