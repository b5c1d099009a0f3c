"""Compiled loops of the stereo shadow (:mod:`.shadow`): the render method's projection into
the second view (:func:`shadow_mask`, and :func:`casts_shadow`, which
says whether a second view is worth rendering), and the scanline method's row-by-row second
view of a rectified pair (:func:`scanline_shadow`). :mod:`.kernels` re-exports them.
"""

from __future__ import annotations

import numpy as np

from ..jit import njit


@njit(cache=True, nogil=True)
def casts_shadow(depth, fb, tol_m, tol_rel):  # pragma: no cover - compiled
    """True when two valid 4-neighbours differ by more than half the shadow tolerance and the
    shadow of the nearer on the farther, fb·(1/z_near − 1/z_far) pixels, reaches half a pixel."""
    H, W = depth.shape
    for v in range(H):
        for u in range(W):
            z = np.float64(depth[v, u])
            if z <= 0:
                continue
            for dv, du in ((0, 1), (1, 0)):
                if v + dv >= H or u + du >= W:
                    continue
                n = np.float64(depth[v + dv, u + du])
                if n <= 0:
                    continue
                near, far = min(z, n), max(z, n)
                if (
                    far - near > 0.5 * (tol_m + tol_rel * near)
                    and fb * (1.0 / near - 1.0 / far) >= 0.5
                ):
                    return True
    return False


@njit(cache=True, nogil=True)
def shadow_mask(
    depth, xy, R, t, K, w2, h2, near2, depth2, rendered, tol_m, tol_rel
):  # pragma: no cover
    """Which returns the second view cannot see: (gone (H, W) bool, occluded, outside).

    Every valid pixel's point (depth · (x, y, 1)) goes to the second view (X2 = R·X + t), is
    projected with K (rounded half to even, as ``np.rint``) and, when ``rendered``, compared
    with ``depth2`` there: hidden when it lies behind by more than tol_m + tol_rel·seen."""
    H, W = depth.shape
    gone = np.zeros((H, W), np.bool_)
    occluded = 0
    outside = 0
    for v in range(H):
        for u in range(W):
            z = np.float64(depth[v, u])
            if z <= 0:
                continue
            X, Y = xy[v, u, 0] * z, xy[v, u, 1] * z
            x2 = R[0, 0] * X + R[0, 1] * Y + R[0, 2] * z + t[0]
            y2 = R[1, 0] * X + R[1, 1] * Y + R[1, 2] * z + t[1]
            z2 = R[2, 0] * X + R[2, 1] * Y + R[2, 2] * z + t[2]
            if not z2 > near2:
                gone[v, u] = True
                outside += 1
                continue
            pu = np.rint((K[0, 0] * x2 + K[0, 1] * y2) / z2 + K[0, 2])
            pv = np.rint(K[1, 1] * y2 / z2 + K[1, 2])
            if not (pu >= 0 and pu < w2 and pv >= 0 and pv < h2):
                gone[v, u] = True
                outside += 1
                continue
            if rendered:
                seen = np.float64(depth2[int(pv), int(pu)])
                if seen > 0 and z2 > seen + (tol_m + tol_rel * seen):
                    gone[v, u] = True
                    occluded += 1
    return gone, occluded, outside


def scanline_shadow(depth: np.ndarray, shift: float, tol_m: float, tol_rel: float):
    """Which returns the second view of a rectified pair cannot see, from the depth image
    alone: (gone (H, W) bool, occluded, outside).

    The second view has the same pinhole K and sits at X2 = X1 + (tx, 0, 0): a return at
    column u and depth z appears in the same row at x2 = u + shift/z, shift = fx·tx. Each row
    is drawn into a one-dimensional depth buffer of the second view (W columns, centres at
    integers): two neighbours whose depths differ by at most the tolerance are one surface
    (the segment between them, 1/z linear in x2: exact for a plane); a return without such a
    neighbour on one side covers half a pixel on that side at its own depth.

    Only returns on the second view's side can hide a return (of two points whose order the
    views swap, the one on that side is the nearer), so the row is walked from that side: each
    return is looked up before it and the segment to its predecessor are drawn, which also
    keeps it from hiding behind its own surface. It is outside when rint(x2) leaves [0, W),
    hidden when the buffer there holds a surface nearer than z − (tol_m + tol_rel·seen).

    Computed for the second view on the +x side (shift < 0, :func:`_scanline_right`); one on
    the −x side is its mirror image (the image flipped left to right, the shift negated)."""
    depth = np.ascontiguousarray(depth, dtype=np.float32)
    if shift <= 0:
        return _scanline_right(depth, float(shift), float(tol_m), float(tol_rel))
    gone, occluded, outside = _scanline_right(
        np.ascontiguousarray(depth[:, ::-1]), -float(shift), float(tol_m), float(tol_rel)
    )
    return np.ascontiguousarray(gone[:, ::-1]), occluded, outside


