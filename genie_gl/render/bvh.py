"""A bounding volume hierarchy over world-space triangles, and exact rays through it (numba).

The hierarchy is built top down by the binned surface area heuristic (Wald 2007): a node's
triangles are split along the widest extent of their box centres where :data:`BINS` bins
give the least summed (count x box area) of the two sides, down to leaves of at most
:data:`LEAF` triangles (past depth ``STACK - 64`` a node splits at its middle, so the
traversal stack holds any tree). Nodes are stored depth first: a node's first child follows
it, ``right[i]`` is its second (``-1``: a leaf). Node boxes are float32 rounded outward, so
they hold their triangles' float64 corners.

A ray meets a triangle by Woop, Benthin and Wald's watertight test (JCGT 2013) in float64:
the triangle is moved to the ray's origin, sheared so the ray runs along its major axis, and
tested with 2-D edge functions; an edge two triangles share gives the same numbers negated,
so no ray slips between them (a ray through a shared edge or vertex hits them all). The
distance is along the unit direction. A ray's boxes are tested with slabs whose far
distance is widened by ``1 + 2 gamma(3)`` (Ize 2013), so rounding never drops a box the
ray passes through.

The tie rule: the nearest hit wins; hits at the same float64 distance go to the triangle
with the lower index in the joined arrays (the scene's instance order, then the face order
within the mesh). The answer therefore depends neither on the hierarchy's shape nor on the
order its nodes are visited: a box is passed over only when its entry lies beyond the nearest
hit found by a factor :data:`TIE` (a hit on the box's face, at a tie, is never passed over
because rounding put the entry a few units in the last place past it).
"""

from __future__ import annotations

import numpy as np

from ..jit import njit, prange

LEAF = 4  # triangles per leaf, at most
BINS = 16  # bins of the surface area heuristic
STACK = 256  # the traversal stack; deeper than this the build splits at the middle
WIDEN = 1.0 + 2.0 * (3 * 2.0**-53) / (
    1 - 3 * 2.0**-53
)  # Ize's far-distance factor for float64 slabs
TIE = (
    1.0 + 2.0**-40
)  # a box is passed over only when it starts beyond the nearest hit by this factor:
# its rounded entry may exceed the rounded distance of a hit on its face


@njit(cache=True, nogil=True, boundscheck=False)
def _area(b):  # pragma: no cover - compiled
    """Half the surface area of box ``b`` (6,: low xyz, high xyz)."""
    x, y, z = b[3] - b[0], b[4] - b[1], b[5] - b[2]
    return x * y + y * z + z * x if x >= 0.0 else 0.0


