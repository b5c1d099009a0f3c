"""Exact lens resampling: each lens pixel's own ray intersected with the triangles of its view.

A pinhole view rendered for a lens records the triangle each of its pixels shows
(:class:`genie_gl.triangles.PixelTriangles`). Per view, every triangle it shows at one pixel
or more is put, with its corners in the camera frame (float64), in the tiles of
:data:`TILE` x :data:`TILE` view pixels its projected box overlaps. A lens pixel's ray
crosses the view at a sub-pixel position; it is intersected with every triangle of that
position's tile whose box holds the position, exactly (a watertight ray-triangle test in
float64: a ray through an edge or a vertex that triangles share hits at least one of them;
Woop, Benthin & Wald, JCGT 2013), and the nearest hit gives the pixel's instance, semantic
id, depth and normal. A triangle shown anywhere in the view is found wherever the ray meets
it: a thin bar seen at other pixels, the corner of a small square that holds no pixel
centre near the ray.

What the view shows at no pixel (a triangle finer than its pixels, or hidden at every pixel
centre) is not tried: these are the sub-pixel triangles, and two rules decide for them:

* a ray that hits none of the view's triangles passes between them: it meets nothing when
  one of the four view pixels around it is empty (a silhouette against the background), and
  else the surface those four show (the plane of the nearest one's triangle: a finely
  tessellated surface whose triangles are narrower than a view pixel);
* a ray that hits an instance none of the four view pixels around it shows, behind the
  planes of all four pixels' triangles, is seen through a gap finer than the view: it takes
  that surface too (the sub-pixel triangles of the surface in front close the gap).

Both count as ``subpixel`` in the stats; ``oversample`` (finer views) shrinks what they
decide. Everywhere else the result is the ray caster's (tests/sensors/test_ray_hits.py).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

STATS = ("rays", "shown", "tested", "subpixel", "missed")   # what resample_rays counts, in this order
# how each lens pixel's sample was decided (resample_rays' ``decided``)
HIT, MISS, COVERED, GAP = 1, 2, 3, 4
TILE = 4   # view pixels per side of a tile of the triangles' index
RING_MAX = 32   # a point where more faces meet (the apex of a fan of slivers) is not searched


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _hit(verts, r, dx, dy, zmin):  # pragma: no cover - compiled
    """z (view frame) where the ray (dx, dy, 1) from the camera centre meets triangle ``r``
    of ``verts`` (T, 9: corners a, b, c), inf on a miss or nearer than ``zmin`` (the GPU's
    near plane: what it clips away). The triangle is sheared along the ray (x - dx
    z, y - dy z) and tested with 2D edge functions (Woop, Benthin & Wald's watertight test,
    the ray's z as its major axis: the views' rays have z = 1 and |x|, |y| < 4): the edge
    functions of an edge two triangles share are the same numbers negated, so no ray slips
    between them."""
    az, bz, cz = verts[r, 2], verts[r, 5], verts[r, 8]
    ax, ay = verts[r, 0] - dx * az, verts[r, 1] - dy * az
    bx, by = verts[r, 3] - dx * bz, verts[r, 4] - dy * bz
    cx, cy = verts[r, 6] - dx * cz, verts[r, 7] - dy * cz
    u = cx * by - cy * bx
    w1 = ax * cy - ay * cx
    w2 = bx * ay - by * ax
    if (u < 0.0 or w1 < 0.0 or w2 < 0.0) and (u > 0.0 or w1 > 0.0 or w2 > 0.0):
        return np.inf
    det = u + w1 + w2
    if det == 0.0:
        return np.inf
    t = (u * az + w1 * bz + w2 * cz) / det
    return t if t >= zmin else np.inf


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _plane(verts, r, dx, dy):  # pragma: no cover - compiled
    """z where the ray (dx, dy, 1) meets the plane of triangle ``r`` of ``verts``; inf when it
    does not, in front of the camera."""
    v = verts[r]
    e1x, e1y, e1z = v[3] - v[0], v[4] - v[1], v[5] - v[2]
    e2x, e2y, e2z = v[6] - v[0], v[7] - v[1], v[8] - v[2]
    nx, ny, nz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
    nd = nx * dx + ny * dy + nz
    if nd == 0.0:
        return np.inf
    t = (nx * v[0] + ny * v[1] + nz * v[2]) / nd
    return t if t > 0.0 else np.inf


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _faces_camera(v):  # pragma: no cover - compiled
    """True when triangle ``v`` (9,: camera frame, outward faces counter-clockwise) faces the
    camera at the origin, as the GPU's back-face culling decides it."""
    nx = (v[4] - v[1]) * (v[8] - v[2]) - (v[5] - v[2]) * (v[7] - v[1])
    ny = (v[5] - v[2]) * (v[6] - v[0]) - (v[3] - v[0]) * (v[8] - v[2])
    nz = (v[3] - v[0]) * (v[7] - v[1]) - (v[4] - v[1]) * (v[6] - v[0])
    return nx * v[0] + ny * v[1] + nz * v[2] < 0.0