@njit(cache=True, nogil=True)
def _scanline_right(depth, shift, tol_m, tol_rel):  # pragma: no cover - compiled
    """:func:`scanline_shadow` for shift <= 0: rows walked right to left.

    A column is drawn when its centre lies in [lo, hi) (as a rasteriser fills). A draw that
    no later look-up can read is skipped, which changes nothing: ``fut[u]``, the rightmost
    column a return left of u looks up, lies left of it (the usual case: a surface both views
    see, walked right to left, maps to columns further and further left); and a look-up left
    of every column drawn so far finds nothing. Only near a fold of x2 (an edge whose shadow
    reaches a pixel) is anything drawn."""
    H, W = depth.shape
    gone = np.zeros((H, W), np.bool_)
    ib = np.empty(W, np.float64)
    izr = np.empty(W, np.float64)
    xr = np.empty(W, np.float64)
    col = np.empty(W, np.int64)
    fut = np.empty(W, np.int64)
    occluded = 0
    outside = 0
    for v in range(H):
        for u in range(W):  # one vectorised pass: 1/z, x2, the column looked up
            z = np.float64(depth[v, u])
            i = 1.0 / z if z > 0 else 0.0
            x = u + shift * i
            izr[u] = i
            xr[u] = x
            c = np.rint(x)
            col[u] = int(c) if (z > 0 and c >= 0 and c < W) else -1
            ib[u] = 0.0
        last = -1  # fut[u] = max(col[:u])
        for u in range(W):
            fut[u] = last
            last = max(last, col[u])
        drawn = W  # the leftmost column drawn in this row
        has_prev = False
        prev_i = 0.0
        prev_x = 0.0
        prev_z = 0.0
        for u in range(W - 1, -1, -1):
            iz = izr[u]
            if iz == 0.0:
                if (
                    has_prev and fut[u] >= prev_x - 0.5
                ):  # the predecessor's half pixel towards the hole
                    drawn = _draw(ib, prev_x - 0.5, prev_x, prev_x, prev_i, 0.0, drawn)
                has_prev = False
                continue
            x = xr[u]
            c = col[u]
            reach = max(fut[u], c)
            if c < 0:
                gone[v, u] = True
                outside += 1
            # the usual case needs nothing: its own draws (from min(x, prev_x) on) lie right of
            # every later look-up, the predecessor's half pixel right of this one's too, and
            # its look-up left of every column drawn
            if not has_prev or fut[u] >= min(x, prev_x) or reach >= prev_x - 0.5 or c >= drawn:
                z = np.float64(depth[v, u])
                linked = has_prev and abs(prev_z - z) <= tol_m + tol_rel * min(prev_z, z)
                if (
                    has_prev and not linked and reach >= prev_x - 0.5
                ):  # the predecessor's half pixel
                    drawn = _draw(ib, prev_x - 0.5, prev_x, prev_x, prev_i, 0.0, drawn)
                if c >= drawn and ib[c] > iz:
                    seen = 1.0 / ib[c]
                    if z > seen + (tol_m + tol_rel * seen):
                        gone[v, u] = True
                        occluded += 1
                if linked:  # the surface between the two, after the look-up
                    if fut[u] >= min(x, prev_x):
                        drawn = _draw(
                            ib,
                            min(x, prev_x),
                            max(x, prev_x),
                            x,
                            iz,
                            (prev_i - iz) / (prev_x - x),
                            drawn,
                        )
                elif fut[u] >= x:  # its own half pixel towards the predecessor
                    drawn = _draw(ib, x, x + 0.5, x, iz, 0.0, drawn)
                prev_z = z
            else:
                prev_z = np.float64(depth[v, u])
            has_prev = True
            prev_i, prev_x = iz, x
    return gone, occluded, outside


@njit(cache=True, nogil=True)
def _draw(ib, lo, hi, xa, ia, slope, drawn):  # pragma: no cover - compiled
    """Draw the columns whose centres lie in [lo, hi) of the line 1/z = ia + slope·(x − xa)
    into the row's inverse-depth buffer ``ib`` (the largest 1/z, the nearest, wins); the new
    leftmost drawn column."""
    W = ib.shape[0]
    c0, c1 = max(int(np.ceil(lo)), 0), min(int(np.ceil(hi)) - 1, W - 1)
    for c in range(c0, c1 + 1):
        i = ia + slope * (c - xa)
        if i > ib[c]:
            ib[c] = i
    return min(drawn, c0) if c0 <= c1 else drawn
