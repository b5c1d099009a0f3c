"""The CPU rasteriser: per pixel centre, the nearest triangle along its ray (numba, parallel).

``Renderer(scene, raster="cpu")`` draws with this instead of OpenGL. It visits the same
hierarchy as the culler (:mod:`genie_gl.render.cull`): instances outside the frustum are
dropped before anything here runs; per cluster, its bounding sphere against the frustum and,
for back-face-culled instances, its normal cone; then each triangle of the clusters that pass.

A triangle is tested against the rays of the pixel centres in its screen box, in the camera
frame and in float64, with homogeneous edge functions (Olano and Greer, 1997): the ray
``d = K^-1 (u, v, 1)`` lies inside triangle ABC when ``(A x B)·d``, ``(B x C)·d`` and
``(C x A)·d`` all have the sign of ``A·(B x C)``. No triangle is clipped: one crossing the
near plane is tested like any other, its box taken from its part in front. Where the ray hits
it, the depth is the exact intersection ``z = A·(B x C) / (n·d)`` with its plane (``n`` its
normal), and the nearest hit wins. Edge functions of a shared edge are computed from the same
two vertices in the same order of operations (no fused multiply-add: the kernels are built
without ``fastmath``), so the two triangles of an edge give exact negatives and a pixel
centre on it belongs to both: there are no cracks between triangles.

Depth ties (equal float64 z) go to the lower (instance slot, face). Each thread draws column
strips of its own (no pixel is written by two threads), so a frame does not depend on the
number of threads or on the order the clusters are visited.

What this gives against the OpenGL raster: depth exact along each pixel's ray (the GL path
interpolates float32 eye coordinates over a snapped triangle), coverage decided at the pixel
centre in float64 (GL: sub-pixel fixed point and its fill rule), no GL context, no clear and
no read-back. Sub-pixel triangles, most of a scene of millions, cost a box test each.
"""
from __future__ import annotations

import math

import numba
import numpy as np
from numba import njit, prange

from .clusters import CLUSTER
from .cull import _cone_drops, sphere_in_view

