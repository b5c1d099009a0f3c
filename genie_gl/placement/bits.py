"""Disc coverage as bit sets: the placement search's fitness and greedy seed in whole words
(numba, cached on disk), for weights that are whole numbers (the default: 1 for every region
with assets, 0 elsewhere).

Each candidate's disc is a bit set over the weighted cells (64 cells a word); a chromosome's
union is the OR of its discs, and its weight ``sum_k w_k * popcount(union & class_k)`` over the
distinct weights ``w_k``. With whole-number weights (and a total below 2**53) every partial
sum is an exact integer in float64, so this equals, bit for bit, the cell-by-cell sums of
:func:`genie_gl.placement.disc_kernels.union_weights` and
:func:`~genie_gl.placement.disc_kernels.greedy`
(which add weights in another order): the search takes the same path. Other weights keep
those kernels.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir  # noqa: F401  (the intrinsic's builder types)
from numba import types
from numba.core.extending import intrinsic

from ..jit import njit
from .disc_kernels import breed


@intrinsic
def _popcount(typingctx, x):  # pragma: no cover - compiled
    def codegen(context, builder, signature, args):
        return builder.ctpop(args[0])

    return types.uint64(types.uint64), codegen


@njit(cache=True, nogil=True)
def disc_bits(indptr, indices, words):  # pragma: no cover - compiled
    """(candidates, words) uint64: bit j of row c set when candidate c's disc covers cell j."""
    C = indptr.shape[0] - 1
    bits = np.zeros((C, words), np.uint64)
    for c in range(C):
        for p in range(indptr[c], indptr[c + 1]):
            j = indices[p]
            bits[c, j >> 6] |= np.uint64(1) << np.uint64(j & 63)
    return bits


@njit(cache=True, nogil=True)
def union_weights(pop, bits, classes, class_w):  # pragma: no cover - compiled
    """Covered weight of each chromosome (row of ``pop``: candidate indices)."""
    K, W = classes.shape
    out = np.zeros(pop.shape[0])
    acc = np.empty(W, np.uint64)
    for k in range(pop.shape[0]):
        acc[:] = 0
        for g in range(pop.shape[1]):
            row = bits[pop[k, g]]
            for w in range(W):
                acc[w] |= row[w]
        s = 0.0
        for c in range(K):
            n = np.uint64(0)
            for w in range(W):
                n += _popcount(acc[w] & classes[c, w])
            s += class_w[c] * np.float64(n)
        out[k] = s
    return out


@njit(cache=True, nogil=True)
def greedy(n, bits, classes, class_w):  # pragma: no cover - compiled
    """n candidates chosen one at a time, each adding the most uncovered weight (ties: the
    lowest index)."""
    C, W = bits.shape
    K = classes.shape[0]
    free = np.empty(W, np.uint64)
    free[:] = ~np.uint64(0)
    chosen = np.empty(n, np.int64)
    for i in range(n):
        best, best_gain = 0, -1.0
        for c in range(C):
            gain = 0.0
            for q in range(K):
                m = np.uint64(0)
                for w in range(W):
                    m += _popcount(bits[c, w] & free[w] & classes[q, w])
                gain += class_w[q] * np.float64(m)
            if gain > best_gain:
                best, best_gain = c, gain
        chosen[i] = best
        for w in range(W):
            free[w] &= ~bits[best, w]
    return chosen


@njit(cache=True)
def evolve(
    rng, pop, fit, generations, m, mutation, bits, classes, class_w, total
):  # pragma: no cover
    """``generations`` generations of :func:`~genie_gl.placement.genetic.genetic_placement`
    compiled whole, fitness as :meth:`DiscBits.fitnesses` / ``total``: each generation's five
    draws from ``rng`` in their order (numba's Generator draws numpy's numbers, call by call),
    :func:`~genie_gl.placement.disc_kernels.breed`, the fitnesses. Returns (population, fitnesses,
    the best fitness of each generation)."""
    population, n = pop.shape
    best = np.empty(generations)
    for g in range(generations):
        ab = rng.integers(0, population, (2, population))
        perm = rng.permutation(population)
        cross = rng.random((population, n))
        mutate = rng.random((population, n))
        draws = rng.integers(0, m, np.count_nonzero(mutate < mutation))
        pop = breed(pop, fit, ab[0], ab[1], perm, cross, mutate, mutation, draws)
        fit = union_weights(pop, bits, classes, class_w) / total
        best[g] = fit.max()
    return pop, fit, best


class DiscBits:
    """The bit sets of a coverage problem's discs, or None from :meth:`of` when its weights
    are not whole numbers (then the cell-by-cell kernels stay)."""

    def __init__(self, indptr: np.ndarray, indices: np.ndarray, weight: np.ndarray) -> None:
        words = max(1, -(-len(weight) // 64))
        self.bits = disc_bits(indptr, indices, words)
        values = np.unique(weight)
        self.class_w = values.astype(np.float64)
        self.classes = np.zeros((len(values), words), np.uint64)
        for k, v in enumerate(values):
            j = np.flatnonzero(weight == v)
            np.bitwise_or.at(
                self.classes[k], j >> 6, np.left_shift(np.uint64(1), (j & 63).astype(np.uint64))
            )

    @staticmethod
    def of(indptr: np.ndarray, indices: np.ndarray, weight: np.ndarray) -> "DiscBits | None":
        w = np.asarray(weight, np.float64)
        if len(w) == 0 or not (
            np.all(np.isfinite(w)) and np.all(w == np.round(w)) and w.sum() < 2.0**52
        ):
            return None
        return DiscBits(indptr, indices, w)

    def fitnesses(self, population: np.ndarray) -> np.ndarray:
        return union_weights(
            np.ascontiguousarray(population, np.int64), self.bits, self.classes, self.class_w
        )

    def greedy(self, n: int) -> np.ndarray:
        return greedy(int(n), self.bits, self.classes, self.class_w)