@njit(cache=True, nogil=True, boundscheck=False)
def build_nodes(tri_lo, tri_hi):  # pragma: no cover - compiled
    """The hierarchy over triangles with boxes ``tri_lo``, ``tri_hi`` (n, 3 float64): (order,
    boxes, right, start, count): ``order`` (n,) int64 the triangles in leaf order, ``boxes``
    (m, 6) float32 each node's low and high corner rounded outward, ``right`` (m,) int64 a
    node's second child (its first follows it; -1: a leaf of ``order[start:start + count]``)."""
    n = len(tri_lo)
    order = np.arange(n)
    cen = np.empty((n, 3))
    for t in range(n):
        for a in range(3):
            cen[t, a] = 0.5 * (tri_lo[t, a] + tri_hi[t, a])
    cap = max(1, 2 * n)
    right = np.full(cap, -1, np.int64)
    start = np.zeros(cap, np.int64)
    count = np.zeros(cap, np.int64)
    box = np.empty((cap, 6))
    st_lo = np.empty(2 * STACK, np.int64)
    st_hi = np.empty(2 * STACK, np.int64)
    st_parent = np.empty(2 * STACK, np.int64)
    st_depth = np.empty(2 * STACK, np.int64)
    bin_n = np.zeros(BINS, np.int64)
    bin_b = np.empty((BINS, 6))
    acc = np.empty(6)
    left_cost = np.empty(BINS)
    m = 0
    top = 0
    if n > 0:
        st_lo[0], st_hi[0], st_parent[0], st_depth[0] = 0, n, -1, 0
        top = 1
    while top > 0:
        top -= 1
        lo, hi, parent, depth = st_lo[top], st_hi[top], st_parent[top], st_depth[top]
        node = m
        m += 1
        if parent >= 0:  # the second child of ``parent`` (its first follows it directly)
            right[parent] = node
        start[node] = lo
        count[node] = hi - lo
        for a in range(3):
            box[node, a], box[node, 3 + a] = np.inf, -np.inf
        c_lo = np.array([np.inf, np.inf, np.inf])
        c_hi = np.array([-np.inf, -np.inf, -np.inf])
        for i in range(lo, hi):
            t = order[i]
            for a in range(3):
                box[node, a] = min(box[node, a], tri_lo[t, a])
                box[node, 3 + a] = max(box[node, 3 + a], tri_hi[t, a])
                c_lo[a] = min(c_lo[a], cen[t, a])
                c_hi[a] = max(c_hi[a], cen[t, a])
        if hi - lo <= LEAF:
            continue
        axis = 0
        for a in range(1, 3):
            if c_hi[a] - c_lo[a] > c_hi[axis] - c_lo[axis]:
                axis = a
        extent = c_hi[axis] - c_lo[axis]
        split = (lo + hi) // 2
        if extent > 0.0 and depth < STACK - 64:
            # binned surface area heuristic along the widest axis of the centres
            scale = BINS / extent
            bin_n[:] = 0
            for k in range(BINS):
                for a in range(3):
                    bin_b[k, a], bin_b[k, 3 + a] = np.inf, -np.inf
            for i in range(lo, hi):
                t = order[i]
                k = min(int((cen[t, axis] - c_lo[axis]) * scale), BINS - 1)
                bin_n[k] += 1
                for a in range(3):
                    bin_b[k, a] = min(bin_b[k, a], tri_lo[t, a])
                    bin_b[k, 3 + a] = max(bin_b[k, 3 + a], tri_hi[t, a])
            for a in range(3):
                acc[a], acc[3 + a] = np.inf, -np.inf
            seen = 0
            for k in range(BINS - 1):
                seen += bin_n[k]
                for a in range(3):
                    acc[a] = min(acc[a], bin_b[k, a])
                    acc[3 + a] = max(acc[3 + a], bin_b[k, 3 + a])
                left_cost[k] = seen * _area(acc)
            for a in range(3):
                acc[a], acc[3 + a] = np.inf, -np.inf
            seen = 0
            best, cut = np.inf, -1
            for k in range(BINS - 1, 0, -1):
                seen += bin_n[k]
                for a in range(3):
                    acc[a] = min(acc[a], bin_b[k, a])
                    acc[3 + a] = max(acc[3 + a], bin_b[k, 3 + a])
                cost = left_cost[k - 1] + seen * _area(acc)
                if cost < best and seen < hi - lo:
                    best, cut = cost, k
            if cut > 0:
                i, j = lo, hi - 1  # the triangles of bins below ``cut`` first
                while i <= j:
                    if min(int((cen[order[i], axis] - c_lo[axis]) * scale), BINS - 1) < cut:
                        i += 1
                    else:
                        order[i], order[j] = order[j], order[i]
                        j -= 1
                if lo < i < hi:
                    split = i
        # pushed second child first: the first child is built next, right after its parent
        st_lo[top], st_hi[top], st_parent[top], st_depth[top] = split, hi, node, depth + 1
        st_lo[top + 1], st_hi[top + 1], st_parent[top + 1], st_depth[top + 1] = (
            lo,
            split,
            -1,
            depth + 1,
        )
        top += 2
    boxes = np.empty((m, 6), np.float32)
    for i in range(m):
        for a in range(6):
            v32 = np.float32(box[i, a])
            if a < 3 and np.float64(v32) > box[i, a]:
                v32 = np.nextafter(v32, np.float32(-np.inf))
            if a >= 3 and np.float64(v32) < box[i, a]:
                v32 = np.nextafter(v32, np.float32(np.inf))
            boxes[i, a] = v32
    return order, boxes, right[:m].copy(), start[:m].copy(), count[:m].copy()


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _axis(lo, hi, o, inv, flat, near, far):  # pragma: no cover - compiled
    """(near, far) narrowed by one axis's slab [lo, hi]; ``flat``: the ray does not move
    along it (then it is inside the slab for all distances, or never)."""
    if flat:
        return (near, far) if lo <= o <= hi else (np.inf, -np.inf)
    t0, t1 = (lo - o) * inv, (hi - o) * inv
    return max(near, min(t0, t1)), min(far, max(t0, t1))


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _slab(boxes, i, ox, oy, oz, ix, iy, iz, fx, fy, fz, tfar):  # pragma: no cover - compiled
    """Entry distance of the ray into node ``i``'s box, or inf when it misses it (or enters
    beyond ``tfar``)."""
    near, far = _axis(boxes[i, 0], boxes[i, 3], ox, ix, fx, 0.0, tfar)
    near, far = _axis(boxes[i, 1], boxes[i, 4], oy, iy, fy, near, far)
    near, far = _axis(boxes[i, 2], boxes[i, 5], oz, iz, fz, near, far)
    return near if near <= far * WIDEN else np.inf


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def hit_triangle(corners, t, ox, oy, oz, kx, ky, kz, sx, sy, sz):  # pragma: no cover - compiled
    """Distance along the ray from (ox, oy, oz) (its coordinates on axes kx, ky, kz) to
    triangle ``t`` of ``corners`` (n, 9: a, b, c, world frame, float64), inf on a miss;
    kz is the ray's major axis and (sx, sy, sz) its shear (Woop, Benthin and Wald).
    Zero-area triangles and triangles edge-on to the ray miss."""
    return hit_relative(
        corners[t, kx] - ox, corners[t, ky] - oy, corners[t, kz] - oz,
        corners[t, 3 + kx] - ox, corners[t, 3 + ky] - oy, corners[t, 3 + kz] - oz,
        corners[t, 6 + kx] - ox, corners[t, 6 + ky] - oy, corners[t, 6 + kz] - oz,
        sx, sy, sz,
    )  # fmt: skip


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def hit_relative(ax, ay, az, bx, by, bz, cx, cy, cz, sx, sy, sz):  # pragma: no cover - compiled
    """:func:`hit_triangle` of the corners a, b, c less the ray's origin, on the ray's axes
    (x, y, z: kx, ky, kz): what rays from one origin with one major axis share of a
    triangle, computed once for all of them (the same bits as :func:`hit_triangle`)."""
    a_x, a_y = ax - sx * az, ay - sy * az
    b_x, b_y = bx - sx * bz, by - sy * bz
    c_x, c_y = cx - sx * cz, cy - sy * cz
    u = c_x * b_y - c_y * b_x
    v = a_x * c_y - a_y * c_x
    w = b_x * a_y - b_y * a_x
    if (u < 0.0 or v < 0.0 or w < 0.0) and (u > 0.0 or v > 0.0 or w > 0.0):
        return np.inf
    det = u + v + w
    if det == 0.0:
        return np.inf
    t_hit = (u * (sz * az) + v * (sz * bz) + w * (sz * cz)) / det
    return t_hit if t_hit > 0.0 else np.inf


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def shear(dx, dy, dz):  # pragma: no cover - compiled
    """The watertight test's set-up of a ray of direction (dx, dy, dz): (kx, ky, kz, sx, sy,
    sz), kz its major axis (kx, ky swapped when it points down that axis, keeping the
    winding) and (sx, sy, sz) its shear (Woop, Benthin and Wald)."""
    ax_, ay_, az_ = abs(dx), abs(dy), abs(dz)
    kz = 0 if ax_ >= ay_ and ax_ >= az_ else (1 if ay_ >= az_ else 2)
    kx = (kz + 1) % 3
    ky = (kx + 1) % 3
    dkz = dx if kz == 0 else (dy if kz == 1 else dz)
    if dkz < 0.0:
        kx, ky = ky, kx
    dkx = dx if kx == 0 else (dy if kx == 1 else dz)
    dky = dx if ky == 0 else (dy if ky == 1 else dz)
    sz = 1.0 / dkz
    return kx, ky, kz, dkx * sz, dky * sz, sz


