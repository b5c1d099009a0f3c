"""The compiled loops of a beam's footprint (:class:`genie_gl.effects.lidar.BeamDivergence`):
its sub-rays' directions, and the grouping of their echoes into a beam's returns.

Loops rather than array expressions: a scan has ~200 k sub-rays, and array code would make a
temporary of each step and sort rows that come already in beam order. The directions are
computed in numpy's order of operations (a norm is ``sqrt((x * x + y * y) + z * z)``, a cross
product ``a1 * b2 - a2 * b1``), so they equal numpy's bit for bit.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit, prange


@njit(cache=True, nogil=True, parallel=True, boundscheck=False)
def subray_directions(directions, tangents, out):  # pragma: no cover - compiled
    """Per beam (``directions`` (B, 3)) its K sub-rays into ``out`` (B * K, 3), beam-major:
    the beam's unit direction d, then d + t0 u + t1 v normalised for each row (t0, t1) of
    ``tangents`` (K, 2) after the first, where u = d x up / |d x up| (up: +z, or +x when
    d is within ~26 degrees of a pole) and v = d x u."""
    k = len(tangents)
    for b in prange(len(directions)):
        x, y, z = directions[b, 0], directions[b, 1], directions[b, 2]
        n = math.sqrt((x * x + y * y) + z * z)
        dx, dy, dz = x / n, y / n, z / n
        if abs(dz) < 0.9:
            ax, ay, az = 0.0, 0.0, 1.0
        else:
            ax, ay, az = 1.0, 0.0, 0.0
        ux, uy, uz = dy * az - dz * ay, dz * ax - dx * az, dx * ay - dy * ax
        n = math.sqrt((ux * ux + uy * uy) + uz * uz)
        ux, uy, uz = ux / n, uy / n, uz / n
        vx, vy, vz = dy * uz - dz * uy, dz * ux - dx * uz, dx * uy - dy * ux
        r = b * k
        out[r, 0], out[r, 1], out[r, 2] = dx, dy, dz
        for j in range(1, k):
            t0, t1 = tangents[j, 0], tangents[j, 1]
            ox = (dx + t0 * ux) + t1 * vx
            oy = (dy + t0 * uy) + t1 * vy
            oz = (dz + t0 * uz) + t1 * vz
            n = math.sqrt((ox * ox + oy * oy) + oz * oz)
            out[r + j, 0], out[r + j, 1], out[r + j, 2] = ox / n, oy / n, oz / n


STRONGEST, LAST, DUAL = 0, 1, 2  # a head's return modes, as :func:`footprint_returns` takes them


@njit(cache=True, nogil=True, boundscheck=False)
def footprint_returns(beam, range_m, strength, separation, mode):  # pragma: no cover - compiled
    """The returns of each beam from its footprint's echoes (rows; ``beam`` (M,)
    non-decreasing, ``range_m``, ``strength`` (M,)).

    A beam's rows sorted by range (ties in row order) make groups, each row within
    ``separation`` of the one before; a group's strength is the sum of its rows', its range
    their strength-weighted mean. ``mode`` keeps per beam its strongest group
    (:data:`STRONGEST`, the first on ties), its last (:data:`LAST`), or both (:data:`DUAL`:
    the last, and the strongest of the others), in range order.

    Returns ``rows`` (R,) the strongest row of each kept group (the first on ties), and its
    ``ranges`` (R,) and ``strengths`` (R,)."""
    m = len(beam)
    order = np.arange(m)
    rows = np.empty(m, np.int64)
    ranges = np.empty(m)
    strengths = np.empty(m)
    g_rep = np.empty(m, np.int64)
    g_sum = np.empty(m)
    g_dot = np.empty(m)
    n = 0
    s = 0
    while s < m:
        e = s + 1
        while e < m and beam[e] == beam[s]:
            e += 1
        for i in range(s + 1, e):  # insertion sort: stable, and a no-op on sorted rows
            o = order[i]
            j = i - 1
            while j >= s and range_m[order[j]] > range_m[o]:
                order[j + 1] = order[j]
                j -= 1
            order[j + 1] = o
        g = -1
        for i in range(s, e):
            r = order[i]
            if i == s or range_m[r] - range_m[order[i - 1]] >= separation:
                g += 1
                g_rep[g], g_sum[g], g_dot[g] = r, 0.0, 0.0
            elif strength[r] > strength[g_rep[g]]:
                g_rep[g] = r
            g_sum[g] += strength[r]
            g_dot[g] += strength[r] * range_m[r]
        last = g
        best = -1  # the strongest group, or of the others than the last in dual mode
        for k in range(last + 1 if mode != DUAL else last):
            if best < 0 or g_sum[k] > g_sum[best]:
                best = k
        for k in range(last + 1):
            keep = k == best if mode == STRONGEST else (k == last or (mode == DUAL and k == best))
            if keep:
                rows[n], ranges[n], strengths[n] = g_rep[k], g_dot[k] / g_sum[k], g_sum[k]
                n += 1
        s = e
    return rows[:n].copy(), ranges[:n].copy(), strengths[:n].copy()
