"""The compiled loops of a beam's footprint (:class:`genie_gl.effects.lidar.BeamDivergence`):
its sub-rays' directions, and the grouping of their echoes into a beam's returns.

Each kernel does, row by row, the arithmetic the array expressions it replaced did (the same
operations in the same order: a norm is ``sqrt((x * x + y * y) + z * z)``, a cross product
``a1 * b2 - a2 * b1``), so a scan keeps its bytes; what it saves is the temporaries of a
scan's ~200 k sub-rays and the sorts of rows that come already in beam order.
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


@njit(cache=True, nogil=True, boundscheck=False)
def echo_groups(beam, range_m, strength, separation):  # pragma: no cover - compiled
    """The echoes of each beam sorted by range and grouped: ``beam`` (M,) non-decreasing.

    Returns ``order`` (M,) the rows sorted by (beam, range), ties in row order; ``starts``
    (G,) each group's first position in ``order`` (a group: a beam's echoes, in range order,
    each within ``separation`` of the one before); ``rep`` (G,) the position in ``order`` of
    each group's strongest row (the first on ties)."""
    m = len(beam)
    order = np.arange(m)
    starts = np.empty(m, np.int64)
    rep = np.empty(m, np.int64)
    g = 0
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
        for i in range(s, e):
            if i == s or range_m[order[i]] - range_m[order[i - 1]] >= separation:
                starts[g] = i
                rep[g] = i
                g += 1
            elif strength[order[i]] > strength[order[rep[g - 1]]]:
                rep[g - 1] = i
        s = e
    return order, starts[:g].copy(), rep[:g].copy()


@njit(cache=True, nogil=True, boundscheck=False)
def strongest_groups(g_beam, g_strength, exclude):  # pragma: no cover - compiled
    """Per beam (``g_beam`` (G,) non-decreasing) its strongest group not in ``exclude`` (G,)
    bool, the first on ties; a beam whose groups are all excluded gives none."""
    out = np.empty(len(g_beam), np.int64)
    n = 0
    s = 0
    while s < len(g_beam):
        e = s + 1
        while e < len(g_beam) and g_beam[e] == g_beam[s]:
            e += 1
        best = -1
        for i in range(s, e):
            if not exclude[i] and (best < 0 or g_strength[i] > g_strength[best]):
                best = i
        if best >= 0:
            out[n] = best
            n += 1
        s = e
    return out[:n].copy()