@njit(cache=True, nogil=True, boundscheck=False)
def _shown(pixel, first, count, base, cfm, indices, vertices):  # pragma: no cover - compiled
    """The triangles the view shows: (per pixel its triangle's row, -1 for none; per
    triangle its slot, its triangle within the slot's draw and its camera-frame corners
    (T, 9))."""
    S = first.shape[0]
    at = np.zeros(S + 1, np.int64)
    for s in range(S):
        at[s + 1] = at[s] + count[s]
    row_of = np.full(at[S], -1, np.int32)
    n = pixel.shape[0] // 2
    pix = np.full(n, -1, np.int32)
    slot = np.empty(n, np.int64)
    prim = np.empty(n, np.int64)
    rows = 0
    for j in range(n):
        s1 = np.int64(pixel[2 * j])
        if s1 == 0:
            continue
        p = np.int64(pixel[2 * j + 1])
        key = at[s1 - 1] + p
        r = row_of[key]
        if r < 0:
            r = rows
            row_of[key] = r
            slot[r], prim[r] = s1 - 1, p
            rows += 1
        pix[j] = r
    verts = np.empty((rows, 9), np.float64)
    for r in range(rows):
        s = slot[r]
        m = cfm[s]
        t0 = 3 * (first[s] + prim[r])
        for c in range(3):
            g = base[s] + np.int64(indices[t0 + c])
            x, y, z = np.float64(vertices[g, 0]), np.float64(vertices[g, 1]), np.float64(vertices[g, 2])
            for q in range(3):
                verts[r, 3 * c + q] = m[q, 0] * x + m[q, 1] * y + m[q, 2] * z + m[q, 3]
    return pix, slot[:rows].copy(), prim[:rows].copy(), verts


