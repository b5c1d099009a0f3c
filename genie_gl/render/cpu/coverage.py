"""One cluster's triangles on the pixel centres: the CPU rasteriser's inner kernels.

:mod:`genie_gl.render.cpu.raster` runs a frame: which clusters may show, in what order, which
thread draws which columns. This module draws one cluster into one thread's columns, and
tells the frame which clusters can be skipped.

- (:mod:`genie_gl.render.cpu.bounds`: may the cluster show at all, the pixel box it may
  cover, its vertices on screen.)
- :func:`_draw_cluster`: every other triangle against the pixel centres of its box, exactly
  (homogeneous edge functions in float64; see the rasteriser's module docstring), with
  occlusion tiles (:func:`_hidden`, :func:`_refresh`) skipping what lies behind what is
  already drawn, and the depth test with its tie rule (:func:`_wins`, applied by :func:`_write`,
  by the long spans' loop and by :func:`_rays`, a face against binned rays).
- :func:`draw_strip`: a thread's clusters, nearest first, each drawn by :func:`_draw_cluster`
  compiled into its loop.

:func:`_wins` is where the CPU raster decides a pixel's winner, the one place (:func:`_write`,
the long spans' loop and :func:`_rays` call it): the nearest float64 depth along the ray,
ties (equal float64 z) to the lower (instance slot, face).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ...jit import njit
from ..clusters import CLUSTER
from .bounds import _clip_box, _project, shares_cell

SHIFT = 3
TILE = 1 << SHIFT  # pixels: the side of an occlusion tile
# centres: a span inside a triangle at least this long is written by a loop without a branch
LONG_SPAN = 16
SMALL_BOX = 6  # cells: a box of rays no larger is tested ray by ray, without spans


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
    and on screen (wu, wv), their cells (keys: u's and v's in one word, :func:`_project`), the
    faces left to test (live) and one clipped box."""

    wx: np.ndarray
    wy: np.ndarray
    wz: np.ndarray
    wu: np.ndarray
    wv: np.ndarray
    keys: np.ndarray
    live: np.ndarray
    box: np.ndarray


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _hidden(tmin, ulo, uhi, vlo, vhi, iz, vs):
    """True when every tile the pixel box touches holds only inverse depths above ``iz``
    (nearer than 1 / iz; a tile's value is its pixels' least); tiles are 1 << ``vs`` rows
    tall."""
    for tr in range(int(vlo) >> vs, (int(vhi) >> vs) + 1):
        for tc in range(int(ulo) >> SHIFT, (int(uhi) >> SHIFT) + 1):
            if tmin[tr, tc] <= iz:
                return False
    return True


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", fastmath=True)
def _least(zb, a, b, lo):
    """The least of ``lo`` and inverse depths ``zb[a:b]`` (in a loop the compiler vectorises:
    the least of numbers that are never NaN is the same in any order)."""
    zs = zb[a:b]
    for i in range(len(zs)):
        lo = min(lo, zs[i])
    return lo


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _refresh(tmin, dirty, zb, ulo, uhi, vlo, vhi, Wi, Hi, cell0, vs):
    """Recompute the tiles written since their last refresh (``dirty``) in the pixel box: the
    least inverse depth each holds (0 while one of its pixels, or of the rays binned by
    ``cell0`` (:class:`~genie_gl.render.cpu.bins.Samples`), is empty; a tile without rays
    holds inf); tiles are 1 << ``vs`` rows tall; returns how many."""
    sampled = len(cell0) > 1
    n = 0
    for tr in range(vlo >> vs, (vhi >> vs) + 1):
        for tc in range(ulo >> SHIFT, (uhi >> SHIFT) + 1):
            if not dirty[tr, tc]:
                continue
            dirty[tr, tc] = 0
            n += 1
            lo = math.inf
            for iv in range(tr << vs, min((tr + 1) << vs, Hi)):
                row = iv * Wi
                if sampled:
                    lo = _least(
                        zb, cell0[row + tc * TILE], cell0[row + min((tc + 1) * TILE, Wi)], lo
                    )
                    continue
                lo = _least(zb, row + tc * TILE, row + min((tc + 1) * TILE, Wi), lo)
            tmin[tr, tc] = lo
    return n


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _wins(iz, held, key, had, inear):
    """The CPU raster's winner rule, decided here and nowhere else: a hit of inverse depth
    ``iz`` = (n·d) / A·(B x C) (larger is nearer; no hit nearer than the near plane,
    1 / ``inear``) and (slot, face) ``key`` (slot << 32 | face) wins over what its ray holds
    (``held``, ``had``) when nearer, or as near and of a lower key. Without a branch, so that
    a loop of it vectorises (:func:`_draw_cluster`'s long spans) or runs without a missed
    guess (:func:`_rays`)."""
    return (iz <= inear) & ((iz > held) | ((iz == held) & (key < had)))


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _write(zb, who, p, iz, key, inear):
    """The depth test (:func:`_wins`) of a hit of pixel centre ``p`` of inverse depth ``iz``
    and key ``key``; writes it and returns True when it won. (Its key is read only where the
    hit may win: not farther, not nearer than the near plane.)"""
    held = zb[p]
    if iz >= held and iz <= inear and _wins(iz, held, key, who[p], inear):
        zb[p] = iz
        who[p] = key
        return True
    return False


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _rays(zb, who, sx, sy, r0, r3, face, key, inear):
    """Binned rays r0..r3 - 1 (:class:`~genie_gl.render.cpu.bins.Samples`: x ``sx``, y ``sy``)
    against one face, ``face`` = (sg, its three edge functions' coefficients, n, 1 / vol; see
    :func:`_draw_cluster`): each ray the exact edge test and the depth test (:func:`_wins`),
    in one loop without a branch, the rays read by unsigned index (a row of bins holds a few
    rays: slicing the four arrays cost more than the loop's vector code saved, 0.94-0.97x the
    frame through the tutorial lens, docs/lens-ids.md); returns how many it wrote."""
    sg, e0x, e0y, e0z, e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz, ivol = face
    wrote = 0
    for ii in range(r0, r3):
        i = np.uint64(ii)
        xn, yn = sx[i], sy[i]
        inside = (
            (sg * (e0x * xn + (e0y * yn + e0z)) >= 0.0)
            & (sg * (e1x * xn + (e1y * yn + e1z)) >= 0.0)
            & (sg * (e2x * xn + (e2y * yn + e2z)) >= 0.0)
        )
        iz = (nx * xn + (ny * yn + nz)) * ivol
        held, had = zb[i], who[i]
        won = inside & _wins(iz, held, key, had, inear)
        zb[i] = iz if won else held
        who[i] = key if won else had
        wrote += won
    return wrote


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


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _weakest(d, P, Q, iv, lo, hi):
    """[lo, hi] narrowed to one edge's inner side (see :func:`_line`, scanning rows) at its
    weakest between the lines v = iv and v = iv + 1: every point of the row of cells inside the
    edge lies in it."""
    if d > 0.0:
        lo = max(lo, P + min(Q * iv, Q * (iv + 1)))
    elif d < 0.0:
        hi = min(hi, P + max(Q * iv, Q * (iv + 1)))
    return lo, hi


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _draw_cluster(
    q, k, col_lo, col_hi, bound, geo, inst, view, centres, samples, buf, work, tally, cull
):
    """Draw cluster k of visible instance q into the columns col_lo..col_hi of ``buf`` (a
    :class:`~genie_gl.render.geometry.DepthBuffers`), unless every tile of its box there
    (``bound``: :func:`_bound_cluster`'s) lies nearer than it; ``centres`` the pixel centres'
    rays (:class:`Centres`) or, unless it is
    :data:`~genie_gl.render.cpu.bins.PIXEL_CENTRES`, ``samples`` the frame's rays
    (:class:`~genie_gl.render.cpu.bins.Samples`: each face is tested against the rays of the
    cells of its box),
    ``work`` the thread's :class:`Scratch`; counts into ``tally``
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
    cell0, sx, sy = samples.cell0, samples.xy[0], samples.xy[1]
    sampled = len(cell0) > 1
    vs = samples.vshift if sampled else SHIFT  # an occlusion tile's height, log2 rows
    # a face whose vertices share a cell between pixel centres holds none (not so for rays
    # scattered in their cells)
    by_cell = cull and not sampled
    zb, who, tmax, dirty = buf.inverse_z, buf.winner, buf.tiles, buf.dirty
    wx, wy, wz, wu, wv = work.wx, work.wy, work.wz, work.wu, work.wv
    keys, live, box = work.keys, work.live, work.box
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
    if cull and zlo > near and _hidden(tmax, ulo_c, uhi_c, bound[2], bound[3], 1.0 / zlo, vs):
        return
    tally[0] += 1
    v_lo = c_vrange[cl, 0]
    nv = c_vrange[cl, 1] - v_lo
    # camera-frame vertices, window coordinates, and per axis the cell (k, k + 1) between
    # pixel centres that holds the vertex with a margin (a vertex near a centre, or behind the
    # near plane, gets a key of its own): a triangle whose vertices share a cell on either
    # axis holds no pixel centre
    _project(m, X, Y, Z, vb + v_lo, nv, proj, near, width, height, wx, wy, wz, wu, wv, keys)
    key0 = np.int64(sl) << np.int64(32)
    inear = 1.0 / near
    ifx, ify = 1.0 / fx, 1.0 / fy
    du_lo, du_hi, dv_lo, dv_hi = Wi, -1, Hi, -1  # the box of the pixels this cluster tested
    # the faces whose vertices do not share a cell, listed without a branch per face (most
    # faces of a large scene are smaller than a pixel and go here)
    # (indices unsigned: no test for a negative index on each read)
    nl = 0
    u_lo = np.uint64(v_lo)
    for i in range(nf):
        f = np.uint64(f0 + i)
        a, b, c = np.uint64(faces[f, 0]), np.uint64(faces[f, 1]), np.uint64(faces[f, 2])
        live[nl] = i
        nl += 1 - (by_cell & shares_cell(keys, a - u_lo, b - u_lo, c - u_lo))
    for ii in range(nl):
        f = f0 + live[ii]
        uf = np.uint64(f)
        a, b = np.uint64(faces[uf, 0]) - u_lo, np.uint64(faces[uf, 1]) - u_lo
        c = np.uint64(faces[uf, 2]) - u_lo
        az, bz, cz = wz[a], wz[b], wz[c]
        front = (az >= near) + (bz >= near) + (cz >= near)
        if front == 0:
            continue
        if front == 3:
            ua, ub, uc = wu[a], wu[b], wu[c]
            va, vb_, vc = wv[a], wv[b], wv[c]
            if bc:
                # its orientation on screen, the sign of A·(B x C) (the vertices in front:
                # the projection keeps it), before anything else is computed: a face clearly
                # turned away (by far more than the rounding) is dropped here, the others
                # get the exact test below
                turn = (ub - ua) * (vc - va) - (vb_ - va) * (uc - ua)
                size = (abs(ua) + abs(ub) + abs(uc) + 1.0) * (abs(va) + abs(vb_) + abs(vc) + 1.0)
                if turn > 1e-9 * size:
                    continue
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
        # (of the cells, for rays binned in them: a cell u holds the rays at [u, u + 1))
        ulo = max(np.floor(umin - mu) if sampled else np.ceil(umin - mu), col_lo)
        uhi = min(np.floor(umax + mu), col_hi)
        if ulo > uhi:
            continue
        vlo = max(np.floor(vmin - mv) if sampled else np.ceil(vmin - mv), 0.0)
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
        if cull and _hidden(tmax, ulo, uhi, vlo, vhi, 1.0 / zmin, vs):
            tally[2] += 1
            continue
        tally[3] += 1
        e0x, e0y, e0z = ay_ * bz - az * by_, az * bx_ - ax_ * bz, ax_ * by_ - ay_ * bx_
        e2x, e2y, e2z = cy_ * az - cz * ay_, cz * ax_ - cx_ * az, cx_ * ay_ - cy_ * ax_
        nx, ny, nz = e0x + e1x + e2x, e0y + e1y + e2y, e0z + e1z + e2z  # (B - A) x (C - A)
        sg = 1.0 if vol > 0.0 else -1.0
        ivol = 1.0 / vol
        key = key0 | np.int64(f)
        if sampled:  # (the face as :func:`_rays` takes it)
            face = (sg, e0x, e0y, e0z, e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz, ivol)
        if sampled and (uhi - ulo + 1.0) * (vhi - vlo + 1.0) <= SMALL_BOX:
            # a box of a few cells (most faces of a large scene that get this far): each of
            # their rays gets the exact test, no spans
            for iv in range(int(vlo), int(vhi) + 1):
                row = iv * Wi
                r0, r3 = cell0[row + int(ulo)], cell0[row + int(uhi) + 1]
                tally[4] += r3 - r0
                wrote = _rays(zb, who, sx, sy, r0, r3, face, key, inear)
                if wrote:
                    for tc in range(int(ulo) >> SHIFT, (int(uhi) >> SHIFT) + 1):
                        dirty[iv >> vs, tc] = 1
            du_lo, du_hi = min(du_lo, int(ulo)), max(du_hi, int(uhi))
            dv_lo, dv_hi = min(dv_lo, int(vlo)), max(dv_hi, int(vhi))
            continue
        if sampled:
            # the rays of the cells of its box, row of cells by row: per edge, its inner side
            # at its weakest over the row (see :func:`_line`); only the cells between those
            # bounds may hold rays inside, and each of their rays gets the exact test
            # (:func:`_rays`: a loop without a branch costs less than telling the rays
            # surely inside from those to test)
            d0, p0, q0, g0 = _line(e0x, e0y, e0z, sg, ifx, ify, s, cx, cy, True, Wi + Hi)
            d1, p1, q1, g1 = _line(e1x, e1y, e1z, sg, ifx, ify, s, cx, cy, True, Wi + Hi)
            d2, p2, q2, g2 = _line(e2x, e2y, e2z, sg, ifx, ify, s, cx, cy, True, Wi + Hi)
            gap = max(max(g0, g1), g2) + 1e-9
            iu_lo, iu_hi = int(ulo), int(uhi)
            for iv in range(int(vlo), int(vhi) + 1):
                if cull:
                    c_lo, c_hi = _weakest(d0, p0, q0, iv, ulo, uhi + 1.0)
                    c_lo, c_hi = _weakest(d1, p1, q1, iv, c_lo, c_hi)
                    c_lo, c_hi = _weakest(d2, p2, q2, iv, c_lo, c_hi)
                    j_lo = max(int(np.floor(c_lo - gap)), iu_lo)
                    j_hi = min(int(np.floor(c_hi + gap)), iu_hi)
                else:
                    j_lo, j_hi = iu_lo, iu_hi
                if j_lo > j_hi:
                    continue
                # the row's rays of cells j_lo..j_hi are rows r0..r3 - 1 of the samples
                row = iv * Wi
                r0, r3 = cell0[row + j_lo], cell0[row + j_hi + 1]
                tally[4] += r3 - r0
                wrote = _rays(zb, who, sx, sy, r0, r3, face, key, inear)
                if wrote:
                    for tc in range(j_lo >> SHIFT, (j_hi >> SHIFT) + 1):
                        dirty[iv >> vs, tc] = 1
            du_lo, du_hi = min(du_lo, iu_lo), max(du_hi, iu_hi)
            dv_lo, dv_hi = min(dv_lo, int(vlo)), max(dv_hi, int(vhi))
            continue
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
                if _write(zb, who, iv * Wi + iu, (nx * xn + (ny * yn + nz)) * ivol, key, inear):
                    dirty[iv >> SHIFT, iu >> SHIFT] = 1
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
                row = iv * Wi
                # the centres more than ``gap`` inside every edge, s_lo..s_hi, in one loop
                # without a branch (the depth test as a select of :func:`_wins`, the rule
                # :func:`_write` applies); those nearer the ends get the exact test first
                s_lo, s_hi = i_hi + 1, i_hi
                if in_lo < in_hi:
                    s_lo = int(max(np.floor(in_lo) + 1.0, i_lo))
                    s_hi = int(min(np.ceil(in_hi) - 1.0, i_hi))
                    if s_lo > s_hi:
                        s_lo, s_hi = i_hi + 1, i_hi
                for end in range(2):
                    e_lo, e_hi = (i_lo, s_lo - 1) if end == 0 else (s_hi + 1, i_hi)
                    for ix in range(e_lo, e_hi + 1):
                        xn = xs[ix] - shear
                        inside = (
                            (sg * (e0x * xn + (e0y * yn + e0z)) >= 0.0)
                            & (sg * (e1x * xn + (e1y * yn + e1z)) >= 0.0)
                            & (sg * (e2x * xn + (e2y * yn + e2z)) >= 0.0)
                        )
                        if not inside:
                            continue
                        iz = (nx * xn + (ny * yn + nz)) * ivol
                        if _write(zb, who, row + ix, iz, key, inear):
                            dirty[iv >> SHIFT, ix >> SHIFT] = 1
                if s_hi - s_lo < LONG_SPAN:
                    for ix in range(s_lo, s_hi + 1):
                        iz = (nx * (xs[ix] - shear) + (ny * yn + nz)) * ivol
                        if _write(zb, who, row + ix, iz, key, inear):
                            dirty[iv >> SHIFT, ix >> SHIFT] = 1
                    continue
                # (slices indexed from 0: a loop the compiler vectorises)
                zs, ws = zb[row + s_lo : row + s_hi + 1], who[row + s_lo : row + s_hi + 1]
                xl = xs[s_lo : s_hi + 1]
                wrote = 0
                for i in range(len(zs)):
                    iz = (nx * (xl[i] - shear) + (ny * yn + nz)) * ivol
                    held, had = zs[i], ws[i]
                    won = _wins(iz, held, key, had, inear)
                    zs[i] = iz if won else held
                    ws[i] = key if won else had
                    wrote += won
                if wrote:
                    for tc in range(s_lo >> SHIFT, (s_hi >> SHIFT) + 1):
                        dirty[iv >> SHIFT, tc] = 1
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
                    if _write(zb, who, ix * Wi + iu, (nx * xn + (ny * yn + nz)) * ivol, key, inear):
                        dirty[ix >> SHIFT, iu >> SHIFT] = 1
    if du_hi >= 0:
        tally[5] += _refresh(tmax, dirty, zb, du_lo, du_hi, dv_lo, dv_hi, Wi, Hi, cell0, vs)


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def draw_strip(
    order, bounds, whose, job0, col_lo, col_hi, geo, inst, view, centres, samples, buf, work,
    tally, cull,
):  # fmt: skip
    """Draw the clusters ``order`` (nearest first; ``bounds`` theirs, :func:`_bound_cluster`'s)
    that reach the columns col_lo..col_hi, each by :func:`_draw_cluster` (compiled into this
    loop: a call per cluster would pass every array of the scene, the frame and the scratch)."""
    for jj in range(len(order)):
        j = order[jj]
        if bounds[j, 1] < col_lo or bounds[j, 0] > col_hi:
            continue
        q = whose[j]
        _draw_cluster(
            q, j - job0[q], col_lo, col_hi, bounds[j], geo, inst, view, centres, samples, buf,
            work, tally, cull,
        )  # fmt: skip
