"""Exact casting of a coherent bundle of rays binned on an azimuth-elevation grid (numba).

A spinning head's scan and a 360-degree panorama are bundles: rays from one origin, or from
origins within a small ball (a head that moves during its sweep), in every direction. Rather
than walking the whole hierarchy per ray (:mod:`genie_gl.render.bvh`), the rays are sorted
into the cells of a grid of world azimuth (from +x towards +y, [-pi, pi)) and elevation (up
from the x-y plane; rows uniform in its sine, a unit direction's z), spanning the rays'
elevations, and the hierarchy's clusters (subtrees of at most :func:`cluster_size`
triangles: larger for a few rays in a large scene) into the cells their boxes can reach;
each ray then
walks only the clusters of its own cell, nearest box first, and stops once a box lies
beyond its nearest hit. The rays of a cell walk together, :data:`PACKET` at a time, each
box loaded once for the packet and tested against each of its rays still in it.

Binning is conservative. Let ``c`` be the centre of the origins and ``r`` the radius of the
ball around ``c`` that holds them all. A ray from ``o`` meeting a triangle at p has the
direction of p - o = (p - c) - (o - c), the direction from ``c`` of a point of the
triangle's box grown by a ball of radius ``r``. Its azimuth and elevation are bounded from
the box (relative to ``c``): z within [z_lo - r, z_hi + r]; the distance from the z axis
within [rho_lo, rho_hi + r], rho_lo the distance of the axis from the box's footprint on
the x-y plane less r; the azimuth within the smallest arc holding the footprint corners'
azimuths, widened by asin(r / (rho_lo + r)) and by :data:`AZ_ERR` (a ray's column comes
from a polynomial arctangent, :func:`azimuth`, within that of its own), or every azimuth
when the footprint, grown by r, holds the axis (a box over a pole, around the origin or
next to it). The arc may cross the seam at +-pi: its cells wrap. Every bound is widened by
:data:`SLACK` for rounding. A ray's distance to a hit is at least the box's distance from
``c`` less ``r``.

The test is :func:`genie_gl.render.bvh.hit_triangle`, Woop, Benthin and Wald's watertight
test in float64, with the same ray set-up and the same slabs within a cluster, so a ray gets
the same float64 distance from a triangle here as through the whole hierarchy, and no ray
slips through an edge two triangles share. Rays from one origin with one major axis share
the triangle's corners less the origin (:func:`genie_gl.render.bvh.hit_relative`: the same
expressions, computed once for them).

The tie rule (the same as :func:`genie_gl.render.rays.cast_rays`): the nearest hit wins;
hits at the same float64 distance go to the triangle earlier in the scene's joined arrays,
that is the instance earlier in ``scene.instances``, then the lower face. The answer is
therefore bit for bit the hierarchy's, whatever the grid.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba.cpython.unsafe.numbers import trailing_zeros as lowest_bit  # of an int64 != 0

from ..jit import njit, prange
from .bvh import STACK, TIE, _slab, hit_relative, shear

SLACK = 1e-9  # radians added to every angular bound, and relative slack on lengths
# radians: the most a ray's binned azimuth (:func:`azimuth`) is off its arctangent (the
# polynomial's error is at most 1.15e-5 on [0, 1], sampled every 5e-8), added to the spans
AZ_ERR = 2e-5
RAYS_PER_CELL = 16  # the grid is sized for about this many rays per cell
MAX_CELLS = 1 << 22  # cells at most
PACKET = 32  # rays of a cell walked together (a bit each in an int64 mask: at most 63)
CLUSTER = 256  # a cluster: a subtree of the hierarchy of at most this many triangles (the least)
RAYS_PER_CLUSTER = 16  # a bundle's clusters are sized for about one per this many rays


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def azimuth(y, x):  # pragma: no cover - compiled
    """atan2(y, x) within :data:`AZ_ERR` radians, in [-pi - AZ_ERR, pi + AZ_ERR]: the ratio
    of the smaller to the larger of |x|, |y| into Abramowitz and Stegun's polynomial 4.4.49
    for the arctangent on [0, 1], then its octant (a division and five multiply-adds where
    the exact arctangent takes a library call; 0 at (0, 0))."""
    ax, ay = abs(x), abs(y)
    big = max(ax, ay)
    if big == 0.0:
        return 0.0
    q = min(ax, ay) / big
    s = q * q
    a = q * (0.9998660 + s * (-0.3302995 + s * (0.1801410 + s * (-0.0851330 + s * 0.0208351))))
    if ay > ax:
        a = 0.5 * math.pi - a
    if x < 0.0:
        a = math.pi - a
    return -a if y < 0.0 else a


@njit(cache=True, nogil=True, parallel=True, boundscheck=False)
def _ray_cells(dirs, el0, el_scale, n_el, n_az, out):  # pragma: no cover - compiled
    """Each ray's cell (elevation row * n_az + azimuth column) into ``out`` (n,) int64; rows
    are uniform in the sine of elevation, the unit direction's z, from ``el0``; columns in
    the azimuth as :func:`azimuth` gives it (the clusters' spans are widened by its error)."""
    az_scale = n_az / (2.0 * math.pi)
    for r in prange(len(dirs)):
        x, y, z = dirs[r, 0], dirs[r, 1], dirs[r, 2]
        a = int((azimuth(y, x) + math.pi) * az_scale)
        e = int((z - el0) * el_scale)
        out[r] = min(max(e, 0), n_el - 1) * n_az + min(max(a, 0), n_az - 1)


@njit(cache=True, nogil=True, parallel=True, boundscheck=False)
def unit_rows(d, out):  # pragma: no cover - compiled
    """``d`` (n, 3) float64 rows divided by their norms into ``out``; returns the first row
    whose norm is zero or not finite, or -1 (the norm as numpy's: sqrt((x x + y y) + z z))."""
    n = len(d)
    bad = np.full(n, False)
    for r in prange(n):
        x, y, z = d[r, 0], d[r, 1], d[r, 2]
        s = math.sqrt((x * x + y * y) + z * z)
        if not (s > 0.0 and s < np.inf):
            bad[r] = True
            continue
        out[r, 0], out[r, 1], out[r, 2] = x / s, y / s, z / s
    for r in range(n):
        if bad[r]:
            return r
    return -1


@njit(cache=True, nogil=True, boundscheck=False)
def ball(o):  # pragma: no cover - compiled
    """(centre (3,), radius): the middle of the box of origins ``o`` (n, 3) and the largest
    distance of an origin from it."""
    lo = o[0].copy()
    hi = o[0].copy()
    for r in range(1, len(o)):
        for a in range(3):
            lo[a] = min(lo[a], o[r, a])
            hi[a] = max(hi[a], o[r, a])
    c = 0.5 * (lo + hi)
    far = 0.0
    for r in range(len(o)):
        x, y, z = o[r, 0] - c[0], o[r, 1] - c[1], o[r, 2] - c[2]
        far = max(far, (x * x + y * y) + z * z)
    return c, math.sqrt(far)


@njit(cache=True, nogil=True, boundscheck=False)
def z_range(d):  # pragma: no cover - compiled
    """(least, greatest) z of rows ``d`` (n, 3), n >= 1."""
    lo = hi = d[0, 2]
    for r in range(1, len(d)):
        lo, hi = min(lo, d[r, 2]), max(hi, d[r, 2])
    return lo, hi


@njit(cache=True, nogil=True, boundscheck=False)
def _by_cell(cell, n_cells):  # pragma: no cover - compiled
    """(order, start): the rays sorted by cell (a counting sort, stable) and each cell's
    first position (n_cells + 1,)."""
    start = np.zeros(n_cells + 1, np.int64)
    for r in range(len(cell)):
        start[cell[r] + 1] += 1
    for k in range(n_cells):
        start[k + 1] += start[k]
    fill = start[:-1].copy()
    order = np.empty(len(cell), np.int64)
    for r in range(len(cell)):
        order[fill[cell[r]]] = r
        fill[cell[r]] += 1
    return order, start


def ray_cells(
    dirs: np.ndarray, el0: float, el_scale: float, n_el: int, n_az: int
) -> tuple[np.ndarray, np.ndarray]:
    """(order, start): rays ``dirs`` (n, 3) sorted by their cell of the grid, and where each
    of the n_el * n_az cells starts in ``order`` ((n_el * n_az + 1,) int64)."""
    cell = np.empty(len(dirs), np.int64)
    _ray_cells(dirs, el0, el_scale, n_el, n_az, cell)
    return _by_cell(cell, n_el * n_az)


@njit(cache=True, nogil=True, parallel=True, boundscheck=False)
def cluster_spans(
    boxes, nodes, c, r, el0, el1, el_scale, n_el, n_az, span, near
):  # pragma: no cover
    """Per cluster (hierarchy node ``nodes[i]``, its box a row of ``boxes`` (m, 6) float32)
    the cells it may cover, seen from origins within ``r`` of ``c`` (3,): ``span`` (n, 4)
    int64 (first row, last row, first column, last column; columns may run past the grid
    and wrap; first row > last row: none) and ``near`` (n,) float64, the least distance a
    ray travels to reach the box."""
    az_scale = n_az / (2.0 * math.pi)
    for i in prange(len(nodes)):
        b = nodes[i]
        x0, x1 = np.float64(boxes[b, 0]) - c[0], np.float64(boxes[b, 3]) - c[0]
        y0, y1 = np.float64(boxes[b, 1]) - c[1], np.float64(boxes[b, 4]) - c[1]
        z0, z1 = np.float64(boxes[b, 2]) - c[2], np.float64(boxes[b, 5]) - c[2]
        big = max(abs(x0), abs(x1), abs(y0), abs(y1), abs(z0), abs(z1))
        rr = r * (1.0 + SLACK) + SLACK * big
        gx, gy, gz = max(x0, 0.0, -x1), max(y0, 0.0, -y1), max(z0, 0.0, -z1)
        near[i] = max(math.sqrt(gx * gx + gy * gy + gz * gz) * (1.0 - SLACK) - rr, 0.0)
        # the footprint's (a rectangle's) distance from the z axis: 0 when it holds the axis
        rho_lo = math.sqrt(gx * gx + gy * gy) * (1.0 - SLACK) - rr
        fx, fy = max(abs(x0), abs(x1)), max(abs(y0), abs(y1))
        rho_hi = math.sqrt(fx * fx + fy * fy) * (1.0 + SLACK) + rr
        z_lo, z_hi = z0 - rr, z1 + rr
        if rho_lo <= 0.0:
            e_hi = math.pi / 2 if z_hi >= 0.0 else math.atan2(z_hi, rho_hi)
            e_lo = -math.pi / 2 if z_lo <= 0.0 else math.atan2(z_lo, rho_hi)
        else:
            e_hi = math.atan2(z_hi, rho_lo if z_hi >= 0.0 else rho_hi)
            e_lo = math.atan2(z_lo, rho_lo if z_lo <= 0.0 else rho_hi)
        # rows are uniform in the sine of elevation (monotone on [-pi/2, pi/2])
        e_lo = math.sin(max(e_lo - SLACK, -math.pi / 2)) - SLACK
        e_hi = math.sin(min(e_hi + SLACK, math.pi / 2)) + SLACK
        if e_hi < el0 or e_lo > el1:
            span[i, 0], span[i, 1], span[i, 2], span[i, 3] = 1, 0, 0, -1
            continue
        span[i, 0] = min(max(int(math.floor((e_lo - el0) * el_scale)), 0), n_el - 1)
        span[i, 1] = min(max(int(math.floor((e_hi - el0) * el_scale)), 0), n_el - 1)
        if rho_lo <= 0.0:
            span[i, 2], span[i, 3] = 0, n_az - 1
            continue
        # the footprint, grown by r, leaves the axis out: its corners' azimuths span less than pi
        a0 = math.atan2(y0, x0)
        lo, hi = 0.0, 0.0
        for k in range(1, 4):
            d = math.atan2(y1 if k >= 2 else y0, x1 if k % 2 == 1 else x0) - a0
            d = d - 2 * math.pi if d > math.pi else (d + 2 * math.pi if d < -math.pi else d)
            lo, hi = min(lo, d), max(hi, d)
        grow = math.asin(min(rr / (rho_lo + rr), 1.0)) + AZ_ERR + SLACK
        c0 = int(math.floor((a0 + lo - grow + math.pi) * az_scale))
        c1 = int(math.floor((a0 + hi + grow + math.pi) * az_scale))
        if c1 - c0 + 1 >= n_az:
            c0, c1 = 0, n_az - 1
        span[i, 2], span[i, 3] = c0, c1


@njit(cache=True, nogil=True, boundscheck=False)
def cell_lists(order, span, near, n_az, n_cells):  # pragma: no cover - compiled
    """Each cell's triangles in the order ``order`` (nearest first): (start (n_cells + 1,),
    triangles, their near distances)."""
    count = np.zeros(n_cells + 1, np.int64)
    for t in range(len(span)):
        for e in range(span[t, 0], span[t, 1] + 1):
            for a in range(span[t, 2], span[t, 3] + 1):
                count[e * n_az + (a % n_az) + 1] += 1
    for i in range(n_cells):
        count[i + 1] += count[i]
    fill = count[:-1].copy()
    tri = np.empty(count[-1], np.int64)
    dist = np.empty(count[-1])
    for t in order:
        for e in range(span[t, 0], span[t, 1] + 1):
            for a in range(span[t, 2], span[t, 3] + 1):
                k = e * n_az + (a % n_az)
                tri[fill[k]] = t
                dist[fill[k]] = near[t]
                fill[k] += 1
    return count, tri, dist


@njit(cache=True, nogil=True, parallel=True, boundscheck=False)
def cast_packets(
    origins,
    one_origin,
    dirs,
    ray_order,
    ray_start,
    cl_start,
    cl_node,
    cl_near,
    corners,
    rank,
    boxes,
    right,
    start,
    count,
    out_t,
    out_tri,
    threads,
):  # pragma: no cover - compiled
    """Every ray's nearest hit among the clusters of its cell into ``out_t`` (inf: none) and
    ``out_tri`` (the triangle's number in the joined arrays, -1: none); ties to the lower
    number. Rays of cell k are ``ray_order[ray_start[k]:ray_start[k + 1]]``, its clusters
    ``cl_node[cl_start[k]:cl_start[k + 1]]`` (hierarchy nodes, nearest first). The rays of a
    cell go :data:`PACKET` at a time: a packet walks each cluster's subtree once, a node's
    box tested against each ray still in it (a bit mask per stack entry) with the slabs of
    :func:`genie_gl.render.bvh._cast_one`, a leaf's triangles against the rays that reached
    it, so a box and a leaf's corners are loaded once for the packet; clusters are taken
    until one lies beyond every ray's nearest hit. Each ray meets every triangle of every
    box it enters before its nearest hit, and the least (distance, number) of the triangles
    met wins, so the answer does not depend on the packets, the order or the grid. Cells go
    in blocks of 16, share t of ``threads`` (numba's threads) taking blocks t, t + threads,
    t + 2 threads, ... in the grid's order: the shares interleave, so each holds every row
    (rows of the grid differ in work: a head's rays to the floor end at once, its rays to
    the horizon walk far), and a thread's next block lies next to its last, whose clusters
    it mostly walks again while they are still in the caches."""
    cells = len(ray_start) - 1
    blocks = (cells + 15) // 16
    for th in prange(threads):
        rid = np.empty(PACKET, np.int64)
        org = np.empty((PACKET, 3))
        oks = np.empty((PACKET, 3))
        inv = np.empty((PACKET, 3))
        flat = np.empty((PACKET, 3), np.bool_)
        axes = np.empty((PACKET, 3), np.int64)
        shr = np.empty((PACKET, 3))
        best = np.empty(PACKET)
        who = np.empty(PACKET, np.int64)
        run = np.empty(PACKET + 1, np.int64)
        stack = np.empty(STACK, np.int64)
        stack_m = np.empty(STACK, np.int64)
        stack_t = np.empty(STACK)
        for bl in range(th, blocks, threads):  # the threads' blocks interleaved, in grid order
            for k in range(bl * 16, min(cells, bl * 16 + 16)):
                for p0 in range(ray_start[k], ray_start[k + 1], PACKET):
                    n = min(PACKET, ray_start[k + 1] - p0)
                    for q in range(n):
                        r = ray_order[p0 + q]
                        rid[q] = r
                        o = origins[0 if one_origin else r]
                        dx, dy, dz = dirs[r, 0], dirs[r, 1], dirs[r, 2]
                        kx, ky, kz, sx, sy, sz = shear(dx, dy, dz)
                        org[q, 0], org[q, 1], org[q, 2] = o[0], o[1], o[2]
                        oks[q, 0], oks[q, 1], oks[q, 2] = o[kx], o[ky], o[kz]
                        axes[q, 0], axes[q, 1], axes[q, 2] = kx, ky, kz
                        shr[q, 0], shr[q, 1], shr[q, 2] = sx, sy, sz
                        flat[q, 0], flat[q, 1], flat[q, 2] = dx == 0.0, dy == 0.0, dz == 0.0
                        inv[q, 0] = 1.0 / dx if dx != 0.0 else 0.0
                        inv[q, 1] = 1.0 / dy if dy != 0.0 else 0.0
                        inv[q, 2] = 1.0 / dz if dz != 0.0 else 0.0
                        best[q], who[q] = np.inf, -1
                    # runs of rays from one origin with one major axis (a static head's packet is
                    # one run; a footprint's sub-rays are one): a triangle's corners less the
                    # origin, on the run's axes, are computed once per run
                    runs = 0
                    for q in range(n):
                        if q == 0 or not (
                            axes[q, 0] == axes[q - 1, 0] and axes[q, 2] == axes[q - 1, 2]
                            and org[q, 0] == org[q - 1, 0] and org[q, 1] == org[q - 1, 1]
                            and org[q, 2] == org[q - 1, 2]
                        ):  # fmt: skip
                            run[runs] = q
                            runs += 1
                    run[runs] = n
                    worst = np.inf  # the farthest nearest hit of the packet's rays
                    for i in range(cl_start[k], cl_start[k + 1]):
                        if cl_near[i] > worst:
                            break
                        root = cl_node[i]
                        m = 0
                        t_min = np.inf
                        for q in range(n):
                            t = _slab(
                                boxes, root, org[q, 0], org[q, 1], org[q, 2], inv[q, 0], inv[q, 1],
                                inv[q, 2], flat[q, 0], flat[q, 1], flat[q, 2], best[q] * TIE,
                            )  # fmt: skip
                            if t < np.inf:
                                m |= 1 << q
                                t_min = min(t_min, t)
                        if m == 0:
                            continue
                        top = 1
                        stack[0], stack_m[0], stack_t[0] = root, m, t_min
                        while top > 0:
                            top -= 1
                            node, m = stack[top], stack_m[top]
                            if right[node] < 0:
                                far = 0.0
                                mm = m
                                while mm:
                                    q = lowest_bit(mm)
                                    mm &= mm - 1
                                    far = max(far, best[q])
                                if stack_t[top] > far * TIE:
                                    continue
                                for t in range(start[node], start[node] + count[node]):
                                    for g in range(runs):
                                        q0, q1 = run[g], run[g + 1]
                                        mm = m & (((1 << (q1 - q0)) - 1) << q0)  # the run's rays
                                        if mm == 0:
                                            continue
                                        # what the run's rays share of the triangle, once
                                        kx, ky, kz = axes[q0, 0], axes[q0, 1], axes[q0, 2]
                                        ox, oy, oz = oks[q0, 0], oks[q0, 1], oks[q0, 2]
                                        ax, ay = corners[t, kx] - ox, corners[t, ky] - oy
                                        az = corners[t, kz] - oz
                                        bx, by = corners[t, 3 + kx] - ox, corners[t, 3 + ky] - oy
                                        bz = corners[t, 3 + kz] - oz
                                        cx, cy = corners[t, 6 + kx] - ox, corners[t, 6 + ky] - oy
                                        cz = corners[t, 6 + kz] - oz
                                        while mm:
                                            q = lowest_bit(mm)
                                            mm &= mm - 1
                                            h = hit_relative(
                                                ax, ay, az, bx, by, bz, cx, cy, cz, shr[q, 0],
                                                shr[q, 1], shr[q, 2],
                                            )  # fmt: skip
                                            if h < best[q] or (
                                                h == best[q] and h < np.inf and rank[t] < who[q]
                                            ):
                                                best[q], who[q] = h, rank[t]
                                continue
                            a, b = node + 1, right[node]
                            ma, mb = 0, 0
                            ta, tb = np.inf, np.inf
                            while m:
                                q = lowest_bit(m)
                                m &= m - 1
                                ox, oy, oz = org[q, 0], org[q, 1], org[q, 2]
                                ix, iy, iz = inv[q, 0], inv[q, 1], inv[q, 2]
                                fx, fy, fz = flat[q, 0], flat[q, 1], flat[q, 2]
                                tf = best[q] * TIE
                                t = _slab(boxes, a, ox, oy, oz, ix, iy, iz, fx, fy, fz, tf)
                                if t < np.inf:
                                    ma |= 1 << q
                                    ta = min(ta, t)
                                t = _slab(boxes, b, ox, oy, oz, ix, iy, iz, fx, fy, fz, tf)
                                if t < np.inf:
                                    mb |= 1 << q
                                    tb = min(tb, t)
                            if ta > tb:
                                a, b, ta, tb, ma, mb = b, a, tb, ta, mb, ma
                            if mb:
                                stack[top], stack_m[top], stack_t[top] = b, mb, tb
                                top += 1
                            if ma:
                                stack[top], stack_m[top], stack_t[top] = a, ma, ta
                                top += 1
                        worst = 0.0
                        for q in range(n):
                            worst = max(worst, best[q])
                    for q in range(n):
                        out_t[rid[q]] = best[q]
                        out_tri[rid[q]] = who[q]


@njit(cache=True, nogil=True, boundscheck=False)
def clusters_of(right, count, size):  # pragma: no cover - compiled
    """The hierarchy's nodes of at most ``size`` triangles whose parent holds more (the
    clusters a bundle bins), in depth-first order."""
    out = np.empty(len(right), np.int64)
    n = 0
    i = 0
    while i < len(right):
        if count[i] <= size or right[i] < 0:
            out[n] = i
            n += 1
            # skip the subtree: the next node not below i is the one after its last descendant
            j = i
            while right[j] >= 0:
                j = right[j]
            i = j + 1
            continue
        i += 1
    return out[:n].copy()


def grid_for(dirs: np.ndarray) -> tuple[float, float, int, int]:
    """(lowest sine of elevation, highest, rows, columns) of a grid for rays ``dirs`` (n, 3)
    unit: spanning their elevations, rows uniform in the sine, about :data:`RAYS_PER_CELL` rays per
    cell over the band."""
    z_lo, z_hi = z_range(dirs)
    lo, hi = max(float(z_lo) - 1e-9, -1.0), min(float(z_hi) + 1e-9, 1.0)
    cells = min(max(len(dirs) // RAYS_PER_CELL, 1), MAX_CELLS)
    band = max(math.asin(hi) - math.asin(lo), 1e-9)
    n_az = max(int(round(math.sqrt(cells * 2 * math.pi / band))), 1)
    n_el = max(min(cells // n_az, 4096), 1)
    return lo, hi, n_el, min(n_az, 16384)


def cluster_size(triangles: int, rays: int) -> int:
    """The cluster size for ``rays`` rays in a scene of ``triangles``: :data:`CLUSTER` times
    a power of 4 (at most 64), the one nearest (by ratio) to giving a cluster for every
    :data:`RAYS_PER_CLUSTER` rays. Binning a cluster costs about what a ray's walk of it
    does, so a few rays against a large scene (a VLP-16's 29 k beams on 10 M triangles) bin
    larger subtrees, many rays smaller ones."""
    want = triangles * RAYS_PER_CLUSTER / max(rays, 1)
    size = CLUSTER
    while size < CLUSTER * 64 and want / size > 2.0:  # 2: the geometric middle of 1 and 4
        size *= 4
    return size


def clusters(hierarchy: tuple, size: int | None = None) -> np.ndarray:
    """(c,) int64 the hierarchy's cluster nodes of at most ``size`` triangles (default
    :data:`CLUSTER`)."""
    right, count = hierarchy[3], hierarchy[5]
    size = CLUSTER if size is None else size
    return clusters_of(right, count, size) if len(right) else np.zeros(0, np.int64)


def cast_binned(
    hierarchy: tuple, origins: np.ndarray, dirs: np.ndarray, nodes: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(distance (n,) float64, inf: none; triangle (n,) int64, its number in the joined
    arrays, -1: none) of every ray; ``hierarchy`` (corners, rank, boxes, right, start,
    count) as :class:`genie_gl.render.rays.RayCaster` builds it, ``origins`` (3,) or (n, 3),
    ``dirs`` (n, 3) unit, ``nodes`` its :func:`clusters` (made here when None). Exact, with the tie
    rule of this module's docstring."""
    corners, rank, boxes, right, start, count = hierarchy
    n = len(dirs)
    if n == 0:
        return np.empty(0), np.empty(0, np.int64)
    one = origins.ndim == 1
    o2 = np.ascontiguousarray(origins.reshape(-1, 3))
    c, r = (o2[0].copy(), 0.0) if one else ball(o2)
    el0, el1, n_el, n_az = grid_for(dirs)
    el_scale = n_el / (el1 - el0)
    ray_order, ray_start = ray_cells(dirs, el0, el_scale, n_el, n_az)
    nodes = clusters(hierarchy) if nodes is None else nodes
    span = np.empty((len(nodes), 4), np.int64)
    near = np.empty(len(nodes))
    cluster_spans(boxes, nodes, c, r, el0, el1, el_scale, n_el, n_az, span, near)
    by_near = np.argsort(near, kind="stable")
    cl_start, cl, cl_near = cell_lists(by_near, span, near, n_az, n_el * n_az)
    t = np.empty(n)
    k = np.empty(n, np.int64)
    cast_packets(
        o2,
        one,
        dirs,
        ray_order,
        ray_start,
        cl_start,
        nodes[cl],
        cl_near,
        corners,
        rank,
        boxes,
        right,
        start,
        count,
        t,
        k,
        numba.get_num_threads(),
    )
    return t, k


@njit(cache=True, nogil=True, parallel=True, boundscheck=False)
def hit_records(
    t, k, dirs, flat, slot_of, face_of, no_slot, out_d, out_slot, out_face, out_n
):  # pragma: no cover
    """Per ray the record of its hit: distance (0: none), slot (``no_slot``: none), face
    (-1: none) and the unit normal of the face (float32, turned against the ray; 0: none),
    from ``t`` (inf: none) and triangle numbers ``k`` (-1: none) of ``flat`` (n, 9)."""
    for r in prange(len(t)):
        j = k[r]
        if j < 0:
            out_d[r], out_slot[r], out_face[r] = 0.0, no_slot, -1
            out_n[r, 0], out_n[r, 1], out_n[r, 2] = 0.0, 0.0, 0.0
            continue
        out_d[r], out_slot[r], out_face[r] = t[r], slot_of[j], face_of[j]
        ux, uy, uz = flat[j, 3] - flat[j, 0], flat[j, 4] - flat[j, 1], flat[j, 5] - flat[j, 2]
        vx, vy, vz = flat[j, 6] - flat[j, 0], flat[j, 7] - flat[j, 1], flat[j, 8] - flat[j, 2]
        nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        s = math.sqrt(nx * nx + ny * ny + nz * nz)
        nx, ny, nz = nx / s, ny / s, nz / s
        if nx * dirs[r, 0] + ny * dirs[r, 1] + nz * dirs[r, 2] > 0.0:
            nx, ny, nz = -nx, -ny, -nz
        out_n[r, 0], out_n[r, 1], out_n[r, 2] = nx, ny, nz