PARALLEL_FACES = 5_000      # below this many faces in view, one thread draws a frame
SHIFT = 3
TILE = 1 << SHIFT           # pixels: the side of an occlusion tile


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _clip_box(ax, ay, az, bx, by, bz, cx_, cy_, cz, near, proj, box):
    """The pixel-centre box (ulo, uhi, vlo, vhi) of the part of triangle ABC at z >= near,
    written into ``box`` (unbounded in float, clamped by the caller)."""
    fx, s, cx, fy, cy = proj[0], proj[1], proj[2], proj[3], proj[4]
    umin, umax, vmin, vmax = math.inf, -math.inf, math.inf, -math.inf
    px = (ax, bx, cx_)
    py = (ay, by, cy_)
    pz = (az, bz, cz)
    for i in range(3):
        j = (i + 1) % 3
        x0, y0, z0 = px[i], py[i], pz[i]
        x1, y1, z1 = px[j], py[j], pz[j]
        if z0 >= near:    # the vertex itself
            u = (fx * x0 + s * y0) / z0 + cx
            v = fy * y0 / z0 + cy
            umin, umax, vmin, vmax = min(umin, u), max(umax, u), min(vmin, v), max(vmax, v)
        if (z0 >= near) != (z1 >= near):    # where the edge crosses the near plane
            t = (near - z0) / (z1 - z0)
            x, y = x0 + t * (x1 - x0), y0 + t * (y1 - y0)
            u = (fx * x + s * y) / near + cx
            v = fy * y / near + cy
            umin, umax, vmin, vmax = min(umin, u), max(umax, u), min(vmin, v), max(vmax, v)
    box[0], box[1], box[2], box[3] = umin, umax, vmin, vmax


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _hidden(tmin, ulo, uhi, vlo, vhi, iz):
    """True when every tile the pixel box touches holds only inverse depths above ``iz``
    (nearer than 1 / iz; a tile's value is its pixels' least)."""
    for tr in range(int(vlo) >> SHIFT, (int(vhi) >> SHIFT) + 1):
        for tc in range(int(ulo) >> SHIFT, (int(uhi) >> SHIFT) + 1):
            if tmin[tr, tc] <= iz:
                return False
    return True


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _refresh(tmin, dirty, zb, ulo, uhi, vlo, vhi, Wi, Hi):
    """Recompute the tiles written since their last refresh (``dirty``) in the pixel box: the
    least inverse depth each holds (0 while one of its pixels is empty); returns how many."""
    n = 0
    for tr in range(vlo >> SHIFT, (vhi >> SHIFT) + 1):
        for tc in range(ulo >> SHIFT, (uhi >> SHIFT) + 1):
            if not dirty[tr, tc]:
                continue
            dirty[tr, tc] = 0
            n += 1
            lo = math.inf
            for iv in range(tr * TILE, min((tr + 1) * TILE, Hi)):
                row = iv * Wi
                for iu in range(tc * TILE, min((tc + 1) * TILE, Wi)):
                    lo = min(lo, zb[row + iu])
            tmin[tr, tc] = lo
    return n


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _write(zb, who, dirty, iu, iv, Wi, iz, key, inear):
    """The depth test of a hit at pixel (iu, iv) of inverse depth ``iz`` = (n·d) / A·(B x C)
    (larger is nearer; no hit nearer than the near plane, 1 / ``inear``): it wins over what
    the pixel holds when nearer, or as near and of a lower (slot, face) ``key``."""
    p = iv * Wi + iu
    if (iz <= inear) & ((iz > zb[p]) | ((iz == zb[p]) & (key < who[p]))):
        zb[p] = iz
        who[p] = key
        dirty[iv >> SHIFT, iu >> SHIFT] = 1


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _edge_span(ex, ry, sg, fx, cx, sy, lo, hi):
    """Narrow [lo, hi] (floats) to the u where sg E(u) >= 0 for an edge E(u) = ex xn(u) + ry,
    xn(u) = (u - cx) / fx - sy; the caller widens by a pixel and tests exactly."""
    a = sg * ex / fx
    b = sg * (ry - ex * (cx / fx + sy))
    if a > 0.0:
        lo = max(lo, -b / a)
    elif a < 0.0:
        hi = min(hi, -b / a)
    elif b < 0.0:
        lo, hi = 1.0, 0.0
    return lo, hi


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", fastmath={"nnan", "ninf", "nsz"})
def _project(m, X, Y, Z, v0, nv, proj, near, width, height, wx, wy, wz, wu, wv, keys_u, keys_v):
    """Camera-frame vertices ``v0 .. v0 + nv``, their window coordinates, and per axis the
    cell (k, k + 1) between pixel centres that holds each with a margin (a vertex near a
    centre, or behind the near plane, gets a key of its own): a triangle whose vertices share
    a cell on either axis holds no pixel centre. Each vertex is computed by the same
    instructions wherever it is stored, so a vertex shared by two clusters is the same (the
    loop runs in vector registers: the coordinates come as three arrays, ``X``, ``Y``, ``Z``)."""
    fx, s, cx, fy, cy = proj[0], proj[1], proj[2], proj[3], proj[4]
    last_u, last_v = width - 1.0, height - 1.0
    m00, m01, m02, m03 = m[0, 0], m[0, 1], m[0, 2], m[0, 3]   # in registers: the stores below
    m10, m11, m12, m13 = m[1, 0], m[1, 1], m[1, 2], m[1, 3]   # cannot be proven not to alias m
    m20, m21, m22, m23 = m[2, 0], m[2, 1], m[2, 2], m[2, 3]
    Xs, Ys, Zs = X[v0:v0 + nv], Y[v0:v0 + nv], Z[v0:v0 + nv]
    for w in range(nv):
        px, py, pz = np.float64(Xs[w]), np.float64(Ys[w]), np.float64(Zs[w])
        x = m00 * px + m01 * py + m02 * pz + m03
        y = m10 * px + m11 * py + m12 * pz + m13
        z = m20 * px + m21 * py + m22 * pz + m23
        wx[w] = x
        wy[w] = y
        wz[w] = z
        own = -2.0 - w
        iz = 1.0 / (z if z >= near else 1.0)
        u = (fx * x + s * y) * iz + cx
        v = fy * y * iz + cy
        wu[w] = u
        wv[w] = v
        e = 1e-7 * (abs(u) + abs(v) + 1.0)
        hu, hv = np.floor(u + e), np.floor(v + e)
        ku = hu if np.ceil(u - e) > hu else own
        kv = hv if np.ceil(v - e) > hv else own
        ku = -1.0 if u + e < 0.0 else (width if u - e > last_u else ku)
        kv = -1.0 if v + e < 0.0 else (height if v - e > last_v else kv)
        front = z >= near
        keys_u[w] = ku if front else own
        keys_v[w] = kv if front else own


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _bound_cluster(q, k, c_lo, c_hi, c_centre, c_radius, c_axis, c_cos, c_sin, c_thick, c_perim, slot, cbase,
                   backcull, cfm, eye, det, proj, planes, near, width, height, cull, out):
    """Whether cluster k of visible instance q may show: False when its sphere is outside the
    frustum, when every face is back-facing (back-face-culled instances: the culler's cone
    bound, which holds for the GPU's float32 rounding and so for float64), or when its box is
    off screen. Writes (ulo, uhi, vlo, vhi, z) into ``out``: the pixel box it may cover and
    its nearest depth (its box's eight corners bound both more tightly than its sphere; the
    whole image and the near plane when it reaches the near plane). Without ``cull``, always
    True with the whole image."""
    fx, s, cx, fy, cy = proj[0], proj[1], proj[2], proj[3], proj[4]
    last_u, last_v = width - 1.0, height - 1.0
    out[0], out[1], out[2], out[3], out[4] = 0.0, last_u, 0.0, last_v, near
    if not cull:
        return True
    cl = cbase[q] + k
    m = cfm[slot[q]]
    ex, ey, ez, rad, sc, rmag, tmag, inside = sphere_in_view(m, c_centre, c_radius, cl, planes)
    if not inside:
        return False
    if backcull[q] and _cone_drops(m, det[q], eye[q], c_centre[cl], c_radius[cl], c_axis[cl], c_cos[cl], c_sin[cl],
                                   c_thick[cl], c_perim[cl], ez, ex, ey, rad, sc, rmag, tmag, proj, near, 2.0 ** -8,
                                   width, height):
        return False
    zlo = ez - rad
    if zlo <= near:
        return True
    zb_lo, bu_lo, bu_hi, bv_lo, bv_hi = math.inf, math.inf, -math.inf, math.inf, -math.inf
    for corner in range(8):
        px = c_hi[cl, 0] if corner & 1 else c_lo[cl, 0]
        py = c_hi[cl, 1] if corner & 2 else c_lo[cl, 1]
        pz = c_hi[cl, 2] if corner & 4 else c_lo[cl, 2]
        x = m[0, 0] * px + m[0, 1] * py + m[0, 2] * pz + m[0, 3]
        y = m[1, 0] * px + m[1, 1] * py + m[1, 2] * pz + m[1, 3]
        z = m[2, 0] * px + m[2, 1] * py + m[2, 2] * pz + m[2, 3]
        zb_lo = min(zb_lo, z)
        if z > 0.0:
            u = (fx * x + s * y) / z + cx
            v = fy * y / z + cy
            bu_lo, bu_hi, bv_lo, bv_hi = min(bu_lo, u), max(bu_hi, u), min(bv_lo, v), max(bv_hi, v)
    if zb_lo <= near:   # the sphere reaches no nearer than the near plane; its box does
        return True
    out[0] = max(np.floor(bu_lo) - 1.0, 0.0)
    out[1] = min(np.ceil(bu_hi) + 1.0, last_u)
    out[2] = max(np.floor(bv_lo) - 1.0, 0.0)
    out[3] = min(np.ceil(bv_hi) + 1.0, last_v)
    out[4] = max(zlo, zb_lo * (1.0 - 1e-12))
    return out[0] <= out[1] and out[2] <= out[3]


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _draw_cluster(q, k, col_lo, col_hi, bound, X, Y, Z, faces, c_vrange, slot, vbase, fbase, nfaces, cbase,
                  backcull, cfm, proj, near, width, height, xs, ys, sys_, zb, who, tmax, dirty, wx, wy, wz, wu, wv,
                  keys_u, keys_v, live, box, span, tally, cull):
    """Draw cluster k of visible instance q into the columns col_lo..col_hi, unless every
    tile of its box there (``bound``: :func:`_bound_cluster`'s) lies nearer than it; counts
    into ``tally`` (clusters drawn, faces with a pixel box, faces hidden, faces drawn, pixels
    tested, occlusion tiles refreshed). Without ``cull``, every face is tested against every
    pixel centre of its box (no cluster, cone, cell, occlusion or span test): the reference
    the culled frame must equal byte for byte."""
    fx, s, cx, fy, cy = proj[0], proj[1], proj[2], proj[3], proj[4]
    f0 = fbase[q] + k * CLUSTER
    nf = min(CLUSTER, nfaces[q] - k * CLUSTER)
    cl = cbase[q] + k
    vb = vbase[q]
    sl = slot[q]
    m = cfm[sl]
    bc = backcull[q]
    Wi, Hi = int(width), int(height)
    last_u, last_v = width - 1.0, height - 1.0
    ulo_c, uhi_c = max(bound[0], col_lo), min(bound[1], col_hi)
    if ulo_c > uhi_c:
        return
    zlo = bound[4]
    if cull and zlo > near and _hidden(tmax, ulo_c, uhi_c, bound[2], bound[3], 1.0 / zlo):
        return
    tally[0] += 1
    v_lo = c_vrange[cl, 0]
    nv = c_vrange[cl, 1] - v_lo
    # camera-frame vertices, window coordinates, and per axis the cell (k, k + 1) between
    # pixel centres that holds the vertex with a margin (a vertex near a centre, or behind the
    # near plane, gets a key of its own): a triangle whose vertices share a cell on either
    # axis holds no pixel centre
    _project(m, X, Y, Z, vb + v_lo, nv, proj, near, width, height, wx, wy, wz, wu, wv, keys_u, keys_v)
    key0 = np.int64(sl) << np.int64(32)
    inear = 1.0 / near
    ifx, ify = 1.0 / fx, 1.0 / fy
    du_lo, du_hi, dv_lo, dv_hi = Wi, -1, Hi, -1     # the box of the pixels this cluster tested
    # the faces whose vertices do not share a cell, listed without a branch per face (most
    # faces of a large scene are smaller than a pixel and go here)
    nl = 0
    for i in range(nf):
        f = f0 + i
        a, b, c = faces[f, 0] - v_lo, faces[f, 1] - v_lo, faces[f, 2] - v_lo
        ka, kb, kc = keys_u[a], keys_u[b], keys_u[c]
        la, lb, lc = keys_v[a], keys_v[b], keys_v[c]
        live[nl] = i
        nl += 1 - (cull & (((ka == kb) & (kb == kc)) | ((la == lb) & (lb == lc))))
    for ii in range(nl):
        f = f0 + live[ii]
        a, b, c = faces[f, 0] - v_lo, faces[f, 1] - v_lo, faces[f, 2] - v_lo
        az, bz, cz = wz[a], wz[b], wz[c]
        front = (az >= near) + (bz >= near) + (cz >= near)
        if front == 0:
            continue
        if front == 3:
            ua, ub, uc = wu[a], wu[b], wu[c]
            va, vb_, vc = wv[a], wv[b], wv[c]
            umin, umax = min(ua, min(ub, uc)), max(ua, max(ub, uc))
            vmin, vmax = min(va, min(vb_, vc)), max(va, max(vb_, vc))
            zmin = min(az, min(bz, cz))
        else:
            _clip_box(wx[a], wy[a], az, wx[b], wy[b], bz, wx[c], wy[c], cz, near, proj, box)
            umin, umax, vmin, vmax = box[0], box[1], box[2], box[3]
            zmin = near
        # the box of the pixel centres it may hold (projection rounding: a generous margin,
        # the edge functions below decide)
        mu = 1e-7 * (abs(umin) + abs(umax) + 1.0)
        mv = 1e-7 * (abs(vmin) + abs(vmax) + 1.0)
        ulo = max(np.ceil(umin - mu), col_lo)
        uhi = min(np.floor(umax + mu), col_hi)
        if ulo > uhi:
            continue
        vlo = max(np.ceil(vmin - mv), 0.0)
        vhi = min(np.floor(vmax + mv), last_v)
        if vlo > vhi:
            continue
        ax_, ay_ = wx[a], wy[a]
        bx_, by_ = wx[b], wy[b]
        cx_, cy_ = wx[c], wy[c]
        # edge functions (A x B)·d, (B x C)·d, (C x A)·d
        e1x, e1y, e1z = by_ * cz - bz * cy_, bz * cx_ - bx_ * cz, bx_ * cy_ - by_ * cx_
        vol = ax_ * e1x + ay_ * e1y + az * e1z        # A·(B x C): twice the signed volume
        if vol == 0.0:
            continue                                   # its plane holds the eye: edge-on
        # front faces are clockwise on screen (v down): A·(B x C) < 0 seen from outside
        if bc and vol > 0.0:
            continue
        tally[1] += 1
        if cull and _hidden(tmax, ulo, uhi, vlo, vhi, 1.0 / zmin):
            tally[2] += 1
            continue
        tally[3] += 1
        e0x, e0y, e0z = ay_ * bz - az * by_, az * bx_ - ax_ * bz, ax_ * by_ - ay_ * bx_
        e2x, e2y, e2z = cy_ * az - cz * ay_, cz * ax_ - cx_ * az, cx_ * ay_ - cy_ * ax_
        nx, ny, nz = e0x + e1x + e2x, e0y + e1y + e2y, e0z + e1z + e2z   # (B - A) x (C - A)
        sg = 1.0 if vol > 0.0 else -1.0
        ivol = 1.0 / vol
        key = key0 | np.int64(f)
        if ulo == uhi and vlo == vhi:
            # one pixel centre in its box (most faces of a large scene that get this far):
            # the exact test at once, no spans
            iu, iv = int(ulo), int(vlo)
            yn = ys[iv]
            xn = xs[iu] - sys_[iv]
            tally[4] += 1
            if ((sg * (e0x * xn + (e0y * yn + e0z)) >= 0.0) & (sg * (e1x * xn + (e1y * yn + e1z)) >= 0.0)
                    & (sg * (e2x * xn + (e2y * yn + e2z)) >= 0.0)):
                _write(zb, who, dirty, iu, iv, Wi, (nx * xn + (ny * yn + nz)) * ivol, key, inear)
                du_lo, du_hi, dv_lo, dv_hi = min(du_lo, iu), max(du_hi, iu), min(dv_lo, iv), max(dv_hi, iv)
            continue
        # per edge, sg E = A u + B v + C in pixel coordinates. The box is scanned along its
        # longer side, line by line (rows: v fixed; columns: u fixed): on a line w the edge's
        # inner side is x >= P + Q w or x <= P + Q w (x the scanned coordinate), or all or
        # nothing. The span's rounding is far below ``gap``: centres more than ``gap`` inside
        # it are inside; those nearer its ends get the exact test, the same expression
        # whichever way a triangle is scanned (so that shared edges stay watertight).
        rows = (vhi - vlo) <= (uhi - ulo)
        for k in range(3):
            ex_, ey_, ez_ = (e0x, e0y, e0z) if k == 0 else ((e1x, e1y, e1z) if k == 1 else (e2x, e2y, e2z))
            A = sg * ex_ * ifx
            B = sg * (ey_ - ex_ * s * ifx) * ify
            C = sg * ez_ - A * cx - B * cy
            a_, b_ = (A, B) if rows else (B, A)   # the scanned coordinate's coefficient, the line's
            if a_ != 0.0:
                ia = -1.0 / a_
                span[k, 0] = 1.0 if a_ > 0.0 else -1.0
                span[k, 1] = C * ia
                span[k, 2] = b_ * ia
                span[k, 3] = 1e-12 * (abs(span[k, 1]) + abs(span[k, 2]) * (Wi + Hi) + 1.0)
            else:
                span[k, 0] = 0.0
                span[k, 1] = b_
                span[k, 2] = C
                span[k, 3] = 0.0
        w_lo, w_hi = (vlo, vhi) if rows else (ulo, uhi)
        x_lo, x_hi = (ulo, uhi) if rows else (vlo, vhi)
        for iw in range(int(w_lo), int(w_hi) + 1):
            lo, hi, gap = x_lo, x_hi, 0.0
            for k in range(3 if cull else 0):
                if span[k, 0] > 0.0:
                    lo = max(lo, span[k, 1] + span[k, 2] * iw)
                elif span[k, 0] < 0.0:
                    hi = min(hi, span[k, 1] + span[k, 2] * iw)
                elif span[k, 1] * iw + span[k, 2] < -1e-9 * (abs(span[k, 1] * iw) + abs(span[k, 2])):
                    hi = -1.0
                gap = max(gap, span[k, 3])
            if not (lo <= hi + 2.0):
                continue
            i_lo = int(max(np.ceil(lo) - 1.0, x_lo))
            i_hi = int(min(np.floor(hi) + 1.0, x_hi))
            if i_lo > i_hi:
                continue
            in_lo, in_hi = (lo + gap, hi - gap) if cull else (math.inf, -math.inf)
            tally[4] += i_hi - i_lo + 1
            # the box of what this cluster may have written (the dirty tiles in it are refreshed)
            if rows:
                du_lo, du_hi, dv_lo, dv_hi = min(du_lo, i_lo), max(du_hi, i_hi), min(dv_lo, iw), max(dv_hi, iw)
            else:
                du_lo, du_hi, dv_lo, dv_hi = min(du_lo, iw), max(du_hi, iw), min(dv_lo, i_lo), max(dv_hi, i_hi)
            for ix in range(i_lo, i_hi + 1):
                iu, iv = (ix, iw) if rows else (iw, ix)
                yn = ys[iv]
                xn = xs[iu] - sys_[iv]
                if not (in_lo < ix < in_hi):
                    inside = ((sg * (e0x * xn + (e0y * yn + e0z)) >= 0.0)
                              & (sg * (e1x * xn + (e1y * yn + e1z)) >= 0.0)
                              & (sg * (e2x * xn + (e2y * yn + e2z)) >= 0.0))
                    if not inside:
                        continue
                _write(zb, who, dirty, iu, iv, Wi, (nx * xn + (ny * yn + nz)) * ivol, key, inear)
    if du_hi >= 0:
        tally[5] += _refresh(tmax, dirty, zb, du_lo, du_hi, dv_lo, dv_hi, Wi, Hi)


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _nearest_first(alive, bounds, near):
    """The clusters that may show (``alive``), nearest first by their least depth
    (``bounds[:, 4]``), in 1024 buckets of equal depth ratio (a counting sort, stable; the
    order only decides how soon occluders are drawn, never a pixel)."""
    n = len(alive)
    lo, hi = math.inf, 0.0
    count = 0
    for j in range(n):
        if alive[j]:
            z = max(bounds[j, 4], near)
            lo, hi = min(lo, z), max(hi, z)
            count += 1
    out = np.empty(count, np.int64)
    if count == 0:
        return out
    nb = 1024
    scale = (nb - 1) / max(math.log(hi / lo), 1e-12)
    key = np.empty(n, np.int64)
    start = np.zeros(nb + 1, np.int64)
    for j in range(n):
        if alive[j]:
            b = min(int(math.log(max(bounds[j, 4], near) / lo) * scale), nb - 1)
            key[j] = b
            start[b + 1] += 1
    for b in range(nb):
        start[b + 1] += start[b]
    for j in range(n):
        if alive[j]:
            out[start[key[j]]] = j
            start[key[j]] += 1
    return out