@njit(cache=True, nogil=True, boundscheck=False)
def _cast_one(
    o, dx, dy, dz, corners, rank, boxes, right, start, count, stack, stack_t
):  # pragma: no cover
    """(distance, triangle number) of the nearest hit of one ray from ``o`` (3,) (inf, -1:
    none); ``corners`` (n, 9) the triangles in leaf order, ``rank`` their numbers in the
    joined arrays, ``stack`` and ``stack_t`` scratch. Ties: the lower triangle number."""
    kx, ky, kz, sx, sy, sz = shear(dx, dy, dz)
    okx, oky, okz = o[kx], o[ky], o[kz]
    ox, oy, oz = o[0], o[1], o[2]
    fx, fy, fz = dx == 0.0, dy == 0.0, dz == 0.0
    ix = 1.0 / dx if not fx else 0.0
    iy = 1.0 / dy if not fy else 0.0
    iz = 1.0 / dz if not fz else 0.0
    best, who = np.inf, np.int64(-1)
    if len(right) == 0:
        return best, who
    t0 = _slab(boxes, 0, ox, oy, oz, ix, iy, iz, fx, fy, fz, best * TIE)
    if t0 == np.inf:
        return best, who
    top = 1
    stack[0], stack_t[0] = 0, t0
    while top > 0:
        top -= 1
        i = stack[top]
        if stack_t[top] > best * TIE:  # entered beyond the nearest hit found since it was pushed
            continue
        if right[i] < 0:
            for t in range(start[i], start[i] + count[i]):
                h = hit_triangle(corners, t, okx, oky, okz, kx, ky, kz, sx, sy, sz)
                if h < best or (h == best and h < np.inf and rank[t] < who):
                    best, who = h, rank[t]
            continue
        a, b = i + 1, right[i]
        ta = _slab(boxes, a, ox, oy, oz, ix, iy, iz, fx, fy, fz, best * TIE)
        tb = _slab(boxes, b, ox, oy, oz, ix, iy, iz, fx, fy, fz, best * TIE)
        if ta > tb:
            a, b, ta, tb = b, a, tb, ta
        if tb < np.inf:  # the farther child waits below the nearer one
            stack[top], stack_t[top] = b, tb
            top += 1
        if ta < np.inf:
            stack[top], stack_t[top] = a, ta
            top += 1
    return best, who


