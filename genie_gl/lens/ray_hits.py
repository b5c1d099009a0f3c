"""Exact lens resampling: each lens pixel's own ray intersected with the triangles of its view.

A pinhole view rendered for a lens records the triangle each of its pixels shows
(:class:`genie_gl.triangles.PixelTriangles`). The candidates of a view are every triangle
the view drew of every instance it shows at one pixel or more (so also the slivers of those
instances too thin to cover any pixel centre: a board seen edge-on, the side of a thin
slat), with their corners in the camera frame (float64), clipped at the view's near plane
and, for meshes drawn with back-face culling, only their faces toward the camera (what the
GPU drew). Each is put in the tiles of :data:`TILE` x :data:`TILE` view pixels its
projected box overlaps, nearest corner first. A lens pixel's ray crosses the view at a
sub-pixel position; it is intersected with the triangle the nearest view pixel shows, then
with every candidate of that position's tile nearer than the hit so far whose projection
holds the position, exactly (a watertight ray-triangle test in float64: a ray through an
edge or a vertex that triangles share hits at least one of them; Woop, Benthin & Wald,
JCGT 2013). The nearest hit gives the pixel's instance, semantic id, depth and normal; a
ray that hits no candidate has no return (it passes the silhouette, or through a gap the
view cannot resolve: what a ray caster says too).

Only an instance the view shows at no pixel at all (wholly finer than a view pixel, or
hidden at every pixel centre) is not tried: these are the sub-pixel triangles;
``oversample`` (finer views) shrinks them. Everywhere else the result is the ray caster's
(tests/lens/test_ray_hits.py compares with Open3D's).
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit

STATS = ("rays", "candidates", "tested", "missed")  # what resample_rays counts, in this order
TILE = 4  # view pixels per side of a tile of the triangles' index


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
def _faces_camera(v):  # pragma: no cover - compiled
    """True when triangle ``v`` (9,: camera frame, outward faces counter-clockwise) faces the
    camera at the origin, as the GPU's back-face culling decides it."""
    nx = (v[4] - v[1]) * (v[8] - v[2]) - (v[5] - v[2]) * (v[7] - v[1])
    ny = (v[5] - v[2]) * (v[6] - v[0]) - (v[3] - v[0]) * (v[8] - v[2])
    nz = (v[3] - v[0]) * (v[7] - v[1]) - (v[4] - v[1]) * (v[6] - v[0])
    return nx * v[0] + ny * v[1] + nz * v[2] < 0.0


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _corners(out, r, m, vertices, g0, g1, g2):  # pragma: no cover - compiled
    """Row ``r`` of ``out`` (T, 9): vertices g0, g1, g2 by ``m`` (3, 4) in float64."""
    for c in range(3):
        g = g0 if c == 0 else (g1 if c == 1 else g2)
        x, y, z = np.float64(vertices[g, 0]), np.float64(vertices[g, 1]), np.float64(vertices[g, 2])
        for q in range(3):
            out[r, 3 * c + q] = m[q, 0] * x + m[q, 1] * y + m[q, 2] * z + m[q, 3]


@njit(cache=True, nogil=True, boundscheck=False)
def _shown(pixel, first, count, base, cfm, indices, vertices):  # pragma: no cover - compiled
    """The triangles the view's pixels show (each once): per view pixel its row (-1: none),
    per row its slot and its camera-frame corners (T, 9)."""
    S = first.shape[0]
    at = np.zeros(S + 1, np.int64)
    for s in range(S):
        at[s + 1] = at[s] + count[s]
    row_of = np.full(at[S], -1, np.int64)
    n = pixel.shape[0] // 2
    pix = np.full(n, -1, np.int64)
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
        t0 = 3 * (first[s] + prim[r])
        _corners(
            verts,
            r,
            cfm[s],
            vertices,
            base[s] + np.int64(indices[t0]),
            base[s] + np.int64(indices[t0 + 1]),
            base[s] + np.int64(indices[t0 + 2]),
        )
    return pix, slot[:rows].copy(), verts


