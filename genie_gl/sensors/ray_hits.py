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
TILE = 4   # view pixels per side of a tile of the triangles' index


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _hit(verts, r, dx, dy):  # pragma: no cover - compiled
    """z (view frame) where the ray (dx, dy, 1) from the camera centre meets triangle ``r``
    of ``verts`` (T, 9: corners a, b, c), inf on a miss. The triangle is sheared along the ray (x - dx
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
    return t if t > 0.0 else np.inf


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


@njit(cache=True, nogil=True, boundscheck=False)
def _shown(pixel, first, count, base, cfm, indices, vertices):  # pragma: no cover - compiled
    """The triangles the view shows: (per pixel its triangle's row, -1 for none; per
    triangle its slot and camera-frame corners (T, 9))."""
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
    return pix, slot[:rows].copy(), verts


@njit(cache=True, nogil=True, boundscheck=False)
def _tiles(verts, K, vw, vh):  # pragma: no cover - compiled
    """Each triangle's projected box and nearest corner (T, 5: u0, u1, v0, v1 in view pixels,
    the whole plane when a corner is not in front of the camera; z0) and the tiles' lists of
    the triangles whose box overlaps them (start (tiles + 1,), rows)."""
    fx, sk, cx, fy, cy = K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]
    T = verts.shape[0]
    ntx, nty = (vw + TILE - 1) // TILE + 1, (vh + TILE - 1) // TILE + 1
    box = np.empty((T, 5), np.float64)
    span = np.empty((T, 4), np.int64)
    start = np.zeros(ntx * nty + 1, np.int64)
    for r in range(T):
        u0, u1, v0, v1 = np.inf, -np.inf, np.inf, -np.inf
        for c in range(3):
            x, y, z = verts[r, 3 * c], verts[r, 3 * c + 1], verts[r, 3 * c + 2]
            if not z > 1e-12:
                u0, u1, v0, v1 = -np.inf, np.inf, -np.inf, np.inf
                break
            u, v = fx * x / z + sk * y / z + cx, fy * y / z + cy
            u0, u1, v0, v1 = min(u0, u), max(u1, u), min(v0, v), max(v1, v)
        pad = 1e-6 + 1e-9 * (abs(u0) + abs(u1) + abs(v0) + abs(v1))   # beyond float64 rounding
        box[r, 0], box[r, 1], box[r, 2], box[r, 3] = u0 - pad, u1 + pad, v0 - pad, v1 + pad
        box[r, 4] = min(verts[r, 2], min(verts[r, 5], verts[r, 8]))
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
    for r in range(T):
        for ty in range(span[r, 2], span[r, 3] + 1):
            for tx in range(span[r, 0], span[r, 1] + 1):
                t = ty * ntx + tx
                rows[fill[t]] = r
                fill[t] += 1
    return box, start, rows, ntx, nty


@njit(cache=True, nogil=True, boundscheck=False)
def resample_rays(sel, mx, my, dx, dy, zs, K, vw, vh, near, far, R,
                  pixel, first, count, base, cfm, indices, vertices, inst_of, sem_of,
                  rgb, out_depth, out_inst, out_sem, out_rgb, out_normal, stats):  # pragma: no cover
    """Write the samples of one view into the lens image, each from its own ray.

    sel (N,) int64: output pixel of each sample; mx, my (N,) float64: where its ray crosses
    the view (view pixels, by ``K``); dx, dy (N,) float64: its ray (view frame, z = 1); zs
    (N,) or (0,): camera-frame z per view-frame z along the ray; K (3, 3): the view's; vw, vh:
    its size; near, far: the sensor's range; R (3, 3): camera_from_view. pixel (vh·vw·2,)
    uint32 and first, count, base, cfm, indices, vertices, inst_of, sem_of: the view's
    :class:`~genie_gl.triangles.PixelTriangles`. rgb (vh·vw, 3) uint8 or (0, 3): the view's
    colour. out_*: the lens image's buffers (zero-filled), written where a sample has a
    return (out_rgb, out_normal may be (0, 3): not written). stats (5,) int64:
    :data:`STATS`, added to.
    """
    colour = rgb.shape[0] > 0 and out_rgb.shape[0] > 0
    normals = out_normal.shape[0] > 0
    scale = zs.shape[0] > 0
    pix, slot, verts = _shown(pixel, first, count, base, cfm, indices, vertices)
    box, start, rows, ntx, nty = _tiles(verts, K, vw, vh)
    around = np.empty(4, np.int64)   # the triangle each of the 4 nearest view pixels shows (-1: none)
    tested = 0
    for i in range(sel.shape[0]):
        px, py = mx[i], my[i]
        ray_x, ray_y = dx[i], dy[i]
        x0, y0 = int(math.floor(px)), int(math.floor(py))
        covered = True
        for c in range(4):
            xx, yy = x0 + (c & 1), y0 + (c >> 1)
            around[c] = pix[yy * vw + xx] if 0 <= xx < vw and 0 <= yy < vh else -1
            covered &= around[c] >= 0
        # the nearest view pixel's triangle first: most rays hit it, and then only what is
        # nearer than that hit is tried
        best, hit = np.inf, -1
        near_r = around[2 * int(py - y0 >= 0.5) + int(px - x0 >= 0.5)]
        if near_r >= 0:
            tested += 1
            best = _hit(verts, near_r, ray_x, ray_y)
            if best < np.inf:
                hit = near_r
        tile = (min(max(int(math.floor(py / TILE)), 0), nty - 1) * ntx
                + min(max(int(math.floor(px / TILE)), 0), ntx - 1))
        for e in range(start[tile], start[tile + 1]):
            r = rows[e]
            if (box[r, 4] >= best or px < box[r, 0] or px > box[r, 1] or py < box[r, 2] or py > box[r, 3]
                    or r == near_r):
                continue
            tested += 1
            t = _hit(verts, r, ray_x, ray_y)
            if t < best:
                best, hit = t, r
        if hit >= 0 and covered:
            # an instance none of the 4 nearest view pixels shows, behind all their planes:
            # seen through a gap finer than the view
            through = True
            for c in range(4):
                r = around[c]
                if inst_of[slot[r]] == inst_of[slot[hit]] or not best > _plane(verts, r, ray_x, ray_y) * (1.0 + 1e-9):
                    through = False
                    break
            if through:
                hit = -1
        if hit < 0:
            if not covered:
                stats[4] += 1
                continue
            # between triangles finer than the view, inside a surface it covers: the plane of
            # the nearest view pixel's triangle along this ray
            hit = near_r
            best = _plane(verts, hit, ray_x, ray_y)
            if best == np.inf:
                continue
            stats[3] += 1
        z = best * zs[i] if scale else best
        if z < near or z > far:
            continue
        o = sel[i]
        s = slot[hit]
        out_depth[o] = z
        out_inst[o] = inst_of[s]
        out_sem[o] = sem_of[s]
        if colour:   # the colour of the nearest of the 4 view pixels that shows this instance
            j, dj = -1, np.inf
            for c in range(4):
                xx, yy = x0 + (c & 1), y0 + (c >> 1)
                d2 = (xx - px) ** 2 + (yy - py) ** 2
                if around[c] >= 0 and inst_of[slot[around[c]]] == inst_of[s] and d2 < dj:
                    j, dj = yy * vw + xx, d2
            if j < 0:
                j = (min(max(int(math.floor(py + 0.5)), 0), vh - 1) * vw
                     + min(max(int(math.floor(px + 0.5)), 0), vw - 1))
            out_rgb[o, 0] = rgb[j, 0]
            out_rgb[o, 1] = rgb[j, 1]
            out_rgb[o, 2] = rgb[j, 2]
        if normals:
            v = verts[hit]
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
