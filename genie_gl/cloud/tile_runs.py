"""The cloud stage's two passes over the frames with one computation of every point's tile.

:func:`~genie_gl.cloud.process.frame_chunks` counts each tile's points (pass 1), draws the
chosen ranks per tile, then gathers the chosen points (pass 2). Pass 2 used to compute every
pixel's world point and tile again, and walk every pixel, to learn each point's rank in its
tile. Here pass 1 keeps what it found as runs: the stretches of one image row whose valid
pixels fall in one tile (a rendered frame has a few thousand: objects and the floor cross a
tile edge a few times a row), each as (first pixel, last pixel + 1, tile in the window of
tiles counted around the camera, valid pixels). Pass 2 walks the runs, not the pixels: a run
holds ranks r .. r + n - 1 of its tile, so the chosen ranks in it (sorted) name its chosen
pixels (directly when the run has no holes; by walking it when it has), and a world point
is computed only for those (a few hundred thousand of the ~12 M pixels of a 40-camera
scene), with the expression and order of :func:`~genie_gl.cloud.kernels._row_points`, so
the points have the same bits.

A frame whose points reach beyond its window, or that has more runs than the room given,
has no runs; pass 2 takes the recomputing kernel (:data:`~genie_gl.cloud.kernels.TILERS`)
for it.
"""

from __future__ import annotations

import numpy as np

from ..jit import njit
from .kernels import _frame_rows, _row_points, has_return


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _close_run(counts, runs, nr, a, b, p0, p1, n):  # pragma: no cover - compiled
    """Add a closed run (pixels p0 .. p1 - 1 of tile (a, b), n valid) to ``counts`` and, while
    there is room, to ``runs``; returns the runs written (-1 once ``runs`` overflowed)."""
    counts[a, b] += n
    if 0 <= nr < runs.shape[0]:
        runs[nr, 0], runs[nr, 1], runs[nr, 2], runs[nr, 3] = p0, p1, a * counts.shape[1] + b, n
        return nr + 1
    return -1


def _make_runners(separable: bool):
    """count (pass 1, runs kept) and pick (pass 2, from the runs) for one kind of ray table."""

    @njit(cache=True, nogil=True, boundscheck=False)
    def count(depth, tx, ty, M, size, i0, j0, counts, runs):  # pragma: no cover - compiled
        """Add the frame's valid points per tile to counts[i - i0, j - j0], as the kernels'
        ``count`` does, and write its runs to ``runs`` (R, 4) int32: (first pixel's flat
        index, last pixel's + 1, a * J + b for tile (i0 + a, j0 + b), valid pixels).
        Returns (points outside ``counts``, runs written); runs written is -1 when ``runs``
        had too little room (the counts are whole either way; with points outside they are
        not: count again)."""
        H, W, d, tx, ty, inv, rows = _frame_rows(depth, tx, ty, size)
        px, py, pz, ka, kb = rows
        I, J = counts.shape
        outside = 0
        nr = 0
        for v in range(H):
            _row_points(separable, v, W, d, tx, ty, M, inv, rows, False)
            row = v * W
            a, b, inside, run = np.int64(0), np.int64(0), False, 0  # the current tile, its count
            first = last = 0  # the current tile's first and last valid pixel in the row
            for u in range(W):
                if not has_return(d[row + u]):
                    continue
                au, bu = ka[u] - i0, kb[u] - j0
                if inside and au == a and bu == b:
                    run += 1
                    last = u
                    continue
                if inside:
                    nr = _close_run(counts, runs, nr, a, b, row + first, row + last + 1, run)
                a, b = au, bu
                inside = 0 <= a < I and 0 <= b < J
                run = 1
                first = last = u
                outside += not inside
            if inside:
                nr = _close_run(counts, runs, nr, a, b, row + first, row + last + 1, run)
        return outside, nr

    @njit(cache=True, nogil=True, boundscheck=False)
    def pick(
        runs, depth, tx, ty, M, tile, seen, next_q, end_q, chosen, taken, src, dst, xyz
    ):  # pragma: no cover - compiled
        """The kernels' ``pick`` from pass 1's runs. tile (codes,): the output tile of each
        run's tile code (-1 for none); seen (T,): points of each tile met so far; chosen:
        the down-sampled tiles' chosen ranks, each tile's sorted, tile t's ahead of
        chosen[end_q[t]] from chosen[next_q[t]] on (next_q[t] == -1: every point of the tile
        is taken), next_q advanced past what is picked; taken (T,): each tile's next output
        slot. Writes the picked points to xyz[dst] (computed as :func:`_row_points` does),
        their pixels' flat indices to src; returns how many."""
        H, W = depth.shape
        d, txf, tyf = depth.reshape(-1), tx.reshape(-1), ty.reshape(-1)
        m00, m01, m02, m03 = M[0, 0], M[0, 1], M[0, 2], M[0, 3]
        m10, m11, m12, m13 = M[1, 0], M[1, 1], M[1, 2], M[1, 3]
        m20, m21, m22, m23 = M[2, 0], M[2, 1], M[2, 2], M[2, 3]
        m = 0
        for k in range(runs.shape[0]):
            t = tile[runs[k, 2]]
            if t < 0:
                continue
            p0, p1, n = np.int64(runs[k, 0]), np.int64(runs[k, 1]), np.int64(runs[k, 3])
            r = seen[t]
            seen[t] = r + n
            q, q1 = next_q[t], end_q[t]
            if q >= 0:  # ranks before r: passed by another pass (a frame picked without runs)
                while q < q1 and chosen[q] < r:
                    q += 1
                if q >= q1 or chosen[q] >= r + n:  # none of the run's points chosen
                    next_q[t] = q
                    continue
            holes = p1 - p0 != n
            o = taken[t]
            p = p0 - 1  # the pixel of rank j of the run (when the run has holes)
            j = np.int64(-1)
            i = np.int64(0)  # the next rank in the run to take
            while True:
                if q >= 0:
                    if q >= q1 or chosen[q] >= r + n:
                        break
                    i = chosen[q] - r
                    q += 1
                elif i >= n:
                    break
                if holes:  # walk to the run's i-th valid pixel
                    while j < i:
                        p += 1
                        if has_return(d[p]):
                            j += 1
                else:
                    p = p0 + i
                i += 1
                v = p // W
                u = p - v * W
                dk = d[p]
                if separable:
                    x, y = txf[u], tyf[v]
                else:
                    x, y = txf[p], tyf[p]
                b0, b1, b2 = m01 * y + m02, m11 * y + m12, m21 * y + m22
                src[m], dst[m] = p, o
                xyz[o, 0] = dk * (m00 * x + b0) + m03
                xyz[o, 1] = dk * (m10 * x + b1) + m13
                xyz[o, 2] = dk * (m20 * x + b2) + m23
                o += 1
                m += 1
            taken[t] = o
            if q >= 0:
                next_q[t] = q
        return m

    return count, pick


RUNNERS = {s: _make_runners(s) for s in (True, False)}