@njit(cache=True, nogil=True, parallel=True, boundscheck=False, error_model="numpy")
def _raster(X, Y, Z, faces, c_lo, c_hi, c_centre, c_radius, c_vrange, c_axis, c_cos, c_sin, c_thick, c_perim,
            slot, vbase, fbase, nfaces, cbase, job0, backcull, cfm, eye, det, proj, planes, near, width, height,
            T, zb, who, tmin, tally, cull, ids, sems, near_m, far_m, out_depth, out_instance, out_semantic):
    """Draw the clusters of the visible instances (jobs job0[q]..job0[q+1] are instance q's)
    nearest first into ``zb`` (float64 1 / z, 0 where nothing) and ``who`` (slot << 32 |
    face where ``zb`` holds a hit; not cleared, so anything elsewhere), H x W flattened, with T threads: thread t draws the columns of
    strip t, the strips cut where the clusters' centres split evenly (whole tiles), so each
    thread's occlusion tiles see every occluder of its strip and no pixel is written by two."""
    W = int(width)
    H = int(height)
    xs = np.empty(W)
    for u in range(W):
        xs[u] = (u - proj[2]) / proj[0]
    ys, sys_ = np.empty(H), np.empty(H)
    for v in range(H):
        ys[v] = (v - proj[4]) / proj[3]
        sys_[v] = proj[1] * ys[v] / proj[0]
    njobs = job0[len(job0) - 1]
    whose = np.empty(njobs, np.int64)
    q = 0
    for j in range(njobs):
        while job0[q + 1] <= j:
            q += 1
        whose[j] = q
    # once per cluster, in parallel: may it show, its pixel box and its nearest depth
    bounds = np.empty((njobs, 5))
    alive = np.zeros(njobs, np.bool_)
    for j in prange(njobs):
        q = whose[j]
        alive[j] = _bound_cluster(q, j - job0[q], c_lo, c_hi, c_centre, c_radius, c_axis, c_cos, c_sin, c_thick,
                                  c_perim, slot, cbase, backcull, cfm, eye, det, proj, planes, near, width, height,
                                  cull, bounds[j])
    order = _nearest_first(alive, bounds, near)
    # strips: T runs of whole tiles, cut at the quantiles of the clusters' box centres (a
    # count per column: the k-th centre's column is where the running count passes k)
    cut = np.zeros(T + 1, np.int64)
    cut[T] = W
    per = np.zeros(W + 1, np.int64)
    for jj in range(len(order)):
        j = order[jj]
        per[int(0.5 * (bounds[j, 0] + bounds[j, 1]))] += 1
    col, seen = 0, per[0]
    for t in range(1, T):
        k = (len(order) * t) // T
        while seen <= k and col < W:
            col += 1
            seen += per[col]
        u = col if len(order) else (W * t) // T
        cut[t] = min(max((u >> SHIFT) << SHIFT, cut[t - 1]), W)
    tmin[:, :] = 0.0
    dirty = np.zeros(tmin.shape, np.uint8)
    tally[:, :] = 0
    for t in prange(T):
        if cut[t] >= cut[t + 1]:
            continue
        col_lo, col_hi = float(cut[t]), float(cut[t + 1] - 1)
        for r in range(H):   # each thread clears its strip (``who`` is read only where ``zb`` holds a hit)
            zb[r * W + cut[t]:r * W + cut[t + 1]] = 0.0
        wx, wy, wz = np.empty(3 * CLUSTER), np.empty(3 * CLUSTER), np.empty(3 * CLUSTER)
        wu, wv, box = np.empty(3 * CLUSTER), np.empty(3 * CLUSTER), np.empty(4)
        keys_u, keys_v = np.empty(3 * CLUSTER), np.empty(3 * CLUSTER)
        live = np.empty(CLUSTER, np.int64)
        span = np.empty((3, 4))
        for jj in range(len(order)):
            j = order[jj]
            if bounds[j, 1] < col_lo or bounds[j, 0] > col_hi:
                continue
            q = whose[j]
            _draw_cluster(q, j - job0[q], col_lo, col_hi, bounds[j], X, Y, Z, faces, c_vrange, slot, vbase, fbase,
                          nfaces, cbase, backcull, cfm, proj, near, width, height, xs, ys, sys_, zb, who, tmin,
                          dirty, wx, wy, wz, wu, wv, keys_u, keys_v, live, box, span, tally[t], cull)
        if len(out_depth) > 1:   # the strip's depth and ids at once (as :func:`_shade` makes them)
            for r in range(H):
                for p in range(r * W + cut[t], r * W + cut[t + 1]):
                    d = zb[p]
                    z = 1.0 / d if d > 0.0 else 0.0
                    if d > 0.0 and z >= near_m and z <= far_m:
                        sl = who[p] >> np.int64(32)
                        out_depth[p] = np.float32(z)
                        out_instance[p] = ids[sl]
                        out_semantic[p] = sems[sl]
                    else:
                        out_depth[p] = 0.0
                        out_instance[p] = 0
                        out_semantic[p] = 0


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _vertex(vertices, vi, m, r):
    """Row r of camera_from_model ``m`` applied to vertex ``vi`` (float64)."""
    return (m[r, 0] * np.float64(vertices[vi, 0]) + m[r, 1] * np.float64(vertices[vi, 1])
            + m[r, 2] * np.float64(vertices[vi, 2]) + m[r, 3])


