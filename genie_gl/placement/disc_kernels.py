"""Compiled inner loops of disc-coverage placement (numba, cached on disk).

The candidates' discs are held as a sparse matrix (CSR: ``indptr``, ``indices`` into the
weighted raster cells), built from a stencil window per candidate instead of a dense
candidates x cells distance matrix. A fitness evaluation stamps the cells of a chromosome's
discs with a fresh mark (no clearing between evaluations) and sums the weight of the cells it
marks first: O(covered cells), not O(candidates x cells).
"""

from __future__ import annotations

import numpy as np

from ..jit import njit


@njit(cache=True, nogil=True)
def disc_cells(cx, cy, index, x0, y0, res, radius):  # pragma: no cover - compiled
    """CSR of the weighted cells each candidate's disc covers (a cell is covered when its
    centre lies within ``radius`` of the candidate).

    cx, cy : (C,) candidate centres; index : (H, W) int64, compact index of each raster cell
    (-1: weight 0, left out); cell (r, c) has its centre at (x0 + (c + 0.5)·res, y0 + (r +
    0.5)·res).
    """
    H, W = index.shape
    C = cx.shape[0]
    r2 = radius * radius
    indptr = np.zeros(C + 1, np.int64)
    for pass_ in range(2):
        if pass_ == 1:
            for k in range(C):
                indptr[k + 1] += indptr[k]
            indices = np.empty(indptr[C], np.int64)
        for k in range(C):
            c0 = max(0, int(np.floor((cx[k] - radius - x0) / res - 0.5)))
            c1 = min(W - 1, int(np.ceil((cx[k] + radius - x0) / res - 0.5)))
            r0 = max(0, int(np.floor((cy[k] - radius - y0) / res - 0.5)))
            r1 = min(H - 1, int(np.ceil((cy[k] + radius - y0) / res - 0.5)))
            m = 0
            for r in range(r0, r1 + 1):
                dy = y0 + (r + 0.5) * res - cy[k]
                for c in range(c0, c1 + 1):
                    dx = x0 + (c + 0.5) * res - cx[k]
                    if index[r, c] >= 0 and dx * dx + dy * dy <= r2:
                        if pass_ == 1:
                            indices[indptr[k] + m] = index[r, c]
                        m += 1
            if pass_ == 0:
                indptr[k + 1] = m
    return indptr, indices


@njit(cache=True, nogil=True)
def union_weights(pop, indptr, indices, weight, stamp, mark):  # pragma: no cover - compiled
    """Covered weight of each chromosome (row of ``pop``: candidate indices). ``stamp`` is a
    scratch array of marks per cell, ``mark`` the last mark used; returns (weights, mark)."""
    out = np.zeros(pop.shape[0])
    for k in range(pop.shape[0]):
        mark += 1
        s = 0.0
        for g in range(pop.shape[1]):
            c = pop[k, g]
            for p in range(indptr[c], indptr[c + 1]):
                cell = indices[p]
                if stamp[cell] != mark:
                    stamp[cell] = mark
                    s += weight[cell]
        out[k] = s
    return out, mark


@njit(cache=True, nogil=True)
def greedy(n, indptr, indices, weight):  # pragma: no cover - compiled
    """n candidates chosen one at a time, each adding the most uncovered weight (ties: the
    lowest index)."""
    C = indptr.shape[0] - 1
    covered = np.zeros(weight.shape[0], np.bool_)
    chosen = np.empty(n, np.int64)
    for i in range(n):
        best, best_gain = 0, -1.0
        for c in range(C):
            gain = 0.0
            for p in range(indptr[c], indptr[c + 1]):
                if not covered[indices[p]]:
                    gain += weight[indices[p]]
            if gain > best_gain:
                best, best_gain = c, gain
        chosen[i] = best
        for p in range(indptr[best], indptr[best + 1]):
            covered[indices[p]] = True
    return chosen


@njit(cache=True, nogil=True)
def breed(pop, fit, a, b, perm, cross, mutate, mutation, draws):  # pragma: no cover - compiled
    """One generation of the genetic search from its random draws: tournament winners
    ``parents[k] = pop[a[k]] if fit[a[k]] >= fit[b[k]] else pop[b[k]]``, mates
    ``parents[perm]``, a uniform crossover (``cross < 0.5`` keeps the parent's gene), point
    mutations where ``mutate < mutation`` (the genes of ``draws`` in row order) and the elite
    (the first fittest of ``pop``) as child 0. The numpy steps' results, integer by integer."""
    P, n = pop.shape
    parents = np.empty_like(pop)
    for k in range(P):
        src = a[k] if fit[a[k]] >= fit[b[k]] else b[k]
        parents[k] = pop[src]
    child = np.empty_like(pop)
    d = 0
    for k in range(P):
        for g in range(n):
            child[k, g] = parents[k, g] if cross[k, g] < 0.5 else parents[perm[k], g]
            if mutate[k, g] < mutation:
                child[k, g] = draws[d]
                d += 1
    child[0] = pop[np.argmax(fit)]
    return child