@njit(cache=True, nogil=True, boundscheck=False)
def _candidates(
    shown_slot, mesh_first, mesh_count, base, backcull, cfm, faces, vertices
):  # pragma: no cover
    """The view's candidate triangles: every face of the mesh of every slot in
    ``shown_slot``. Returns per row its slot, whether it may be hit (False: a back face of a
    mesh drawn with back-face culling) and its camera-frame corners (T, 9)."""
    S = base.shape[0]
    shown = np.zeros(S, np.bool_)
    for s in shown_slot:
        shown[s] = True
    at = np.zeros(S + 1, np.int64)
    for s in range(S):
        at[s + 1] = at[s] + (mesh_count[s] if shown[s] else 0)
    T = at[S]
    verts = np.empty((T, 9), np.float64)
    slot = np.empty(T, np.int64)
    front = np.ones(T, np.bool_)
    for s in range(S):
        if not shown[s]:
            continue
        for p in range(mesh_count[s]):
            r = at[s] + p
            f = mesh_first[s] + p
            _corners(
                verts,
                r,
                cfm[s],
                vertices,
                base[s] + np.int64(faces[f, 0]),
                base[s] + np.int64(faces[f, 1]),
                base[s] + np.int64(faces[f, 2]),
            )
            slot[r] = s
            if backcull[s]:
                front[r] = _faces_camera(verts[r])
    return slot, front, verts


@njit(cache=True, nogil=True, boundscheck=False)
def _tiles(verts, front, K, vw, vh, zmin):  # pragma: no cover - compiled
    """Each triangle's projected box and nearest corner (T, 5: u0, u1, v0, v1 in view pixels
    of its part beyond ``zmin``; z0), its projected edge functions (T, 9; zeros, passing
    every point, when it is clipped) and the tiles' lists of the triangles (``front`` only)
    whose box overlaps them, nearest corner first (start (tiles + 1,), rows)."""
    fx, sk, cx, fy, cy = K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]
    T = verts.shape[0]
    ntx, nty = (vw + TILE - 1) // TILE + 1, (vh + TILE - 1) // TILE + 1
    box = np.empty((T, 5), np.float64)
    edges = np.zeros((T, 9), np.float64)  # 2D edge functions (view pixels), all >= 0 inside
    uv = np.empty(6, np.float64)
    span = np.empty((T, 4), np.int64)
    start = np.zeros(ntx * nty + 1, np.int64)
    for r in range(T):
        u0, u1, v0, v1 = np.inf, -np.inf, np.inf, -np.inf
        inside = 0
        for c in range(3):
            x, y, z = verts[r, 3 * c], verts[r, 3 * c + 1], verts[r, 3 * c + 2]
            if z >= zmin:
                inside += 1
                u, v = fx * x / z + sk * y / z + cx, fy * y / z + cy
                uv[2 * c], uv[2 * c + 1] = u, v
                u0, u1, v0, v1 = min(u0, u), max(u1, u), min(v0, v), max(v1, v)
            n = (c + 1) % 3  # where the edge to the next corner crosses z = zmin
            xn, yn, zn = verts[r, 3 * n], verts[r, 3 * n + 1], verts[r, 3 * n + 2]
            if (z - zmin) * (zn - zmin) < 0.0:
                a = (zmin - z) / (zn - z)
                xc, yc = x + a * (xn - x), y + a * (yn - y)
                u, v = fx * xc / zmin + sk * yc / zmin + cx, fy * yc / zmin + cy
                u0, u1, v0, v1 = min(u0, u), max(u1, u), min(v0, v), max(v1, v)
        if inside == 3:
            # the projected triangle's edge functions a u + b v + c, inside >= 0 (scaled to
            # pixels of distance, widened by 1e-6 px beyond rounding): a pre-test only
            sign = (
                1.0
                if (uv[2] - uv[0]) * (uv[5] - uv[1]) - (uv[3] - uv[1]) * (uv[4] - uv[0]) > 0.0
                else -1.0
            )
            for c in range(3):
                n = (c + 1) % 3
                ea, eb = -(uv[2 * n + 1] - uv[2 * c + 1]) * sign, (uv[2 * n] - uv[2 * c]) * sign
                length = math.hypot(ea, eb)
                if length > 0.0:
                    ea, eb = ea / length, eb / length
                edges[r, 3 * c] = ea
                edges[r, 3 * c + 1] = eb
                u, v = uv[2 * c], uv[2 * c + 1]
                edges[r, 3 * c + 2] = -(ea * u + eb * v) + 1e-6 + 1e-9 * (abs(u) + abs(v))
        pad = 1e-6 + 1e-9 * (abs(u0) + abs(u1) + abs(v0) + abs(v1))  # beyond float64 rounding
        box[r, 0], box[r, 1], box[r, 2], box[r, 3] = u0 - pad, u1 + pad, v0 - pad, v1 + pad
        box[r, 4] = min(verts[r, 2], min(verts[r, 5], verts[r, 8]))
        if (
            inside == 0
            or not front[r]
            or box[r, 1] < -1.0
            or box[r, 0] > vw + 1.0
            or box[r, 3] < -1.0
            or box[r, 2] > vh + 1.0
        ):  # nearer than the near plane, a culled back face, or off the view
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
    for r in np.argsort(box[:, 4]):  # each tile's list nearest first
        if span[r, 0] > span[r, 1]:
            continue
        for ty in range(span[r, 2], span[r, 3] + 1):
            for tx in range(span[r, 0], span[r, 1] + 1):
                t = ty * ntx + tx
                rows[fill[t]] = r
                fill[t] += 1
    return box, edges, start, rows, ntx, nty


