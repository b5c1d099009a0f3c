"""Placement fitness against coverage counted independently of CoverageProblem: cell centres
and candidate grid from the layout's own geometry, one loop per cell (a wrong coverage count
would otherwise be silent: the GA just optimises the wrong number)."""

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.placement.genetic import CoverageProblem, greedy_placement


def reference(layout, radius, res, step, weights=None):
    """(cell centres, their weights, candidate centres), counted cell by cell from the leaves."""
    bx, by, bw, bh = layout.bounds
    leaves = list(layout.leaves())
    centres, wts = [], []
    for j in range(int(np.ceil(bh / res - 1e-9))):
        for i in range(int(np.ceil(bw / res - 1e-9))):
            x, y = bx + (i + 0.5) * res, by + (j + 0.5) * res
            owner = None
            for r in leaves:  # later leaves over earlier ones; a leaf owns [x, x + w) x [y, y + h)
                if r.x - 1e-9 <= x < r.x + r.w - 1e-9 and r.y - 1e-9 <= y < r.y + r.h - 1e-9:
                    owner = r.type
            if owner is None:
                continue
            default = 0.0 if layout.region_types[owner].asset_group is None else 1.0
            w = (weights or {}).get(owner, default)
            if w > 0:
                centres.append((x, y))
                wts.append(w)
    cands = [
        (x, y)
        for y in np.arange(by + step / 2, by + bh, step)
        for x in np.arange(bx + step / 2, bx + bw, step)
    ]
    return np.array(centres), np.array(wts), np.array(cands)


@pytest.mark.parametrize(
    "strategy,radius,weights",
    [
        ("storage_area", 3.0, None),
        ("assembly_line", 4.5, None),
        ("storage_area", 2.0, {"rack": 3.0, "hall": 0.5}),
    ],
)
def test_fitness_is_the_covered_weight_share_counted_cell_by_cell(strategy, radius, weights):
    layout = gg.generate_layout(strategy, seed=2)
    res, step = 0.5, 1.5
    px, w, cands = reference(layout, radius, res, step, weights)
    p = CoverageProblem(layout, radius, resolution_m=res, step_m=step, weights=weights)
    np.testing.assert_allclose(p.candidates, cands, atol=1e-9)
    assert p.total == pytest.approx(w.sum(), rel=1e-12)
    rng = np.random.default_rng(5)
    pop = rng.integers(0, len(cands), (10, 6))
    pop[1] = pop[1, 0]  # one disc repeated: counted once
    expected = []
    for chrom in pop:
        hit = np.zeros(len(px), bool)
        for c in chrom:
            hit |= np.hypot(*(px - cands[c]).T) <= radius
        expected.append(w[hit].sum() / w.sum())
    np.testing.assert_allclose(p.fitnesses(pop), expected, rtol=1e-12)
    np.testing.assert_allclose([p.fitness(c) for c in pop], expected, rtol=1e-12)
    assert sum(e > 0 for e in expected) >= 5 and max(expected) < 1  # not a trivial all-or-nothing


def test_greedy_takes_the_disc_with_most_new_weight_each_time():
    layout = gg.generate_layout("storage_area", seed=2)
    radius, res, step = 3.0, 0.5, 1.5
    px, w, cands = reference(layout, radius, res, step)
    p = CoverageProblem(layout, radius, resolution_m=res, step_m=step)
    inside = (
        np.hypot(px[None, :, 0] - cands[:, None, 0], px[None, :, 1] - cands[:, None, 1]) <= radius
    )
    hit, best = np.zeros(len(px), bool), []
    for _ in range(4):
        gain = (inside & ~hit) @ w
        best.append(gain.max())
        hit |= inside[gain.argmax()]
    g = greedy_placement(p, 4)
    assert g.coverage == pytest.approx(w[hit].sum() / w.sum(), rel=1e-12)
    # each chosen disc's centre adds the greedy gain (ties may pick another disc of equal gain)
    got = np.zeros(len(px), bool)
    for centre, gain in zip(g.centres, best):
        k = int(np.argmin(np.hypot(*(cands - centre).T)))
        assert (inside[k] & ~got) @ w == pytest.approx(gain, rel=1e-12)
        got |= inside[k]


def test_defaults_are_half_metre_cells_and_one_metre_candidates_and_radius_must_be_positive():
    layout = gg.generate_layout("assembly_line", seed=2)
    px, w, cands = reference(layout, 2.5, 0.5, 1.0)
    p = CoverageProblem(layout, 2.5)
    np.testing.assert_allclose(p.candidates, cands, atol=1e-9)
    assert p.total == pytest.approx(w.sum(), rel=1e-12) and p.resolution_m == 0.5
    for bad in (0.0, -1.0):
        with pytest.raises(gg.ConfigError, match="radius_m must be > 0"):
            CoverageProblem(layout, bad)


def _numpy_genetic(
    problem, n, rng, population=32, generations=150, mutation=0.05, seed_greedy=True
):
    """The genetic search written with numpy's array steps (the compiled generation's reference)."""
    from genie_gl.placement.genetic import greedy_indices

    m = len(problem.candidates)
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
    return problem.candidates[pop[fit.argmax()]], history


@pytest.mark.parametrize(
    "n, population, mutation, seed_greedy",
    [(12, 32, 0.05, True), (12, 32, 0.05, False), (5, 9, 0.4, False)],
)
def test_compiled_generations_follow_the_numpy_steps(n, population, mutation, seed_greedy):
    """Each generation of the search (tournament, crossover, mutation, elite) is compiled;
    from the same draws it makes the same populations as numpy's array steps: the same
    cameras and the same history, generation by generation."""
    from genie_gl.placement.genetic import genetic_placement

    layout = gg.generate_layout("assembly_line", seed=4)
    problem = CoverageProblem(layout, 3.0)  # too few discs to cover it all: the search has work
    got = genetic_placement(
        problem,
        n,
        rng=np.random.default_rng(9),
        population=population,
        generations=60,
        mutation=mutation,
        seed_greedy=seed_greedy,
    )
    want, history = _numpy_genetic(
        problem, n, np.random.default_rng(9), population, 60, mutation, seed_greedy
    )
    np.testing.assert_array_equal(got.centres, want)
    assert got.history == history
    assert seed_greedy or len(set(history)) > 2  # from a random start the search moves
