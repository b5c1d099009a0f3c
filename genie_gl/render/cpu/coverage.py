"""One cluster's triangles on the pixel centres: the CPU rasteriser's inner kernels.

:mod:`genie_gl.render.cpu.raster` runs a frame: which clusters may show, in what order, which
thread draws which columns. This module draws one cluster into one thread's columns, and
tells the frame which clusters can be skipped.

- :func:`_bound_cluster`: may cluster k of an instance show at all (its sphere against the
  frustum, its normal cone for back-face-culled instances), and the pixel box and nearest
  depth it may cover.
- :func:`_project`: its vertices in the camera frame and on screen, and per axis the cell
  between pixel centres each lies in: a triangle whose three vertices share a cell on either
  axis holds no pixel centre and costs no more than that comparison.
- :func:`_draw_cluster`: every other triangle against the pixel centres of its box, exactly
  (homogeneous edge functions in float64; see the rasteriser's module docstring), with
  occlusion tiles (:func:`_hidden`, :func:`_refresh`) skipping what lies behind what is
  already drawn, and the depth test with its tie rule (:func:`_write`).

:func:`_write` is where the CPU raster decides a pixel's winner, the one place: the nearest
float64 depth along the pixel centre's ray, ties (equal float64 z) to the lower (instance
slot, face).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ...jit import njit
from ..clusters import CLUSTER
from ..cull import _cone_drops, shares_cell, sphere_in_view

SHIFT = 3
TILE = 1 << SHIFT  # pixels: the side of an occlusion tile


class Centres(NamedTuple):
    """The pixel centres' rays of a frame: column u, row v's ray is
    ``(x[u] - shear[v], y[v], 1)`` in the camera frame (``K^-1 (u, v, 1)``).

    Attributes
    ----------
    x : (W,) float64, (u - cx) / fx.
    y : (H,) float64, (v - cy) / fy.
    shear : (H,) float64, s y[v] / fx.
    """

    x: np.ndarray
    y: np.ndarray
    shear: np.ndarray


class Scratch(NamedTuple):
    """One thread's work arrays for one cluster: its vertices in the camera frame (wx, wy, wz)
    and on screen (wu, wv), their cells (keys_u, keys_v; :func:`_project`), the faces left to
    test (live) and one clipped box."""

    wx: np.ndarray
    wy: np.ndarray
    wz: np.ndarray
    wu: np.ndarray
    wv: np.ndarray
    keys_u: np.ndarray
    keys_v: np.ndarray
    live: np.ndarray
    box: np.ndarray


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
        if z0 >= near:  # the vertex itself
            u = (fx * x0 + s * y0) / z0 + cx
            v = fy * y0 / z0 + cy
            umin, umax, vmin, vmax = min(umin, u), max(umax, u), min(vmin, v), max(vmax, v)
        if (z0 >= near) != (z1 >= near):  # where the edge crosses the near plane
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
    the pixel holds when nearer, or as near and of a lower (slot, face) ``key`` (slot << 32 |
    face). The CPU raster's winner rule, decided here and nowhere else."""
    p = iv * Wi + iu
    held = zb[p]
    if iz <= inear and (iz > held or (iz == held and key < who[p])):
        zb[p] = iz
        who[p] = key
        dirty[iv >> SHIFT, iu >> SHIFT] = 1


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _line(ex_, ey_, ez_, sg, ifx, ify, s, cx, cy, rows, extent):
    """One edge's inner side on the scanned lines: sg E = A u + B v + C in pixel coordinates;
    on line w, the scanned coordinate x must be >= P + Q w (d > 0) or <= P + Q w (d < 0);
    with d == 0 the line is inside where P w + Q >= 0. Returns (d, P, Q, the span's rounding)."""
    A = sg * ex_ * ifx
    B = sg * (ey_ - ex_ * s * ifx) * ify
    C = sg * ez_ - A * cx - B * cy
    a_, b_ = (A, B) if rows else (B, A)  # the scanned coordinate's coefficient, the line's
    if a_ != 0.0:
        ia = -1.0 / a_
        P, Q = C * ia, b_ * ia
        return (1.0 if a_ > 0.0 else -1.0), P, Q, 1e-12 * (abs(P) + abs(Q) * extent + 1.0)
    return 0.0, b_, C, 0.0


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _clip(d, P, Q, iw, lo, hi, whole):
    """[lo, hi] narrowed to one edge's inner side on line ``iw`` (see :func:`_line`), and
    ``whole`` set when the line runs along an edge parallel to it, within its rounding: then
    the span cannot tell inside from outside and every centre of the line gets the exact test."""
    if d > 0.0:
        lo = max(lo, P + Q * iw)
    elif d < 0.0:
        hi = min(hi, P + Q * iw)
    else:
        tol = 1e-9 * (abs(P * iw) + abs(Q))
        if P * iw + Q < -tol:
            hi = -1.0
        elif P * iw + Q <= tol:
            whole = True
    return lo, hi, whole


