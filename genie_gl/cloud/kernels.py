"""Compiled inner loops of the cloud stage (numba, cached on disk after the first run).

Each kernel makes one pass over its input and writes its output once: the frame-to-points
kernel fuses the validity test, the pose transform and the label gather that a numpy version
spreads over a dozen full-size temporaries; the tiling kernel is a stable counting sort, O(N)
where ``argsort`` is O(N log N).

Frames to points. Keeping only the valid pixels is a compaction, and a compaction written
pixel by pixel cannot use SIMD: a point's slot depends on how many valid pixels came before
it, so each output value costs a scalar store (five per point), and the stores, not the
arithmetic or the memory traffic, set the pace. Rendered frames are made of long runs of
valid pixels (an object, the floor) between runs of invalid ones (out of range, the corners
a lens cannot see), and a run maps to a contiguous block of output: inside it the slot is
the pixel's offset, the loop vectorises and the labels are a plain copy. So each row is read
as 64-pixel masks (one vector compare each); a word with few runs is written run by run
(runs that continue across words are joined first), a word of scattered holes (random sensor
dropout) pixel by pixel with branch-free compaction. Both paths evaluate the same float32
expression in the same order, so they write identical bits.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import int64, types, uint64
from numba.core.extending import intrinsic

from ..jit import njit

MAX_RUNS = 2  # a 64-pixel word with more runs of valid pixels than this is written pixel by pixel


@intrinsic
def _valid64(typingctx, row, start):  # pragma: no cover - compiled
    """Bit k set where 0 < row[start + k] < inf (ordered: NaN is not valid, nor is +Inf: no
    return), k < 64: two vector compares (row float32, contiguous, start + 64 <= len)."""

    def codegen(context, builder, signature, args):
        a, s = args
        data = context.make_array(signature.args[0])(context, builder, a).data
        vty = ir.VectorType(ir.FloatType(), 64)
        vec = builder.load(builder.bitcast(builder.gep(data, [s]), vty.as_pointer()), align=4)
        above = builder.fcmp_ordered(">", vec, ir.Constant(vty, [0.0] * 64))
        below = builder.fcmp_ordered("<", vec, ir.Constant(vty, [float("inf")] * 64))
        return builder.bitcast(builder.and_(above, below), ir.IntType(64))

    return types.uint64(row, start), codegen


@njit(nogil=True, inline="always")
def has_return(x):  # pragma: no cover - compiled
    """A depth that is a return: 0 < x < inf (NaN, 0, negatives and +Inf are none)."""
    return x > 0 and x < np.inf


@intrinsic
def _ctz(typingctx, x):  # pragma: no cover - compiled
    """Trailing zero bits of a uint64 (64 for 0)."""

    def codegen(context, builder, signature, args):
        return builder.cttz(args[0], ir.Constant(ir.IntType(1), 0))

    return types.uint64(x), codegen


@intrinsic
def _popcount(typingctx, x):  # pragma: no cover - compiled
    def codegen(context, builder, signature, args):
        return builder.ctpop(args[0])

    return types.uint64(x), codegen


@intrinsic
def _copy4(typingctx, dst, dst_start, src, src_start):  # pragma: no cover - compiled
    """dst[dst_start:dst_start + 4] = src[src_start:src_start + 4] as one unaligned 16-byte
    move (float32 arrays, contiguous): one load and one store for a point's x, y, z (and a
    fourth float the next point overwrites)."""

    def codegen(context, builder, signature, args):
        a, o, b, s = args
        vty = ir.VectorType(ir.FloatType(), 4)
        dptr = builder.gep(context.make_array(signature.args[0])(context, builder, a).data, [o])
        sptr = builder.gep(context.make_array(signature.args[2])(context, builder, b).data, [s])
        v = builder.load(builder.bitcast(sptr, vty.as_pointer()), align=4)
        builder.store(v, builder.bitcast(dptr, vty.as_pointer()), align=4)
        return context.get_dummy_value()

    return types.void(dst, dst_start, src, src_start), codegen


@njit(nogil=True, boundscheck=False, inline="always")
def _write(separable, colour, dense, p, q, x0, n, bufs, pose):  # pragma: no cover - compiled
    """Write the points of pixels [p, q) (flat indices; x0: the column of p) from slot n on;
    returns the new n. dense: all of them are valid, and the whole pass vectorises. Otherwise
    the points are computed densely into ``scratch`` (3 (q - p) + 1 floats; vectorised: the
    arithmetic, not the stores, is what bounds a scalar loop) and then compacted branch-free:
    every pixel copies its point (one 16-byte move) to slot n, only valid ones advance n, so
    the outputs need a spare slot, and xyz one more for the move's fourth float. bufs: the
    frame's flat arrays, pose: (M, and the row's y terms a0, a1, a2; see the caller)."""
    d, tx, ty, sem, inst, rgb, cs, xyz, so, io, co, scratch = bufs
    m, a0, a1, a2 = pose
    m00, m01, m02, m03 = m[0, 0], m[0, 1], m[0, 2], m[0, 3]
    m10, m11, m12, m13 = m[1, 0], m[1, 1], m[1, 2], m[1, 3]
    m20, m21, m22, m23 = m[2, 0], m[2, 1], m[2, 2], m[2, 3]
    L = q - p
    p, x0, n = uint64(p), uint64(x0), uint64(n)
    out, base = (xyz, uint64(3) * n) if dense else (scratch, uint64(0))
    for k in range(uint64(L)):
        x, dk = tx[x0 + k], d[p + k]
        if separable:
            b0, b1, b2 = a0, a1, a2
        else:
            y = ty[p + k]
            b0, b1, b2 = m01 * y + m02, m11 * y + m12, m21 * y + m22
        o = base + uint64(3) * k
        out[o] = dk * (m00 * x + b0) + m03
        out[o + uint64(1)] = dk * (m10 * x + b1) + m13
        out[o + uint64(2)] = dk * (m20 * x + b2) + m23
    if dense:
        for k in range(uint64(L)):
            so[n + k] = sem[p + k]
            io[n + k] = inst[p + k]
        if colour and cs == 3:
            for k in range(uint64(3 * L)):
                co[uint64(3) * n + k] = rgb[uint64(3) * p + k]
        elif colour:
            for k in range(uint64(L)):
                c, r = uint64(3) * (n + k), cs * (p + k)
                for j in range(uint64(3)):
                    co[c + j] = rgb[r + j]
        return int64(n) + L
    for k in range(uint64(L)):  # the 16-byte move spills a float into slot n + 1: xyz has n + 2
        o, s = uint64(3) * n, uint64(3) * k
        _copy4(xyz, o, scratch, s)
        so[n] = sem[p + k]
        io[n] = inst[p + k]
        if colour:
            c, r = uint64(3) * n, cs * (p + k)
            for j in range(uint64(3)):
                co[c + j] = rgb[r + j]
        n += uint64(has_return(d[p + k]))
    return int64(n)


def _make(separable: bool, colour: bool):
    """The frame-to-points kernel for one kind of camera ray, with or without colour.

    separable : a pinhole without skew, whose ray (x, y, 1) takes x from the column and y from
    the row (tx (1, W), ty (H, 1): no table read); otherwise tx and ty are (H, W) tables.
    Both flags are compile-time constants of the closure, passed on to the inlined
    :func:`_write`, so no loop branches on them (a loop-invariant branch inside a loop stops
    its vectorisation). The closure holds only the two flags: a closure holding functions
    could not be cached on disk. The loops index flat arrays with unsigned offsets: no array
    views are made per run (each view costs reference-count updates) and no negative-index
    wrap-around is tested per pixel.
    """

    @njit(cache=True, nogil=True, boundscheck=False)
    def unproject(
        depth, tx, ty, M, semantic, instance, rgb, xyz, sem_out, inst_out, rgb_out
    ):  # pragma: no cover - compiled
        H, W = depth.shape
        d, tx, ty = depth.reshape(-1), tx.reshape(-1), ty.reshape(-1)
        cs = uint64(rgb.shape[2])  # channels of the colour source: 3, or 4 (RGBA as read back)
        bufs = (
            d,
            tx,
            ty,
            semantic.reshape(-1),
            instance.reshape(-1),
            rgb.reshape(-1),
            cs,
            xyz.reshape(-1),
            sem_out,
            inst_out,
            rgb_out.reshape(-1),
            np.empty(3 * W + 1, np.float32),
        )
        n = 0
        for v in range(H):
            row = v * W
            xs = 0 if separable else row  # flat index of the row's first ray x
            y = ty[v] if separable else ty[row]
            pose = (M, M[0, 1] * y + M[0, 2], M[1, 1] * y + M[1, 2], M[2, 1] * y + M[2, 2])
            # the pending stretch [s0, s1) of the row: a run of valid pixels (dense) or a
            # stretch of scattered ones, written once it cannot grow
            s0 = s1 = 0
            dense = True
            for c in range(0, W - 63, 64):
                b = _valid64(d, row + c)
                if b != ~uint64(0) and b != 0 and _popcount(b & ~(b << uint64(1))) > MAX_RUNS:
                    if dense or s1 != c:
                        if s1 > s0:
                            n = _write(
                                separable, colour, dense, row + s0, row + s1, xs + s0, n, bufs, pose
                            )
                        s0, dense = c, False
                    s1 = c + 64
                    continue
                while b != 0:  # the word's runs of valid pixels
                    s = int64(_ctz(b))
                    r = ~(b >> uint64(s))
                    e = s + (int64(_ctz(r)) if r != 0 else 64 - s)
                    if not dense or s1 != c + s:
                        if s1 > s0:
                            n = _write(
                                separable, colour, dense, row + s0, row + s1, xs + s0, n, bufs, pose
                            )
                        s0, dense = c + s, True
                    s1 = c + e
                    if e == 64:
                        break
                    b = (b >> uint64(e)) << uint64(e)
            if s1 > s0:
                n = _write(separable, colour, dense, row + s0, row + s1, xs + s0, n, bufs, pose)
            if W % 64:
                c = W - W % 64
                n = _write(separable, colour, False, row + c, row + W, xs + c, n, bufs, pose)
        return n

    return unproject


_KERNELS = {(s, c): _make(s, c) for s in (True, False) for c in (True, False)}


def unproject(depth, tx, ty, M, semantic, instance, rgb, xyz, sem_out, inst_out, rgb_out) -> int:
    """Write the points of the valid pixels (0 < depth < inf) of one frame, in pixel order; returns
    their number n. The outputs need room for n + 1 points (the spare slot of the branch-free
    compaction), xyz for n + 2 (see :func:`_write`).

    depth (H, W) float32, C-contiguous. Camera rays (z = 1): tx (1, W) and ty (H, 1) for a
    pinhole without skew, (H, W) tables for any other lens. M (3, 4) float32: the pose, its
    translation already relative to the cloud's origin (the difference taken in float64).
    semantic (H, W) uint16, instance (H, W) uint32; rgb (H, W, 3 or 4) uint8 (channels 0-2 are
    used: RGBA as read back needs no copy) or (0, 0, 3) for none; all C-contiguous;
    xyz (n + 2, 3) float32, sem_out, inst_out (n + 1,), rgb_out (n + 1, 3) or (0, 3).
    """
    return int(
        _KERNELS[tx.shape[0] == 1, rgb.shape[0] > 0](
            depth, tx, ty, M, semantic, instance, rgb, xyz, sem_out, inst_out, rgb_out
        )
    )


@njit(nogil=True, boundscheck=False, inline="always")
def _frame_rows(depth, tx, ty, size):  # pragma: no cover - compiled
    """A frame's flat arrays and one row's buffers for :func:`_row_points`:
    (H, W, d, tx, ty, 1 / size, (px, py, pz, ka, kb))."""
    H, W = depth.shape
    rows = (
        np.empty(W, np.float32),
        np.empty(W, np.float32),
        np.empty(W, np.float32),
        np.empty(W, np.int64),
        np.empty(W, np.int64),
    )
    return H, W, depth.reshape(-1), tx.reshape(-1), ty.reshape(-1), 1.0 / size, rows


@njit(nogil=True, boundscheck=False, inline="always")
def _row_points(
    separable, v, W, d, tx, ty, M, inv, rows, with_z=True
):  # pragma: no cover - compiled
    """World points (px, py, pz; the expression and order of :func:`_write`, so the same
    bits) and tile indices (ka, kb) of every pixel of row v, valid or not, into ``rows``:
    dense loops that vectorise (a strided read of a written cloud would cost more).
    ``with_z`` False leaves pz alone (a count needs the tiles alone)."""
    px, py, pz, ka, kb = rows
    row = v * W
    y = ty[v] if separable else ty[row]
    a0, a1, a2 = M[0, 1] * y + M[0, 2], M[1, 1] * y + M[1, 2], M[2, 1] * y + M[2, 2]
    m00, m01, m02, m03 = M[0, 0], M[0, 1], M[0, 2], M[0, 3]
    m10, m11, m12, m13 = M[1, 0], M[1, 1], M[1, 2], M[1, 3]
    m20, m21, m22, m23 = M[2, 0], M[2, 1], M[2, 2], M[2, 3]
    for u in range(W):
        dk = d[row + u]
        if separable:
            x = tx[u]
            b0, b1, b2 = a0, a1, a2
        else:
            x, y = tx[row + u], ty[row + u]
            b0, b1, b2 = m01 * y + m02, m11 * y + m12, m21 * y + m22
        px[u] = dk * (m00 * x + b0) + m03
        py[u] = dk * (m10 * x + b1) + m13
        if with_z:
            pz[u] = dk * (m20 * x + b2) + m23
    for u in range(W):
        ka[u] = _tile(px[u], inv)
        kb[u] = _tile(py[u], inv)


def _make_tilers(separable: bool):
    """Tile counting and picking straight from a frame's depth (no cloud is written): the
    counts of the points per tile, then the points chosen by their rank in their tile."""

    @njit(cache=True, nogil=True, boundscheck=False)
    def count(depth, tx, ty, M, size, i0, j0, counts):  # pragma: no cover - compiled
        """Add the frame's valid points per tile to counts[i - i0, j - j0]; returns how many
        fell outside counts (then nothing is complete: count again with a wider window)."""
        H, W, d, tx, ty, inv, rows = _frame_rows(depth, tx, ty, size)
        px, py, pz, ka, kb = rows
        I, J = counts.shape
        outside = 0
        for v in range(H):
            _row_points(separable, v, W, d, tx, ty, M, inv, rows, False)
            a, b, inside, run = np.int64(0), np.int64(0), False, 0  # the current tile, its count
            for u in range(W):
                if not has_return(d[v * W + u]):
                    continue
                au, bu = ka[u] - i0, kb[u] - j0
                if inside and au == a and bu == b:
                    run += 1
                    continue
                if inside:
                    counts[a, b] += run
                a, b = au, bu
                inside = 0 <= a < I and 0 <= b < J
                run = 1
                outside += not inside
            if inside:
                counts[a, b] += run
        return outside

    @njit(cache=True, nogil=True, boundscheck=False)
    def pick(
        depth, tx, ty, M, size, i0, j0, tile, seen, start, picked, taken, src, dst, xyz
    ):  # pragma: no cover - compiled
        """Pick the frame's chosen points by their rank in their tile, frames visited in
        order; returns how many. tile (I, J): the output tile of grid tile (i0 + a, j0 + b),
        -1 for none; seen (T,): points of each tile met so far; start (T,): where the tile's
        choices begin in ``picked`` (-1: take all); taken (T,): each tile's next output slot.
        Writes the picked points to xyz[dst], their pixels' flat indices to src."""
        H, W, d, tx, ty, inv, rows = _frame_rows(depth, tx, ty, size)
        px, py, pz, ka, kb = rows
        I, J = tile.shape
        m = 0
        a, b = np.int64(-1), np.int64(-1)  # the current grid tile, its output tile t, the rank
        t, r, s = -1, 0, -1  # r of the next point in t, and where t's choices start (s)
        for v in range(H):
            _row_points(separable, v, W, d, tx, ty, M, inv, rows)
            for u in range(W):
                if not has_return(d[v * W + u]):
                    continue
                au, bu = ka[u] - i0, kb[u] - j0
                if au != a or bu != b:
                    if t >= 0:
                        seen[t] = r
                    a, b = au, bu
                    t = tile[a, b] if 0 <= a < I and 0 <= b < J else -1  # inside, if counted alike
                    if t >= 0:
                        r, s = seen[t], start[t]
                if t < 0:
                    continue
                if s < 0 or picked[s + r]:
                    o = taken[t]
                    src[m], dst[m] = v * W + u, o
                    xyz[o, 0], xyz[o, 1], xyz[o, 2] = px[u], py[u], pz[u]
                    taken[t] = o + 1
                    m += 1
                r += 1
        if t >= 0:
            seen[t] = r
        return m

    @njit(cache=True, nogil=True, boundscheck=False)
    def extent(depth, tx, ty, M, size):  # pragma: no cover - compiled
        """(i0, i1, j0, j1): the least and greatest tile indices of the frame's valid points
        (i0 > i1 if there are none)."""
        H, W, d, tx, ty, inv, rows = _frame_rows(depth, tx, ty, size)
        px, py, pz, ka, kb = rows
        i0 = j0 = np.int64(2**62)
        i1 = j1 = -np.int64(2**62)
        for v in range(H):
            _row_points(separable, v, W, d, tx, ty, M, inv, rows, False)
            for u in range(W):
                if has_return(d[v * W + u]):
                    i0, i1, j0, j1 = min(i0, ka[u]), max(i1, ka[u]), min(j0, kb[u]), max(j1, kb[u])
        return i0, i1, j0, j1

    return count, pick, extent