@njit(cache=True, nogil=True, boundscheck=False)
def _tiles(verts, K, vw, vh, zmin):  # pragma: no cover - compiled
    """Each triangle's projected box, nearest corner and width (T, 6: u0, u1, v0, v1 in view
    pixels of its part beyond ``zmin``; z0; its least height, twice its area over its longest
    edge, in view pixels, inf when a corner is nearer than ``zmin``) and the tiles' lists of
    the triangles whose box overlaps them, nearest corner first (start (tiles + 1,), rows)."""
    fx, sk, cx, fy, cy = K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]
    T = verts.shape[0]
    ntx, nty = (vw + TILE - 1) // TILE + 1, (vh + TILE - 1) // TILE + 1
    box = np.empty((T, 6), np.float64)
    edges = np.zeros((T, 9), np.float64)   # 2D edge functions (view pixels), all >= 0 inside
    uv = np.empty(6, np.float64)
    span = np.empty((T, 4), np.int64)
    start = np.zeros(ntx * nty + 1, np.int64)
    for r in range(T):
        u0, u1, v0, v1 = np.inf, -np.inf, np.inf, -np.inf
        width = np.inf
        inside = 0
        for c in range(3):
            x, y, z = verts[r, 3 * c], verts[r, 3 * c + 1], verts[r, 3 * c + 2]
            if z >= zmin:
                inside += 1
                u, v = fx * x / z + sk * y / z + cx, fy * y / z + cy
                uv[2 * c], uv[2 * c + 1] = u, v
                u0, u1, v0, v1 = min(u0, u), max(u1, u), min(v0, v), max(v1, v)
            n = (c + 1) % 3   # where the edge to the next corner crosses z = zmin
            xn, yn, zn = verts[r, 3 * n], verts[r, 3 * n + 1], verts[r, 3 * n + 2]
            if (z - zmin) * (zn - zmin) < 0.0:
                a = (zmin - z) / (zn - z)
                xc, yc = x + a * (xn - x), y + a * (yn - y)
                u, v = fx * xc / zmin + sk * yc / zmin + cx, fy * yc / zmin + cy
                u0, u1, v0, v1 = min(u0, u), max(u1, u), min(v0, v), max(v1, v)
        if inside == 3:
            area2 = abs((uv[2] - uv[0]) * (uv[5] - uv[1]) - (uv[3] - uv[1]) * (uv[4] - uv[0]))
            edge = max(math.hypot(uv[2] - uv[0], uv[3] - uv[1]), math.hypot(uv[4] - uv[2], uv[5] - uv[3]),
                       math.hypot(uv[0] - uv[4], uv[1] - uv[5]))
            width = area2 / edge if edge > 0.0 else 0.0
            # the projected triangle's edge functions a u + b v + c, inside >= 0 (scaled to
            # pixels of distance, widened by 1e-6 px beyond rounding): a pre-test only
            sign = 1.0 if (uv[2] - uv[0]) * (uv[5] - uv[1]) - (uv[3] - uv[1]) * (uv[4] - uv[0]) > 0.0 else -1.0
            for c in range(3):
                n = (c + 1) % 3
                ea, eb = -(uv[2 * n + 1] - uv[2 * c + 1]) * sign, (uv[2 * n] - uv[2 * c]) * sign
                length = math.hypot(ea, eb)
                if length > 0.0:
                    ea, eb = ea / length, eb / length
                edges[r, 3 * c] = ea
                edges[r, 3 * c + 1] = eb
                edges[r, 3 * c + 2] = -(ea * uv[2 * c] + eb * uv[2 * c + 1]) + 1e-6 + 1e-9 * (abs(uv[2 * c]) + abs(uv[2 * c + 1]))
        pad = 1e-6 + 1e-9 * (abs(u0) + abs(u1) + abs(v0) + abs(v1))   # beyond float64 rounding
        box[r, 0], box[r, 1], box[r, 2], box[r, 3] = u0 - pad, u1 + pad, v0 - pad, v1 + pad
        box[r, 4] = min(verts[r, 2], min(verts[r, 5], verts[r, 8]))
        box[r, 5] = width
        if inside == 0:   # wholly nearer than the near plane: in no tile
            span[r, 0], span[r, 1], span[r, 2], span[r, 3] = 1, 0, 1, 0
            continue
        tx0 = int(min(max(math.floor(max(box[r, 0], -1.0) / TILE), 0), ntx - 1))
        tx1 = int(min(max(math.floor(min(box[r, 1], vw + 1.0) / TILE), 0), ntx - 1))
        ty0 = int(min(max(math.floor(max(box[r, 2], -1.0) / TILE), 0), nty - 1))
        ty1 = int(min(max(math.floor(min(box[r, 3], vh + 1.0) / TILE), 0), nty - 1))
        span[r, 0], span[r, 1], span[r, 2], span[r, 3] = tx0, tx1, ty0, ty1
        for ty in range(ty0, ty1 + 1):
            for tx in range(tx0, tx1 + 1):
                start[ty * ntx + tx + 1] += 1
    for t in range(ntx * nty):
        start[t + 1] += start[t]
    fill = start[:-1].copy()
    rows = np.empty(start[-1], np.int32)
    for r in np.argsort(box[:, 4]):   # each tile's list nearest first
        if span[r, 0] > span[r, 1]:
            continue
        for ty in range(span[r, 2], span[r, 3] + 1):
            for tx in range(span[r, 0], span[r, 1] + 1):
                t = ty * ntx + tx
                rows[fill[t]] = r
                fill[t] += 1
    return box, edges, start, rows, ntx, nty