@njit(cache=True, nogil=True, parallel=True, boundscheck=False, error_model="numpy")
def _shade(depth, hit, vertices, faces, fvbase, cfm, ids, sems, color, slot_face0, proj, near_m, far_m, width,
           out_depth, out_instance, out_semantic, out_rgb, out_normal, out_tri, want_rgb, want_normal, want_tri):
    """The frame's targets from the drawn buffers, row by row in parallel: z in [near_m,
    far_m] (else no return), instance and semantic ids, and on request the face normal
    (camera frame, towards the eye), the colour (the instance's, Lambert with a head light,
    as the GL shader) and the (slot + 1, face within the slot's mesh) of every pixel a
    triangle won, in range or not. A face's unit normal is computed once per run of pixels
    that show it."""
    fx, s, cx, fy, cy = proj[0], proj[1], proj[2], proj[3], proj[4]
    W = int(width)
    rows = len(depth) // W
    for v in prange(rows):
        last = np.int64(-1)
        ux = uy = uz = 0.0
        for p in range(v * W, (v + 1) * W):
            h = hit[p] if depth[p] > 0.0 else np.int64(-1)
            z = 1.0 / depth[p] if h >= 0 else 0.0
            if want_tri:
                if h < 0:
                    out_tri[p, 0] = 0
                    out_tri[p, 1] = 0
                else:
                    out_tri[p, 0] = np.uint32((h >> np.int64(32)) + 1)
                    out_tri[p, 1] = np.uint32((h & np.int64(0xFFFFFFFF)) - slot_face0[h >> np.int64(32)])
            if h < 0 or z < near_m or z > far_m:
                out_depth[p] = 0.0
                out_instance[p] = 0
                out_semantic[p] = 0
                if want_rgb:
                    for k in range(4):
                        out_rgb[p, k] = 0
                if want_normal:
                    for k in range(3):
                        out_normal[p, k] = 0.0
                continue
            sl = h >> np.int64(32)
            out_depth[p] = np.float32(z)
            out_instance[p] = ids[sl]
            out_semantic[p] = sems[sl]
            if not (want_rgb or want_normal):
                continue
            if h != last:
                f = h & np.int64(0xFFFFFFFF)
                m = cfm[sl]
                va, vb, vc = fvbase[f] + faces[f, 0], fvbase[f] + faces[f, 1], fvbase[f] + faces[f, 2]
                ax, ay, az = _vertex(vertices, va, m, 0), _vertex(vertices, va, m, 1), _vertex(vertices, va, m, 2)
                bx, by, bz = _vertex(vertices, vb, m, 0) - ax, _vertex(vertices, vb, m, 1) - ay, _vertex(vertices, vb, m, 2) - az
                wx, wy, wz = _vertex(vertices, vc, m, 0) - ax, _vertex(vertices, vc, m, 1) - ay, _vertex(vertices, vc, m, 2) - az
                ux, uy, uz = by * wz - bz * wy, bz * wx - bx * wz, bx * wy - by * wx
                nl = math.sqrt(ux * ux + uy * uy + uz * uz)
                if nl > 0.0:
                    ux, uy, uz = ux / nl, uy / nl, uz / nl
                last = h
            u = p - v * W
            yn = (v - cy) / fy
            xn = (u - cx - s * yn) / fx
            dl = math.sqrt(xn * xn + yn * yn + 1.0)
            vx, vy, vz = xn / dl, yn / dl, 1.0 / dl
            nx, ny, nz = ux, uy, uz
            if nx == 0.0 and ny == 0.0 and nz == 0.0:
                nx, ny, nz = -vx, -vy, -vz
            if nx * vx + ny * vy + nz * vz > 0.0:
                nx, ny, nz = -nx, -ny, -nz
            if want_normal:
                out_normal[p, 0] = nx
                out_normal[p, 1] = ny
                out_normal[p, 2] = nz
            if want_rgb:
                lam = max(-(nx * vx + ny * vy + nz * vz), 0.0)
                for k in range(3):
                    out_rgb[p, k] = np.uint8(min(255.0, np.floor(color[sl, k] * (0.2 + 0.8 * lam) + 0.5)))
                out_rgb[p, 3] = 255