@njit(cache=True, nogil=True, boundscheck=False)
def resample_rays(
    sel,
    mx,
    my,
    dx,
    dy,
    zs,
    K,
    vw,
    vh,
    zmin,
    near,
    far,
    R,
    pixel,
    first,
    count,
    base,
    backcull,
    cfm,
    indices,
    mesh_first,
    mesh_count,
    faces,
    vertices,
    inst_of,
    sem_of,
    rgb,
    out_depth,
    out_inst,
    out_sem,
    out_rgb,
    out_normal,
    stats,
):  # pragma: no cover
    """Write the samples of one view into the lens image, each from its own ray.

    sel (N,) int64: output pixel of each sample; mx, my (N,) float64: where its ray crosses
    the view (view pixels, by ``K``); dx, dy (N,) float64: its ray (view frame, z = 1); zs
    (N,) or (0,): camera-frame z per view-frame z along the ray; K (3, 3): the view's; vw, vh:
    its size; zmin: the view's GPU near plane (z, what it clipped away); near, far: the
    sensor's range (camera z); R (3, 3): camera_from_view. pixel (vh·vw·2,) uint32, first,
    count, base, backcull, cfm, indices, mesh_first, mesh_count, inst_of, sem_of: the view's
    :class:`~genie_gl.triangles.PixelTriangles`; faces, vertices: its scene's. rgb
    (vh·vw, 3) uint8 or (0, 3): the view's colour. out_*: the lens image's buffers
    (zero-filled), written where a sample has a return (out_rgb, out_normal may be (0, 3):
    not written). stats (4,) int64: :data:`STATS`, added to.
    """
    colour = rgb.shape[0] > 0 and out_rgb.shape[0] > 0
    normals = out_normal.shape[0] > 0
    scale = zs.shape[0] > 0
    pix, pslot, pverts = _shown(pixel, first, count, base, cfm, indices, vertices)
    slot, front, verts = _candidates(
        np.unique(pslot), mesh_first, mesh_count, base, backcull, cfm, faces, vertices
    )
    box, edges, start, rows, ntx, nty = _tiles(verts, front, K, vw, vh, zmin)
    around = np.empty(
        4, np.int64
    )  # the triangle each of the 4 nearest view pixels shows (-1: none)
    best_v = np.empty(9, np.float64)
    tested = missed = 0
    for i in range(sel.shape[0]):
        px, py = mx[i], my[i]
        ray_x, ray_y = dx[i], dy[i]
        x0, y0 = int(math.floor(px)), int(math.floor(py))
        for c in range(4):
            xx, yy = x0 + (c & 1), y0 + (c >> 1)
            around[c] = (
                pix[yy * vw + xx] if 0 <= xx < vw and 0 <= yy < vh else -1
            )  # a row of pverts
        # the nearest view pixel's triangle first: most rays hit it, and then only what is
        # nearer than that hit is tried
        best, bslot = np.inf, -1
        near_r = around[2 * int(py - y0 >= 0.5) + int(px - x0 >= 0.5)]
        if near_r >= 0:
            tested += 1
            best = _hit(pverts, near_r, ray_x, ray_y, zmin)
            if best < np.inf:
                bslot = pslot[near_r]
                best_v[:] = pverts[near_r]
        tile = min(max(int(math.floor(py / TILE)), 0), nty - 1) * ntx + min(
            max(int(math.floor(px / TILE)), 0), ntx - 1
        )
        for e in range(start[tile], start[tile + 1]):
            r = rows[e]
            if box[r, 4] >= best:  # this one and all after it lie beyond the hit
                break
            if px < box[r, 0] or px > box[r, 1] or py < box[r, 2] or py > box[r, 3]:
                continue
            if (
                edges[r, 0] * px + edges[r, 1] * py + edges[r, 2] < 0.0
                or edges[r, 3] * px + edges[r, 4] * py + edges[r, 5] < 0.0
                or edges[r, 6] * px + edges[r, 7] * py + edges[r, 8] < 0.0
            ):
                # outside the projected triangle (zeros, always passed, where it is clipped)
                continue
            tested += 1
            t = _hit(verts, r, ray_x, ray_y, zmin)
            if t < best:
                best, bslot = t, slot[r]
                best_v[:] = verts[r]
        if bslot < 0:
            missed += 1
            continue
        z = best * zs[i] if scale else best
        if z < near or z > far:
            continue
        o = sel[i]
        out_depth[o] = z
        out_inst[o] = inst_of[bslot]
        out_sem[o] = sem_of[bslot]
        if colour:  # the colour of the nearest of the 4 view pixels that shows this instance
            j, dj = -1, np.inf
            for c in range(4):
                xx, yy = x0 + (c & 1), y0 + (c >> 1)
                d2 = (xx - px) ** 2 + (yy - py) ** 2
                if around[c] >= 0 and inst_of[pslot[around[c]]] == inst_of[bslot] and d2 < dj:
                    j, dj = yy * vw + xx, d2
            if j < 0:
                j = min(max(int(math.floor(py + 0.5)), 0), vh - 1) * vw + min(
                    max(int(math.floor(px + 0.5)), 0), vw - 1
                )
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
                sign = (
                    -1.0 / norm if nx * ray_x + ny * ray_y + nz > 0.0 else 1.0 / norm
                )  # facing the camera
                nx, ny, nz = nx * sign, ny * sign, nz * sign
                out_normal[o, 0] = R[0, 0] * nx + R[0, 1] * ny + R[0, 2] * nz
                out_normal[o, 1] = R[1, 0] * nx + R[1, 1] * ny + R[1, 2] * nz
                out_normal[o, 2] = R[2, 0] * nx + R[2, 1] * ny + R[2, 2] * nz
    stats[0] += sel.shape[0]
    stats[1] += verts.shape[0]
    stats[2] += tested
    stats[3] += missed