TILERS = {s: _make_tilers(s) for s in (True, False)}


@njit(cache=True, nogil=True, boundscheck=False)
def _count_valid(depth):  # pragma: no cover - compiled
    d = depth.reshape(-1)
    n = 0
    c = 0
    while c + 64 <= d.shape[0]:
        n += int64(_popcount(_valid64(d, c)))
        c += 64
    for k in range(c, d.shape[0]):
        n += has_return(d[k])
    return n


def count_valid(depth: np.ndarray) -> int:
    """The number of valid pixels (0 < depth < inf; NaN is not valid), as :func:`unproject` counts
    them: 64 pixels per vector compare, ~10x faster than ``np.count_nonzero`` on float32."""
    return int(_count_valid(np.ascontiguousarray(depth, np.float32)))


@njit(nogil=True, inline="always")
def _tile(x, inv):  # pragma: no cover - compiled
    """The tile index of coordinate x for tiles of side 1 / inv: floor(x · inv), one rule for
    every tiling kernel (a multiplication: a division per coordinate cost 2-3 ms a frame)."""
    return np.int64(np.floor(x * inv))


@njit(cache=True, nogil=True, boundscheck=False)
def tile_order(xyz, size):  # pragma: no cover - compiled
    """Stable counting sort of the points by their (x, y) tile of side ``size``.

    Returns (order, keys, starts, i0, j0, span): ``order`` lists point indices tile by tile,
    each tile's points in their original order; tile k holds order[starts[k]:starts[k+1]] and
    has grid index (keys[k] // span + i0, keys[k] % span + j0); empty tiles are left out.
    """
    inv = 1.0 / size
    n = xyz.shape[0]
    ti = np.empty(n, np.int64)
    tj = np.empty(n, np.int64)
    i0 = j0 = np.int64(2**62)
    i1 = j1 = -np.int64(2**62)
    for p in range(n):
        i = _tile(xyz[p, 0], inv)
        j = _tile(xyz[p, 1], inv)
        ti[p] = i
        tj[p] = j
        i0, i1, j0, j1 = min(i0, i), max(i1, i), min(j0, j), max(j1, j)
    span = j1 - j0 + 1
    ntiles = (i1 - i0 + 1) * span if n else 0
    counts = np.zeros(ntiles + 1, np.int64)
    for p in range(n):
        ti[p] = (ti[p] - i0) * span + (tj[p] - j0)
        counts[ti[p] + 1] += 1
    occupied = 0
    for k in range(ntiles):
        if counts[k + 1]:
            occupied += 1
        counts[k + 1] += counts[k]
    keys = np.empty(occupied, np.int64)
    starts = np.empty(occupied + 1, np.int64)
    m = 0
    for k in range(ntiles):
        if counts[k + 1] > counts[k]:
            keys[m] = k
            starts[m] = counts[k]
            m += 1
    starts[occupied] = n
    order = np.empty(n, np.int64)
    for p in range(n):
        k = ti[p]
        order[counts[k]] = p
        counts[k] += 1
    return order, keys, starts, i0, j0, span