@njit(cache=True, nogil=True, parallel=True, boundscheck=False)
def cast_all(
    origins, one_origin, dirs, corners, rank, boxes, right, start, count, out_t, out_tri
):  # pragma: no cover
    """Every ray's nearest hit into ``out_t`` (n,) float64 (inf: none) and ``out_tri`` (n,)
    int64 (the triangle's number in the joined arrays, -1: none). ``origins`` (n, 3), or
    (1, 3) with ``one_origin``. Rays go to the threads in blocks of 256."""
    n = len(dirs)
    blocks = (n + 255) // 256
    for b in prange(blocks):
        stack = np.empty(STACK, np.int64)
        stack_t = np.empty(STACK)
        for r in range(b * 256, min(n, (b + 1) * 256)):
            t, k = _cast_one(
                origins[0 if one_origin else r],
                dirs[r, 0],
                dirs[r, 1],
                dirs[r, 2],
                corners,
                rank,
                boxes,
                right,
                start,
                count,
                stack,
                stack_t,
            )
            out_t[r] = t
            out_tri[r] = k


def triangle_boxes(verts: np.ndarray, tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) float64 lows and highs of triangles ``tris`` (n, 3 vertex rows of ``verts``)."""
    c = verts[tris]  # (n, 3, 3)
    return c.min(axis=1), c.max(axis=1)