@njit(cache=True, nogil=True, boundscheck=False)
def resample_rays(sel, mx, my, dx, dy, zs, K, vw, vh, zmin, near, far, R,
                  pixel, first, count, base, backcull, cfm, indices, vertices, faces, point, ring_start, ring_faces,
                  inst_of, sem_of, rgb, out_depth, out_inst, out_sem, out_rgb, out_normal, stats,
                  decided):  # pragma: no cover
    """Write the samples of one view into the lens image, each from its own ray.

    sel (N,) int64: output pixel of each sample; mx, my (N,) float64: where its ray crosses
    the view (view pixels, by ``K``); dx, dy (N,) float64: its ray (view frame, z = 1); zs
    (N,) or (0,): camera-frame z per view-frame z along the ray; K (3, 3): the view's; vw, vh:
    its size; zmin: the view's GPU near plane (z, what it clipped away); near, far: the
    sensor's range (camera z); R (3, 3): camera_from_view. pixel (vh·vw·2,)
    uint32, first, count, base, backcull, cfm, indices, inst_of, sem_of: the view's
    :class:`~genie_gl.triangles.PixelTriangles`; vertices, faces, point, ring_start,
    ring_faces: its :class:`~genie_gl.triangles.SceneTriangles`. rgb (vh·vw, 3) uint8 or
    (0, 3): the view's colour. out_*: the lens image's buffers (zero-filled), written where a
    sample has a return (out_rgb, out_normal may be (0, 3): not written). stats (5,) int64:
    :data:`STATS`, added to. decided (M,) uint8 or (0,): per output pixel, how its sample was
    decided (:data:`HIT`: the nearest triangle its ray hits; :data:`MISS`: it hits none and a
    view pixel around is empty; :data:`COVERED`, :data:`GAP`: the rules for what the view
    cannot resolve, see the module).
    """
    record = decided.shape[0] > 0
    colour = rgb.shape[0] > 0 and out_rgb.shape[0] > 0
    normals = out_normal.shape[0] > 0
    scale = zs.shape[0] > 0
    pix, slot, prim, verts = _shown(pixel, first, count, base, cfm, indices, vertices)
    box, edges, start, rows, ntx, nty = _tiles(verts, K, vw, vh, zmin)
    around = np.empty(4, np.int64)   # the triangle each of the 4 nearest view pixels shows (-1: none)
    points = np.empty(12, np.int64)  # the points whose faces a ray tried
    tri = np.empty(9, np.float64)
    best_v = np.empty(9, np.float64)
    tested = subpixel = missed = 0
    for i in range(sel.shape[0]):
        px, py = mx[i], my[i]
        ray_x, ray_y = dx[i], dy[i]
        x0, y0 = int(math.floor(px)), int(math.floor(py))
        covered, mixed = True, False
        for c in range(4):
            xx, yy = x0 + (c & 1), y0 + (c >> 1)
            around[c] = pix[yy * vw + xx] if 0 <= xx < vw and 0 <= yy < vh else -1
            covered &= around[c] >= 0
            if around[c] >= 0 and around[0] >= 0 and inst_of[slot[around[c]]] != inst_of[slot[around[0]]]:
                mixed = True
        # the nearest view pixel's triangle first: most rays hit it, and then only what is
        # nearer than that hit is tried
        best, bslot = np.inf, -1
        near_r = around[2 * int(py - y0 >= 0.5) + int(px - x0 >= 0.5)]
        if near_r >= 0:
            tested += 1
            best = _hit(verts, near_r, ray_x, ray_y, zmin)
            if best < np.inf:
                bslot = slot[near_r]
                best_v[:] = verts[near_r]
        tile = (min(max(int(math.floor(py / TILE)), 0), nty - 1) * ntx
                + min(max(int(math.floor(px / TILE)), 0), ntx - 1))
        for e in range(start[tile], start[tile + 1]):
            r = rows[e]
            if box[r, 4] >= best:   # this one and all after it lie beyond the hit
                break
            if px < box[r, 0] or px > box[r, 1] or py < box[r, 2] or py > box[r, 3] or r == near_r:
                continue
            if (edges[r, 0] * px + edges[r, 1] * py + edges[r, 2] < 0.0
                    or edges[r, 3] * px + edges[r, 4] * py + edges[r, 5] < 0.0
                    or edges[r, 6] * px + edges[r, 7] * py + edges[r, 8] < 0.0):
                continue   # outside the projected triangle (zeros, always passed, where it is clipped)
            tested += 1
            t = _hit(verts, r, ray_x, ray_y, zmin)
            if t < best:
                best, bslot = t, slot[r]
                best_v[:] = verts[r]
        if not covered or mixed or bslot < 0:
            # at a silhouette, or between triangles: also the faces that meet at the corners
            # of the triangles the 4 nearest view pixels show (slivers too thin to cover a
            # pixel centre, which the view shows nowhere)
            npts = 0
            for k in range(4):
                r = around[k]
                if r < 0 or (k > 0 and r == around[0]) or (k > 1 and r == around[1]) or (k > 2 and r == around[2]):
                    continue
                s = slot[r]
                m = cfm[s]
                t0 = 3 * (first[s] + prim[r])
                for c in range(3):
                    g = point[base[s] + np.int64(indices[t0 + c])]
                    if g < 0 or ring_start[g + 1] - ring_start[g] > RING_MAX:
                        continue   # the apex of a fan of slivers: left to the rules below
                    q = 0
                    while q < npts and points[q] != g:
                        q += 1
                    if q < npts:
                        continue
                    points[npts] = g
                    npts += 1
                    for e in range(ring_start[g], ring_start[g + 1]):
                        f = ring_faces[e]
                        for a in range(3):
                            gv = base[s] + np.int64(faces[f, a])
                            x, y, z = np.float64(vertices[gv, 0]), np.float64(vertices[gv, 1]), np.float64(vertices[gv, 2])
                            for q in range(3):
                                tri[3 * a + q] = m[q, 0] * x + m[q, 1] * y + m[q, 2] * z + m[q, 3]
                        if backcull[s] and not _faces_camera(tri):
                            continue
                        tested += 1
                        t = _hit(tri.reshape(1, 9), 0, ray_x, ray_y, zmin)
                        if t < best:
                            best, bslot = t, s
                            best_v[:] = tri
        if bslot >= 0 and covered:
            # an instance none of the 4 nearest view pixels shows, behind all their planes,
            # which are triangles narrower than a view pixel: seen through a gap between
            # triangles finer than the view
            through = True
            for c in range(4):
                r = around[c]
                if (inst_of[slot[r]] == inst_of[bslot] or not box[r, 5] < 1.0
                        or not best > _plane(verts, r, ray_x, ray_y) * (1.0 + 1e-9)):
                    through = False
                    break
            if through:
                bslot = -1
                if record:
                    decided[sel[i]] = GAP
        elif record:
            decided[sel[i]] = HIT if bslot >= 0 else MISS
        if bslot < 0:
            if not covered:
                missed += 1
                continue
            # between triangles finer than the view, inside a surface it covers: the plane of
            # the nearest view pixel's triangle along this ray
            best = _plane(verts, near_r, ray_x, ray_y)
            if best == np.inf:
                continue
            bslot = slot[near_r]
            best_v[:] = verts[near_r]
            subpixel += 1
            if record and decided[sel[i]] != GAP:
                decided[sel[i]] = COVERED
        z = best * zs[i] if scale else best
        if z < near or z > far:
            continue
        o = sel[i]
        out_depth[o] = z
        out_inst[o] = inst_of[bslot]
        out_sem[o] = sem_of[bslot]
        if colour:   # the colour of the nearest of the 4 view pixels that shows this instance
            j, dj = -1, np.inf
            for c in range(4):
                xx, yy = x0 + (c & 1), y0 + (c >> 1)
                d2 = (xx - px) ** 2 + (yy - py) ** 2
                if around[c] >= 0 and inst_of[slot[around[c]]] == inst_of[bslot] and d2 < dj:
                    j, dj = yy * vw + xx, d2
            if j < 0:
                j = (min(max(int(math.floor(py + 0.5)), 0), vh - 1) * vw
                     + min(max(int(math.floor(px + 0.5)), 0), vw - 1))
            out_rgb[o, 0] = rgb[j, 0]
            out_rgb[o, 1] = rgb[j, 1]
            out_rgb[o, 2] = rgb[j, 2]
        if normals:
            v = best_v
            e1x, e1y, e1z = v[3] - v[0], v[4] - v[1], v[5] - v[2]
            e2x, e2y, e2z = v[6] - v[0], v[7] - v[1], v[8] - v[2]
            nx, ny, nz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
            norm = math.sqrt(nx * nx + ny * ny + nz * nz)
            if norm > 0.0:
                sign = -1.0 / norm if nx * ray_x + ny * ray_y + nz > 0.0 else 1.0 / norm   # facing the camera
                nx, ny, nz = nx * sign, ny * sign, nz * sign
                out_normal[o, 0] = R[0, 0] * nx + R[0, 1] * ny + R[0, 2] * nz
                out_normal[o, 1] = R[1, 0] * nx + R[1, 1] * ny + R[1, 2] * nz
                out_normal[o, 2] = R[2, 0] * nx + R[2, 1] * ny + R[2, 2] * nz
    stats[0] += sel.shape[0]
    stats[1] += verts.shape[0]
    stats[2] += tested
    stats[3] += subpixel
    stats[4] += missed
