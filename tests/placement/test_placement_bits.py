"""The bit-set coverage kernels give the cell-by-cell kernels' numbers bit for bit (fitness of
random chromosomes, the greedy seed, the whole genetic search), and other weights keep the
cell-by-cell kernels."""

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.resources import resolve
from genie_gl.placement import disc_kernels as coverage
from genie_gl.placement.genetic import CoverageProblem, genetic_placement


def cell_by_cell(problem, pop):
    w, _ = coverage.union_weights(
        np.ascontiguousarray(pop, np.int64),
        problem.indptr,
        problem.indices,
        problem.weight,
        np.zeros(len(problem.weight), np.int64),
        0,
    )
    return w / problem.total


@pytest.mark.parametrize("seed", [0, 3])
def test_bit_sets_equal_the_cell_by_cell_kernels(seed):
    layout = gg.generate_layout(resolve("assembly_line", "layouts", (".json",)), seed=seed)
    weights = {
        t: float(k % 3) for k, t in enumerate(layout.region_types)
    }  # whole numbers, several classes
    for w in (None, weights):
        problem = CoverageProblem(layout, 6.0, weights=w)
        bits = problem.disc_bits()
        assert bits is not None and len(bits.class_w) == (
            1 if w is None else len(set(problem.weight))
        )
        pop = np.random.default_rng(seed).integers(0, len(problem.candidates), (64, 40))
        pop[1] = pop[0]  # a chromosome twice, discs repeated within one
        pop[2, :20] = pop[2, 0]
        got = problem.fitnesses(pop)
        assert (
            got.tobytes() == cell_by_cell(problem, pop).tobytes()
            and 0 < got.min()
            and got.max() <= 1
        )
        assert np.array_equal(
            bits.greedy(40), coverage.greedy(40, problem.indptr, problem.indices, problem.weight)
        )


def test_the_genetic_search_takes_the_same_path_and_fractional_weights_keep_the_old_kernels(
    monkeypatch,
):
    layout = gg.generate_layout(resolve("assembly_line", "layouts", (".json",)), seed=1)
    problem = CoverageProblem(layout, 6.0)
    fast = genetic_placement(problem, 12, rng=np.random.default_rng(5), generations=30)
    monkeypatch.setattr(CoverageProblem, "disc_bits", lambda self: None)  # the cell-by-cell kernels
    slow = genetic_placement(problem, 12, rng=np.random.default_rng(5), generations=30)
    assert fast.history == slow.history and np.array_equal(fast.centres, slow.centres)
    monkeypatch.undo()
    fractional = CoverageProblem(layout, 6.0, weights={t: 0.3 for t in layout.region_types})
    assert fractional.disc_bits() is None
    pop = np.random.default_rng(2).integers(0, len(fractional.candidates), (8, 10))
    assert fractional.fitnesses(pop).tobytes() == cell_by_cell(fractional, pop).tobytes()


@pytest.mark.parametrize("seed, mutation", [(0, 0.05), (4, 0.3)])
def test_the_compiled_generations_equal_the_generation_loop(seed, mutation, monkeypatch):
    from genie_gl.placement import genetic as placement

    layout = gg.generate_layout(resolve("assembly_line", "layouts", (".json",)), seed=seed)
    problem = CoverageProblem(layout, 6.0)
    calls = []  # the compiled path is taken (else both sides below would run the loop)
    evolve = placement.evolve
    monkeypatch.setattr(placement, "evolve", lambda *a: calls.append(1) or evolve(*a))

    class Looped(
        CoverageProblem
    ):  # any subclass takes the loop in Python, generation by generation
        pass

    looped = object.__new__(Looped)
    looped.__dict__.update(problem.__dict__)
    rngs = np.random.default_rng(seed), np.random.default_rng(seed)
    fast = genetic_placement(problem, 40, rng=rngs[0], mutation=mutation)
    slow = genetic_placement(looped, 40, rng=rngs[1], mutation=mutation)
    assert (
        fast.history == slow.history and fast.coverage == slow.coverage and len(fast.history) == 151
    )
    assert fast.centres.tobytes() == slow.centres.tobytes()
    assert rngs[0].bit_generator.state == rngs[1].bit_generator.state  # the same draws, to the last
    assert calls == [1]
