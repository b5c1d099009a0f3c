"""Compiled inner loops of the cloud stage (numba, cached on disk after the first run).

Each kernel makes one pass over its input and writes its output once: the frame-to-points
kernel fuses the validity test, the pose transform and the label gather that a numpy version
spreads over a dozen full-size temporaries; the tiling kernel is a stable counting sort, O(N)
where ``argsort`` is O(N log N).
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, boundscheck=False)
def unproject_separable(depth, xs, ys, M, semantic, instance, rgb, xyz, sem_out, inst_out, rgb_out):  # pragma: no cover - compiled
    """Write the points of the valid pixels (depth > 0) of one frame, in pixel order; returns
    their number n. For a lens without distortion the camera ray of pixel (u, v) is
    (xs[u] + skew·ys[v], ys[v], 1): separable, so no per-pixel table is read.

    depth : (H, W) float32; xs : (W,), ys : (H,) float32; M : (3, 4) float32, the pose with its
    translation already relative to the cloud's origin (the difference taken in float64);
    semantic (H, W) uint16, instance (H, W) uint32, rgb (H, W, 3) uint8 or (0, 0, 3) for none.
    Outputs need room for n + 1 points: the loop is branch-free, so every pixel writes a
    point at slot n and only valid pixels advance n (the spare slot takes the last write).
    """
    H, W = depth.shape
    m00, m01, m02, m03 = M[0, 0], M[0, 1], M[0, 2], M[0, 3]
    m10, m11, m12, m13 = M[1, 0], M[1, 1], M[1, 2], M[1, 3]
    m20, m21, m22, m23 = M[2, 0], M[2, 1], M[2, 2], M[2, 3]
    colour = rgb.shape[0] > 0
    n = 0
    for v in range(H):
        y = ys[v]
        # point = d·(R0·x + R1·y + R2) + t: the y and z terms are constant along a row
        a0, a1, a2 = m01 * y + m02, m11 * y + m12, m21 * y + m22
        for u in range(W):
            d = depth[v, u]
            x = xs[u]
            xyz[n, 0] = d * (m00 * x + a0) + m03
            xyz[n, 1] = d * (m10 * x + a1) + m13
            xyz[n, 2] = d * (m20 * x + a2) + m23
            sem_out[n] = semantic[v, u]
            inst_out[n] = instance[v, u]
            if colour:
                rgb_out[n, 0], rgb_out[n, 1], rgb_out[n, 2] = rgb[v, u, 0], rgb[v, u, 1], rgb[v, u, 2]
            n += d > 0
    return n


@njit(cache=True, nogil=True, boundscheck=False)
def unproject_table(depth, table, M, semantic, instance, rgb, xyz, sem_out, inst_out, rgb_out):  # pragma: no cover - compiled
    """As :func:`unproject_separable`, with the ray of every pixel read from ``table`` (2, H, W)
    float32 (distorted lenses: the undistorted ray of each distorted pixel)."""
    H, W = depth.shape
    m00, m01, m02, m03 = M[0, 0], M[0, 1], M[0, 2], M[0, 3]
    m10, m11, m12, m13 = M[1, 0], M[1, 1], M[1, 2], M[1, 3]
    m20, m21, m22, m23 = M[2, 0], M[2, 1], M[2, 2], M[2, 3]
    colour = rgb.shape[0] > 0
    n = 0
    for v in range(H):
        for u in range(W):
            d = depth[v, u]
            x, y = table[0, v, u], table[1, v, u]
            xyz[n, 0] = d * (m00 * x + m01 * y + m02) + m03
            xyz[n, 1] = d * (m10 * x + m11 * y + m12) + m13
            xyz[n, 2] = d * (m20 * x + m21 * y + m22) + m23
            sem_out[n] = semantic[v, u]
            inst_out[n] = instance[v, u]
            if colour:
                rgb_out[n, 0], rgb_out[n, 1], rgb_out[n, 2] = rgb[v, u, 0], rgb[v, u, 1], rgb[v, u, 2]
            n += d > 0
    return n


@njit(cache=True, nogil=True, boundscheck=False)
def tile_order(xyz, size):  # pragma: no cover - compiled
    """Stable counting sort of the points by their (x, y) tile of side ``size``.

    Returns (order, keys, starts, i0, j0, span): ``order`` lists point indices tile by tile,
    each tile's points in their original order; tile k holds order[starts[k]:starts[k+1]] and
    has grid index (keys[k] // span + i0, keys[k] % span + j0); empty tiles are left out.
    """
    n = xyz.shape[0]
    ti = np.empty(n, np.int64)
    tj = np.empty(n, np.int64)
    i0 = j0 = np.int64(2**62)
    i1 = j1 = -np.int64(2**62)
    for p in range(n):
        i = np.int64(np.floor(xyz[p, 0] / size))
        j = np.int64(np.floor(xyz[p, 1] / size))
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