@njit(cache=True, nogil=True, boundscheck=False)
def _cluster_boxes(vertices, vrange, mesh_vbase, mesh_cbase, mesh_clusters):
    """(C, 3) lows and highs: each cluster's box in its model frame (float64)."""
    n = len(vrange)
    lo, hi = np.full((n, 3), np.inf), np.full((n, 3), -np.inf)
    for i in range(len(mesh_cbase)):
        for cl in range(mesh_cbase[i], mesh_cbase[i] + mesh_clusters[i]):
            for v in range(mesh_vbase[i] + vrange[cl, 0], mesh_vbase[i] + vrange[cl, 1]):
                for a in range(3):
                    x = np.float64(vertices[v, a])
                    lo[cl, a] = min(lo[cl, a], x)
                    hi[cl, a] = max(hi[cl, a], x)
    return lo, hi


class Rasteriser:
    """Per-scene state of the CPU rasteriser: the culler's cluster arrays (shared, not
    copied) and per-thread buffers reused from frame to frame."""

    def __init__(self, culler) -> None:
        self.culler = culler
        self._buffers: tuple | None = None
        self._face_vbase: np.ndarray | None = None
        self.tally = np.zeros((64, 8), np.int64)
        self.xyz = tuple(np.ascontiguousarray(culler.vertices[:, a]) for a in range(3))   # float32, per axis
        self.boxes = _cluster_boxes(culler.vertices, culler.clusters[2], culler.mesh_vbase, culler.mesh_cbase,
                                    -(-culler.mesh_nfaces // CLUSTER))
        self.counts = np.zeros(8, np.int64)   # the last frame's tally (see _draw_cluster)

    def face_vbase(self, mesh_vbase: np.ndarray, mesh_fbase: np.ndarray, mesh_nfaces: np.ndarray) -> np.ndarray:
        """(F,) int64: per face of the joined arrays, the first vertex row of its mesh."""
        if self._face_vbase is None:
            out = np.zeros(len(self.culler.faces), np.int64)
            for vb, fb, nf in zip(mesh_vbase, mesh_fbase, mesh_nfaces):
                out[fb:fb + nf] = vb
            self._face_vbase = out
        return self._face_vbase

    def draw(self, slots: np.ndarray, mesh: np.ndarray, backcull: np.ndarray, cfm: np.ndarray, eye: np.ndarray,
             det: np.ndarray, K: np.ndarray, width: int, height: int, near: float,
             planes: np.ndarray, cull: bool = True, ids_out: tuple | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(inverse depth, hit): per pixel (H*W) 1 / z of the nearest hit (float64, 0: nothing) at or beyond
        ``near`` and its (slot << 32 | face) where the inverse depth is not 0; arguments as
        :meth:`genie_gl.render.cull.TriangleCuller.select`; ``cull=False`` tests every face
        against every pixel centre of its box (the reference, slow). ``ids_out``: (ids,
        semantic ids, near_m, far_m, frame arrays) for a frame of depth and ids alone, which
        each thread then fills for its strip as :meth:`shade` would (no :meth:`shade` after)."""
        c = self.culler
        nf = c.mesh_nfaces[mesh]
        nclus = -(-nf // CLUSTER)
        job0 = np.zeros(len(slots) + 1, np.int64)
        np.cumsum(nclus, out=job0[1:])
        proj = np.array([K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]], dtype=np.float64)
        threads = numba.get_num_threads()
        T = 1 if threads == 1 or int(nf.sum()) < PARALLEL_FACES else threads
        npx = width * height
        tiles = (-(-height // TILE), -(-width // TILE))
        buf = self._buffers
        if buf is None or buf[0].shape != (npx,) or buf[2].shape != tiles:
            buf = self._buffers = (np.empty(npx), np.empty(npx, np.int64), np.empty(tiles))
        depth, hit, tmin = buf
        _raster(*self.xyz, c.faces, *self.boxes, *c.clusters, slots.astype(np.int64), c.mesh_vbase[mesh], c.mesh_fbase[mesh],
                nf, c.mesh_cbase[mesh], job0, np.ascontiguousarray(backcull), cfm,
                np.ascontiguousarray(eye, np.float64), np.ascontiguousarray(det, np.float64), proj, planes,
                float(near), float(width), float(height), T, depth, hit, tmin, self.tally[:T], bool(cull),
                *self._ids_out(ids_out))
        self.counts = self.tally[:T].sum(axis=0)
        return depth, hit

    @staticmethod
    def _ids_out(ids_out: tuple | None) -> tuple:
        """:func:`_raster`'s last seven arguments (one-element arrays: no strip shading)."""
        if ids_out is None:
            return (np.zeros(1, np.uint32), np.zeros(1, np.uint32), 0.0, 0.0, np.zeros(1, np.float32),
                    np.zeros(1, np.uint32), np.zeros(1, np.uint16))
        ids, sems, near_m, far_m, out = ids_out
        return (ids, sems, float(near_m), float(far_m), out["depth"].reshape(-1), out["instance"].reshape(-1),
                out["semantic"].reshape(-1))

    def shade(self, depth: np.ndarray | None, hit: np.ndarray | None, cfm: np.ndarray, ids: np.ndarray,
              semantic: np.ndarray, color: np.ndarray, slot_face0: np.ndarray, K: np.ndarray, near_m: float,
              far_m: float, out: dict[str, np.ndarray]) -> None:
        """Fill a frame's arrays ``out`` (:func:`genie_gl.render.memory.frame_buffers`) from
        :meth:`draw`'s buffers (None: nothing drawn); per slot its ids, RGB colour (uint8) and
        first face in the joined arrays (``slot_face0``)."""
        H, W = out["depth"].shape
        if depth is None:
            for a in out.values():
                a.fill(0)
            return
        c = self.culler
        want_rgb, want_normal, want_tri = "rgba" in out, "normal" in out, "primitive" in out
        none32 = np.zeros((1, 4), np.uint8)
        _shade(depth, hit, c.vertices, c.faces, self._face_vbase, cfm, ids, semantic, color, slot_face0,
               np.array([K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]], dtype=np.float64), float(near_m), float(far_m),
               W, out["depth"].reshape(-1), out["instance"].reshape(-1), out["semantic"].reshape(-1),
               out["rgba"].reshape(-1, 4) if want_rgb else none32,
               out["normal"].reshape(-1, 3) if want_normal else np.zeros((1, 3), np.float32),
               out["primitive"].reshape(-1, 2) if want_tri else np.zeros((1, 2), np.uint32),
               want_rgb, want_normal, want_tri)