@njit(
    cache=True, nogil=True, boundscheck=False, error_model="numpy", fastmath={"nnan", "ninf", "nsz"}
)
def _project(m, X, Y, Z, v0, nv, proj, near, width, height, wx, wy, wz, wu, wv, keys_u, keys_v):
    """Camera-frame vertices ``v0 .. v0 + nv``, their window coordinates, and per axis the
    cell (k, k + 1) between pixel centres that holds each with a margin (a vertex near a
    centre, or behind the near plane, gets a key of its own): a triangle whose vertices share
    a cell on either axis holds no pixel centre. Each vertex is computed by the same
    instructions wherever it is stored, so a vertex shared by two clusters is the same (the
    loop runs in vector registers: the coordinates come as three arrays, ``X``, ``Y``, ``Z``)."""
    fx, s, cx, fy, cy = proj[0], proj[1], proj[2], proj[3], proj[4]
    last_u, last_v = width - 1.0, height - 1.0
    m00, m01, m02, m03 = m[0, 0], m[0, 1], m[0, 2], m[0, 3]  # in registers: the stores below
    m10, m11, m12, m13 = m[1, 0], m[1, 1], m[1, 2], m[1, 3]  # cannot be proven not to alias m
    m20, m21, m22, m23 = m[2, 0], m[2, 1], m[2, 2], m[2, 3]
    Xs, Ys, Zs = X[v0 : v0 + nv], Y[v0 : v0 + nv], Z[v0 : v0 + nv]
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
def _bound_cluster(q, k, geo, inst, view, cull, out):
    """Whether cluster k of visible instance q (of ``inst``, a
    :class:`~genie_gl.render.geometry.FrameInstances`; ``geo`` the scene's
    :class:`~genie_gl.render.geometry.SceneGeometry`, ``view`` the frame's
    :class:`~genie_gl.render.geometry.View`) may show: False when its sphere is outside the
    frustum, when every face is back-facing (back-face-culled instances: the culler's cone
    bound, which holds for the GPU's float32 rounding and so for float64), or when its box is
    off screen. Writes (ulo, uhi, vlo, vhi, z) into ``out``: the pixel box it may cover and
    its nearest depth (its box's eight corners bound both more tightly than its sphere; the
    whole image and the near plane when it reaches the near plane). Without ``cull``, always
    True with the whole image."""
    c_lo, c_hi, c_centre, c_radius = geo.lo, geo.hi, geo.centre, geo.radius
    c_axis, c_cos, c_sin, c_thick, c_perim = (
        geo.axis,
        geo.cos_a,
        geo.sin_a,
        geo.thickness,
        geo.perimeter,
    )
    slot, cbase, backcull, cfm, eye, det = (
        inst.slot,
        inst.cbase,
        inst.backcull,
        inst.camera_from_model,
        inst.eye,
        inst.det,
    )
    proj, planes, near, width, height = view.proj, view.planes, view.near, view.width, view.height
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
    if backcull[q] and _cone_drops(
        m,
        det[q],
        eye[q],
        c_centre[cl],
        c_radius[cl],
        c_axis[cl],
        c_cos[cl],
        c_sin[cl],
        c_thick[cl],
        c_perim[cl],
        ez,
        ex,
        ey,
        rad,
        sc,
        rmag,
        tmag,
        proj,
        near,
        2.0**-8,
        width,
        height,
    ):
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
    if zb_lo <= near:  # the sphere reaches no nearer than the near plane; its box does
        return True
    out[0] = max(np.floor(bu_lo) - 1.0, 0.0)
    out[1] = min(np.ceil(bu_hi) + 1.0, last_u)
    out[2] = max(np.floor(bv_lo) - 1.0, 0.0)
    out[3] = min(np.ceil(bv_hi) + 1.0, last_v)
    out[4] = max(zlo, zb_lo * (1.0 - 1e-12))
    return out[0] <= out[1] and out[2] <= out[3]


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _draw_cluster(q, k, col_lo, col_hi, bound, geo, inst, view, centres, buf, work, tally, cull):
    """Draw cluster k of visible instance q into the columns col_lo..col_hi of ``buf`` (a
    :class:`~genie_gl.render.geometry.DepthBuffers`), unless every tile of its box there
    (``bound``: :func:`_bound_cluster`'s) lies nearer than it; ``centres`` the pixel centres'
    rays (:class:`Centres`), ``work`` the thread's :class:`Scratch`; counts into ``tally``
    (clusters drawn, faces with a pixel box, faces hidden, faces drawn, pixels tested,
    occlusion tiles refreshed). Without ``cull``, every face is tested against every pixel
    centre of its box (no cluster, cone, cell, occlusion or span test): the reference the
    culled frame must equal byte for byte."""
    X, Y, Z, faces, c_vrange = geo.X, geo.Y, geo.Z, geo.faces, geo.vrange
    slot, vbase, fbase, nfaces, cbase, backcull, cfm = (
        inst.slot,
        inst.vbase,
        inst.fbase,
        inst.nfaces,
        inst.cbase,
        inst.backcull,
        inst.camera_from_model,
    )
    proj, near, width, height = view.proj, view.near, view.width, view.height
    xs, ys, sys_ = centres.x, centres.y, centres.shear
    zb, who, tmax, dirty = buf.inverse_z, buf.winner, buf.tiles, buf.dirty
    wx, wy, wz, wu, wv = work.wx, work.wy, work.wz, work.wu, work.wv
    keys_u, keys_v, live, box = work.keys_u, work.keys_v, work.live, work.box
    fx, s, cx, fy, cy = proj[0], proj[1], proj[2], proj[3], proj[4]
    f0 = fbase[q] + k * CLUSTER
    nf = min(CLUSTER, nfaces[q] - k * CLUSTER)
    cl = cbase[q] + k
    vb = vbase[q]
    sl = slot[q]
    m = cfm[sl]
    bc = backcull[q]
    Wi, Hi = int(width), int(height)
    last_v = height - 1.0
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
    _project(
        m, X, Y, Z, vb + v_lo, nv, proj, near, width, height, wx, wy, wz, wu, wv, keys_u, keys_v
    )
    key0 = np.int64(sl) << np.int64(32)
    inear = 1.0 / near
    ifx, ify = 1.0 / fx, 1.0 / fy
    du_lo, du_hi, dv_lo, dv_hi = Wi, -1, Hi, -1  # the box of the pixels this cluster tested
    # the faces whose vertices do not share a cell, listed without a branch per face (most
    # faces of a large scene are smaller than a pixel and go here)
    nl = 0
    for i in range(nf):
        f = f0 + i
        a, b, c = faces[f, 0] - v_lo, faces[f, 1] - v_lo, faces[f, 2] - v_lo
        live[nl] = i
        nl += 1 - (cull & shares_cell(keys_u, keys_v, a, b, c))
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
        vol = ax_ * e1x + ay_ * e1y + az * e1z  # A·(B x C): twice the signed volume
        if vol == 0.0:
            continue  # its plane holds the eye: edge-on
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
        nx, ny, nz = e0x + e1x + e2x, e0y + e1y + e2y, e0z + e1z + e2z  # (B - A) x (C - A)
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
            if (
                (sg * (e0x * xn + (e0y * yn + e0z)) >= 0.0)
                & (sg * (e1x * xn + (e1y * yn + e1z)) >= 0.0)
                & (sg * (e2x * xn + (e2y * yn + e2z)) >= 0.0)
            ):
                _write(zb, who, dirty, iu, iv, Wi, (nx * xn + (ny * yn + nz)) * ivol, key, inear)
                du_lo, du_hi, dv_lo, dv_hi = (
                    min(du_lo, iu),
                    max(du_hi, iu),
                    min(dv_lo, iv),
                    max(dv_hi, iv),
                )
            continue
        # per edge, sg E = A u + B v + C in pixel coordinates. The box is scanned along its
        # longer side, line by line (rows: v fixed; columns: u fixed): on a line w the edge's
        # inner side is x >= P + Q w or x <= P + Q w (x the scanned coordinate), or all or
        # nothing. The span's rounding is far below ``gap``: centres more than ``gap`` inside
        # it are inside; those nearer its ends get the exact test, the same expression
        # whichever way a triangle is scanned (so that shared edges stay watertight).
        rows = (vhi - vlo) <= (uhi - ulo)
        d0, p0, q0, g0 = _line(e0x, e0y, e0z, sg, ifx, ify, s, cx, cy, rows, Wi + Hi)
        d1, p1, q1, g1 = _line(e1x, e1y, e1z, sg, ifx, ify, s, cx, cy, rows, Wi + Hi)
        d2, p2, q2, g2 = _line(e2x, e2y, e2z, sg, ifx, ify, s, cx, cy, rows, Wi + Hi)
        w_lo, w_hi = (vlo, vhi) if rows else (ulo, uhi)
        x_lo, x_hi = (ulo, uhi) if rows else (vlo, vhi)
        for iw in range(int(w_lo), int(w_hi) + 1):
            lo, hi, gap, whole = x_lo, x_hi, 0.0, False
            if cull:
                lo, hi, whole = _clip(d0, p0, q0, iw, lo, hi, whole)
                lo, hi, whole = _clip(d1, p1, q1, iw, lo, hi, whole)
                lo, hi, whole = _clip(d2, p2, q2, iw, lo, hi, whole)
                gap = max(max(g0, g1), g2)
            if not (lo <= hi + 2.0):
                continue
            i_lo = int(max(np.ceil(lo - gap), x_lo))
            i_hi = int(min(np.floor(hi + gap), x_hi))
            if i_lo > i_hi:
                continue
            in_lo, in_hi = (lo + gap, hi - gap) if cull and not whole else (math.inf, -math.inf)
            tally[4] += i_hi - i_lo + 1
            # the box of what this cluster may have written (the dirty tiles in it are refreshed)
            if rows:
                du_lo, du_hi, dv_lo, dv_hi = (
                    min(du_lo, i_lo),
                    max(du_hi, i_hi),
                    min(dv_lo, iw),
                    max(dv_hi, iw),
                )
            else:
                du_lo, du_hi, dv_lo, dv_hi = (
                    min(du_lo, iw),
                    max(du_hi, iw),
                    min(dv_lo, i_lo),
                    max(dv_hi, i_hi),
                )
            # (a loop per direction, what is fixed along the line read once: the same values,
            # fewer instructions per centre)
            if rows:
                iv = iw
                yn, shear = ys[iv], sys_[iv]
                for ix in range(i_lo, i_hi + 1):
                    xn = xs[ix] - shear
                    if not (in_lo < ix < in_hi):
                        inside = (
                            (sg * (e0x * xn + (e0y * yn + e0z)) >= 0.0)
                            & (sg * (e1x * xn + (e1y * yn + e1z)) >= 0.0)
                            & (sg * (e2x * xn + (e2y * yn + e2z)) >= 0.0)
                        )
                        if not inside:
                            continue
                    _write(
                        zb, who, dirty, ix, iv, Wi, (nx * xn + (ny * yn + nz)) * ivol, key, inear
                    )
            else:
                iu = iw
                xu = xs[iu]
                for ix in range(i_lo, i_hi + 1):
                    yn = ys[ix]
                    xn = xu - sys_[ix]
                    if not (in_lo < ix < in_hi):
                        inside = (
                            (sg * (e0x * xn + (e0y * yn + e0z)) >= 0.0)
                            & (sg * (e1x * xn + (e1y * yn + e1z)) >= 0.0)
                            & (sg * (e2x * xn + (e2y * yn + e2z)) >= 0.0)
                        )
                        if not inside:
                            continue
                    _write(
                        zb, who, dirty, iu, ix, Wi, (nx * xn + (ny * yn + nz)) * ivol, key, inear
                    )
    if du_hi >= 0:
        tally[5] += _refresh(tmax, dirty, zb, du_lo, du_hi, dv_lo, dv_hi, Wi, Hi)
