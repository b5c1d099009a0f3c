"""Exact culling of what cannot change a pixel (numba, parallel, cached on disk).

Per frame, hierarchically: instances outside the frustum are dropped by the renderer before
anything here runs (they cost nothing more); for the others, :meth:`TriangleCuller.select`
tests each cluster (:mod:`genie_gl.render.clusters`), then each triangle of the clusters that
pass, and writes the indices of the triangles that may change a pixel, instance after
instance, into one index array the renderer draws with one multi-draw call.

A cluster is dropped when its bounding sphere lies outside the frustum, or, for instances
drawn with back-face culling, when every one of its faces is back-facing by more than the
error bound below could change (a bound on the screen area of its faces from the cluster's
normal cone, its thinnest face and its distance to the eye). A triangle is dropped only when
the GPU cannot draw it into a pixel:

* all three vertices are in front of the near plane and no pixel centre lies within the error
  bound of the triangle (its screen box, widened by the bound, holds no pixel centre; or it
  holds some, each lies farther than the bound outside one of its edges, checked line by line
  along the box's shorter side: a triangle whose vertices each move by at most e stays within
  distance e of the original), or
* it is drawn with back-face culling and faces away by more than moving each vertex by its
  error bound could change (the GPU would cull it too).

The error bound covers what separates this float64 test from the GPU's float32 vertex
transform and its sub-pixel snapping: ``snap_px`` (twice the rasteriser's snapping step,
2^-GL_SUBPIXEL_BITS pixel: 1/256 on llvmpipe; 1/16, GL's least, when not given) plus a
relative term scaled by the size of the numbers involved. A triangle the GPU would rasterise is
therefore never dropped, and the culled render is the
unculled render bit for bit (tests compare both on generated and benchmark scenes, and on
triangles whose edges pass within 1/500 pixel of pixel centres, which a bound of 1/4096 pixel
fails on llvmpipe: the bound is a wide margin over what the GPU's rounding moves).

Memory grows with what is drawn, not with the scene's instances: per cluster in view a count
and a mask of :data:`~genie_gl.render.clusters.CLUSTER` bits, per thread the window
coordinates of one cluster's vertices, and the kept indices.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..jit import njit, prange
from .clusters import CLUSTER
from .occlusion import ROUND, UNBOUNDED, DepthBound, cluster_depth, hidden, triangle_depths, write

# numba's own work queue first: its threads sleep between kernels (OpenMP's spin, taking
# cores from llvmpipe's rasteriser threads), and the TBB found here is refused with a warning
numba.config.THREADING_LAYER_PRIORITY = ["workqueue", "omp", "tbb"]

REL_EPS = 1e-6  # relative error bound of the float32 eye coordinates (~16 ulp)
PARALLEL_FACES = 200_000  # below this many faces in view, one thread culls a frame
# occlusion culling costs 0.2-0.3 us of CPU per triangle it tests (one thread) and saves
# 0.2-0.45 us of llvmpipe's per triangle it drops (docs/real-size-scenes.md): it pays when it
# drops at least this share of what it tests; when it did not, it is tried again after this
# many frames without
BREAK_EVEN = 0.8
PROBE_FRAMES = 16
SCAN_LINES = 64  # a triangle whose box spans more lines both ways is kept without a scan
_MASK_WORDS = CLUSTER // 64


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", fastmath=True)
def _cone_drops(
    m,
    det,
    eye,
    cc,
    cr,
    ax,
    cos_a,
    sin_a,
    thick,
    perim,
    ez,
    ex,
    ey,
    rad,
    sc,
    rmag,
    tmag,
    proj,
    near,
    snap,
    width,
    height,
):
    """True when every face of the cluster is back-facing beyond the error bound: its screen
    area (twice) fx fy det 2A d / (z0 z1 z2) exceeds what moving each vertex by the largest
    error bound e can change (2 e · perimeter + 4 e²), for every face (see the module doc)."""
    if cos_a <= 0.0 or det <= 0.0:
        return False
    zmin, zmax = ez - rad, ez + rad
    if zmin <= near:
        return False
    dx, dy, dz = cc[0] - eye[0], cc[1] - eye[1], cc[2] - eye[2]
    dist = math.sqrt(dx * dx + dy * dy + dz * dz)
    if dist <= cr:
        return False
    cos_b = (ax[0] * dx + ax[1] * dy + ax[2] * dz) / dist
    sin_b = math.sqrt(max(0.0, 1.0 - cos_b * cos_b))
    cos_ab = cos_a * cos_b - sin_a * sin_b  # cos(alpha + beta): the least-facing face's
    dmin = dist * cos_ab - cr  # the eye's least distance behind a face plane
    if cos_b <= 0.0 or cos_ab <= 0.0 or dmin <= 0.0:
        return False
    fx, s, fy = proj[0], proj[1], proj[3]
    rx, ry = (abs(ex) + rad) / zmin, (abs(ey) + rad) / zmin
    frob = 0.0
    for r in range(3):
        for c in range(3):
            frob += m[r, c] * m[r, c]
    jac = (
        math.sqrt(
            frob * (fx * fx + s * s + fy * fy + (fx * rx + abs(s) * ry) ** 2 + (fy * ry) ** 2)
        )
        / zmin
    )
    pmag = math.sqrt(3.0) * (math.sqrt(cc[0] ** 2 + cc[1] ** 2 + cc[2] ** 2) + cr)
    err = REL_EPS * (tmag + 3 * rmag * pmag)
    e = (
        snap
        + (fx + abs(s) + fy) * err * (1 + rx + ry) / zmin
        + ROUND * (fx * rx + abs(s) * ry + abs(proj[2]) + fy * ry + abs(proj[4]) + width + height)
    )
    area = fx * fy * det * thick * dmin / (zmax * zmax * zmax)
    return area > 2.0 * math.sqrt(2.0) * e * jac + (4 * e * e + 1e-9) / perim


@njit(
    cache=True, nogil=True, boundscheck=False, error_model="numpy", fastmath=True, inline="always"
)
def _span(pu, pv, qu, qv, length, sg, at, lo, hi, rows):
    """Narrow [lo, hi] to where, on the line ``at`` (a row v = at when ``rows``, else a column
    u = at), points lie within e of the inner side of edge p->q (sg: the triangle's winding;
    ``length``: the edge's length times e)."""
    if rows:  # sg E(u, at) = c - d u >= -length
        d = sg * (qv - pv)
        c = sg * ((qu - pu) * (at - pv) + (qv - pv) * pu)
    else:  # sg E(at, v) = c - d v >= -length
        d = -sg * (qu - pu)
        c = sg * (-(qu - pu) * pv - (qv - pv) * (at - pu))
    if d > 0:
        hi = min(hi, (c + length) / d)
    elif d < 0:
        lo = max(lo, (c + length) / d)
    elif c + length < 0:
        lo, hi = 1.0, 0.0
    return lo, hi


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", fastmath=True)
def _centre_near(ua, va, ub, vb, uc, vc, e, sg, ulo, uhi, vlo, vhi):
    """True when a pixel centre of the box [ulo, uhi] x [vlo, vhi] (whole numbers) lies within
    ``e`` of each edge line on the triangle's inner side (a superset of the points within e of
    the triangle); scans the box's shorter side, line by line. A box of more than
    :data:`SCAN_LINES` lines both ways is kept without a scan."""
    rows = (vhi - vlo) <= (uhi - ulo)
    if min(vhi - vlo, uhi - ulo) + 1 > SCAN_LINES:
        return True
    first, last = (vlo, vhi) if rows else (ulo, uhi)
    lo0, hi0 = (ulo, uhi) if rows else (vlo, vhi)
    lab = math.sqrt((ub - ua) ** 2 + (vb - va) ** 2) * e
    lbc = math.sqrt((uc - ub) ** 2 + (vc - vb) ** 2) * e
    lca = math.sqrt((ua - uc) ** 2 + (va - vc) ** 2) * e
    at = first
    while at <= last:
        lo, hi = lo0, hi0
        lo, hi = _span(ua, va, ub, vb, lab, sg, at, lo, hi, rows)
        lo, hi = _span(ub, vb, uc, vc, lbc, sg, at, lo, hi, rows)
        lo, hi = _span(uc, vc, ua, va, lca, sg, at, lo, hi, rows)
        if math.ceil(lo) <= math.floor(hi):
            return True
        at += 1.0
    return False


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def shares_cell(keys_u, keys_v, a, b, c):
    """Whether vertices a, b and c lie in one cell between pixel centres on either axis (their
    keys, one per axis, equal): then their triangle holds no pixel centre. Branch-free."""
    return ((keys_u[a] == keys_u[b]) & (keys_u[b] == keys_u[c])) | (
        (keys_v[a] == keys_v[b]) & (keys_v[b] == keys_v[c])
    )


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def sphere_in_view(m, c_centre, c_radius, cl, planes):
    """Cluster ``cl``'s bounding sphere under camera_from_model ``m`` (3, 4): its centre in
    the camera frame (ex, ey, ez), its radius there (grown by a relative 1e-6), the largest
    column norm and entry of m's 3 x 3 part, the size of its translation, and whether the
    sphere reaches inside every plane of ``planes``. Inlined, so each caller keeps its own
    floating-point flags."""
    c0, c1, c2 = c_centre[cl, 0], c_centre[cl, 1], c_centre[cl, 2]
    ex = m[0, 0] * c0 + m[0, 1] * c1 + m[0, 2] * c2 + m[0, 3]
    ey = m[1, 0] * c0 + m[1, 1] * c1 + m[1, 2] * c2 + m[1, 3]
    ez = m[2, 0] * c0 + m[2, 1] * c1 + m[2, 2] * c2 + m[2, 3]
    sc = 0.0
    rmag = 0.0
    for c in range(3):
        sc = max(sc, math.sqrt(m[0, c] ** 2 + m[1, c] ** 2 + m[2, c] ** 2))
        for r in range(3):
            rmag = max(rmag, abs(m[r, c]))
    rad = c_radius[cl] * sc * (1 + 1e-6) + 1e-9
    inside = True
    for p in range(planes.shape[0]):
        if planes[p, 0] * ex + planes[p, 1] * ey + planes[p, 2] * ez + planes[p, 3] < -rad:
            inside = False
    tmag = abs(m[0, 3]) + abs(m[1, 3]) + abs(m[2, 3])
    return ex, ey, ez, rad, sc, rmag, tmag, inside


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", fastmath=True)
def _cluster(
    j,
    q,
    k,
    vertices,
    faces,
    c_centre,
    c_radius,
    c_vrange,
    c_axis,
    c_cos,
    c_sin,
    c_thick,
    c_perim,
    slot,
    vbase,
    fbase,
    nfaces,
    cbase,
    backcull,
    cfm,
    eye,
    det,
    usc,
    proj,
    planes,
    near_keep,
    snap,
    width,
    height,
    masks,
    jobface,
    wu,
    wv,
    wz,
    we,
    wr,
    keys_u,
    keys_v,
    occ,
    zb,
    tiles,
    dirty,
    tally,
):
    """Job j (cluster k of visible instance q): sets the bits of its faces that may change a
    pixel in ``masks[j]`` and returns their number. With ``occ``, also drops what lies behind
    the depth bound ``zb`` and writes there what it keeps (:mod:`genie_gl.render.occlusion`)."""
    fx, s, cx, fy, cy = proj[0], proj[1], proj[2], proj[3], proj[4]
    scale = fx + abs(s) + fy
    f0 = fbase[q] + k * CLUSTER
    nf = min(CLUSTER, nfaces[q] - k * CLUSTER)
    cl = cbase[q] + k
    vb = vbase[q]
    jobface[j] = f0
    for w in range(_MASK_WORDS):
        masks[j, w] = 0
    m = cfm[slot[q]]
    bc = backcull[q]
    # cluster sphere against the frustum (camera frame)
    c0, c1, c2 = c_centre[cl, 0], c_centre[cl, 1], c_centre[cl, 2]
    ex, ey, ez, rad, sc, rmag, tmag, inside = sphere_in_view(m, c_centre, c_radius, cl, planes)
    if not inside:
        return 0
    if bc and _cone_drops(
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
        near_keep,
        snap,
        width,
        height,
    ):
        return 0
    if occ and ez - rad > near_keep:
        # the whole cluster behind what is already certainly drawn: nothing of it is seen
        zmin = ez - rad
        dx, dy, dz = c0 - eye[q, 0], c1 - eye[q, 1], c2 - eye[q, 2]
        dist = math.sqrt(dx * dx + dy * dy + dz * dz)
        ax = c_axis[cl]
        cos_b = abs(ax[0] * dx + ax[1] * dy + ax[2] * dz) / max(dist, 1e-300)
        rx, ry = (abs(ex) + rad) / zmin, (abs(ey) + rad) / zmin
        pmag = math.sqrt(3.0) * (math.sqrt(c0 * c0 + c1 * c1 + c2 * c2) + c_radius[cl])
        cerr = REL_EPS * (tmag + 3 * rmag * pmag)
        e_pos = scale * cerr * (1 + rx + ry) / zmin + ROUND * (
            fx * rx + abs(s) * ry + abs(cx) + fy * ry + abs(cy) + width + height
        )
        q_hi = cluster_depth(
            ex,
            ey,
            ez,
            rad,
            near_keep,
            dist,
            c_radius[cl],
            c_cos[cl],
            c_sin[cl],
            cos_b,
            c_thick[cl],
            usc[q],
            proj,
            cerr,
            e_pos,
            snap,
            width,
            height,
        )
        tally[0] += 1
        if q_hi < UNBOUNDED:
            tally[1] += 1
            ulo = max(
                math.floor(
                    fx * min((ex - rad) / zmin, (ex - rad) / (ez + rad))
                    + min(
                        s * (ey - rad) / zmin,
                        s * (ey - rad) / (ez + rad),
                        s * (ey + rad) / zmin,
                        s * (ey + rad) / (ez + rad),
                    )
                    + cx
                )
                - 1.0,
                0.0,
            )
            uhi = min(
                math.ceil(
                    fx * max((ex + rad) / zmin, (ex + rad) / (ez + rad))
                    + max(
                        s * (ey - rad) / zmin,
                        s * (ey - rad) / (ez + rad),
                        s * (ey + rad) / zmin,
                        s * (ey + rad) / (ez + rad),
                    )
                    + cx
                )
                + 1.0,
                width - 1.0,
            )
            vlo = max(
                math.floor(fy * min((ey - rad) / zmin, (ey - rad) / (ez + rad)) + cy) - 1.0, 0.0
            )
            vhi = min(
                math.ceil(fy * max((ey + rad) / zmin, (ey + rad) / (ez + rad)) + cy) + 1.0,
                height - 1.0,
            )
            if ulo > uhi or vlo > vhi or hidden(zb, tiles, dirty, ulo, uhi, vlo, vhi, q_hi):
                tally[2] += 1
                return 0
    # window coordinates of the cluster's vertices, and per axis the cell of whole
    # pixels (centres at integers) that holds the vertex widened by its bound e: a
    # triangle whose three vertices share a cell on either axis holds no pixel centre.
    # A cell is k when (k, k + 1) holds [u - e, u + e], -1 left of the image, W (H)
    # right of (below) it; a vertex whose widened coordinate holds a pixel centre, or
    # that lies behind the near plane, gets a key of its own (its triangles go on to
    # the full test). Branch-free, so that the loop runs in vector registers.
    v_lo = c_vrange[cl, 0]
    nv = c_vrange[cl, 1] - v_lo
    for w in range(nv):
        px = np.float64(vertices[vb + v_lo + w, 0])
        py = np.float64(vertices[vb + v_lo + w, 1])
        pz = np.float64(vertices[vb + v_lo + w, 2])
        x = m[0, 0] * px + m[0, 1] * py + m[0, 2] * pz + m[0, 3]
        y = m[1, 0] * px + m[1, 1] * py + m[1, 2] * pz + m[1, 3]
        z = m[2, 0] * px + m[2, 1] * py + m[2, 2] * pz + m[2, 3]
        iz = 1.0 / (z if z > 1e-300 else 1.0)
        u = fx * x * iz + s * y * iz + cx
        v = fy * y * iz + cy
        err = REL_EPS * (tmag + 3 * rmag * (abs(px) + abs(py) + abs(pz)))
        e = (
            snap
            + scale * err * (1 + (abs(x) + abs(y)) * iz) * iz
            + ROUND * (abs(u) + abs(v) + width + height)
        )
        wz[w], wu[w], wv[w], we[w], wr[w] = z, u, v, e, err
        own = -2.0 - w
        hi_u, hi_v = math.floor(u + e), math.floor(v + e)
        ku = hi_u if math.ceil(u - e) > hi_u else own
        kv = hi_v if math.ceil(v - e) > hi_v else own
        ku = -1.0 if u + e < 0.0 else (width if u - e > width - 1.0 else ku)
        kv = -1.0 if v + e < 0.0 else (height if v - e > height - 1.0 else kv)
        front = z > near_keep
        keys_u[w] = ku if front else own
        keys_v[w] = kv if front else own
    n = 0
    for i in range(nf):
        f = f0 + i
        a, b, c = faces[f, 0] - v_lo, faces[f, 1] - v_lo, faces[f, 2] - v_lo
        if shares_cell(keys_u, keys_v, a, b, c):  # one branch, mostly taken
            continue
        keep = True
        if wz[a] > near_keep and wz[b] > near_keep and wz[c] > near_keep:
            ea, eb, ec = we[a], we[b], we[c]
            ua, va, ub = wu[a], wv[a], wu[b]
            vb_, uc, vc = wv[b], wu[c], wv[c]
            ulo = max(math.ceil(min(ua - ea, min(ub - eb, uc - ec))), 0.0)
            uhi = min(math.floor(max(ua + ea, max(ub + eb, uc + ec))), width - 1.0)
            vlo = max(math.ceil(min(va - ea, min(vb_ - eb, vc - ec))), 0.0)
            vhi = min(math.floor(max(va + ea, max(vb_ + eb, vc + ec))), height - 1.0)
            keep = ulo <= uhi and vlo <= vhi
            if keep:
                area2 = (ub - ua) * (vc - va) - (vb_ - va) * (uc - ua)
                e = max(ea, max(eb, ec))
                # back-facing (front faces are clockwise on screen: negative area in
                # (u, v) with v down) beyond what moving each vertex by e can flip
                spread = abs(ub - ua) + abs(vb_ - va) + abs(uc - ua) + abs(vc - va)
                flip = 2 * e * spread + 4 * e * e + 1e-9
                if bc:
                    keep = area2 <= flip
                if keep and abs(area2) > 1e-12:
                    keep = _centre_near(
                        ua, va, ub, vb_, uc, vc, e, 1.0 if area2 > 0 else -1.0, ulo, uhi, vlo, vhi
                    )
                if keep and occ:
                    # the bounds only where they can matter: a triangle may be hidden only
                    # if it is behind the buffer even at its vertices' nearest depth (q_hi
                    # is no less), and it is written only if it certainly covers a pixel
                    # centre (one lying more than e inside it) and is not culled by the GPU
                    q_top = max(1.0 / wz[a], max(1.0 / wz[b], 1.0 / wz[c]))
                    may_hide = hidden(zb, tiles, dirty, ulo, uhi, vlo, vhi, q_top)
                    ew = e * 1.001
                    may_write = (
                        (not bc or area2 < -flip)
                        and math.ceil(min(ua, min(ub, uc)) + ew)
                        <= math.floor(max(ua, max(ub, uc)) - ew)
                        and math.ceil(min(va, min(vb_, vc)) + ew)
                        <= math.floor(max(va, max(vb_, vc)) - ew)
                    )
                    tally[3] += 1
                    if may_hide or may_write:
                        q_lo, q_hi = triangle_depths(
                            ua,
                            va,
                            wz[a],
                            ub,
                            vb_,
                            wz[b],
                            uc,
                            vc,
                            wz[c],
                            max(wr[a], max(wr[b], wr[c])),
                            e - snap,
                            snap,
                            width,
                            height,
                        )
                        if q_hi < UNBOUNDED:
                            tally[4] += 1
                        if may_hide and hidden(zb, tiles, dirty, ulo, uhi, vlo, vhi, q_hi):
                            keep = False
                            tally[5] += 1
                        elif may_write and q_lo > 0.0:  # certainly drawn: an occluder
                            tally[6] += 1
                            write(zb, dirty, ua, va, ub, vb_, uc, vc, e, 1.0 / q_lo)
        if keep:
            masks[j, i >> 6] |= np.uint64(1) << np.uint64(i & 63)
            n += 1
    return n


@njit(cache=True, nogil=True, parallel=True, boundscheck=False, error_model="numpy", fastmath=True)
def _select(
    vertices,
    faces,
    c_centre,
    c_radius,
    c_vrange,
    c_axis,
    c_cos,
    c_sin,
    c_thick,
    c_perim,
    slot,
    vbase,
    fbase,
    nfaces,
    cbase,
    job0,
    backcull,
    cfm,
    eye,
    det,
    usc,
    proj,
    planes,
    near,
    snap,
    width,
    height,
    chunks,
    counts,
    masks,
    jobface,
):
    """Per job (a cluster of a visible instance; the jobs of instance q are job0[q]..job0[q+1]):
    the faces that may cover a pixel centre, as a bit mask, and their number."""
    near_keep = near * (1.0 + 1e-6) + 1e-9
    njobs = job0[len(job0) - 1]
    per_chunk = (njobs + chunks - 1) // chunks
    none = np.zeros((1, 1), np.float32)
    no_dirty = np.zeros((1, 1), np.uint8)
    no_tally = np.zeros(8, np.int64)
    for ch in prange(chunks):
        j_lo, j_hi = ch * per_chunk, min(njobs, (ch + 1) * per_chunk)
        if j_lo >= j_hi:
            continue
        wu, wv, wz, we = (
            np.empty(3 * CLUSTER),
            np.empty(3 * CLUSTER),
            np.empty(3 * CLUSTER),
            np.empty(3 * CLUSTER),
        )
        wr, keys_u, keys_v = np.empty(3 * CLUSTER), np.empty(3 * CLUSTER), np.empty(3 * CLUSTER)
        q = np.searchsorted(job0, j_lo, side="right") - 1
        for j in range(j_lo, j_hi):
            while job0[q + 1] <= j:
                q += 1
            counts[j] = _cluster(
                j,
                q,
                j - job0[q],
                vertices,
                faces,
                c_centre,
                c_radius,
                c_vrange,
                c_axis,
                c_cos,
                c_sin,
                c_thick,
                c_perim,
                slot,
                vbase,
                fbase,
                nfaces,
                cbase,
                backcull,
                cfm,
                eye,
                det,
                usc,
                proj,
                planes,
                near_keep,
                snap,
                width,
                height,
                masks,
                jobface,
                wu,
                wv,
                wz,
                we,
                wr,
                keys_u,
                keys_v,
                False,
                none,
                none,
                no_dirty,
                no_tally,
            )


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", fastmath=True)
def _select_nearest_first(
    vertices,
    faces,
    c_centre,
    c_radius,
    c_vrange,
    c_axis,
    c_cos,
    c_sin,
    c_thick,
    c_perim,
    slot,
    vbase,
    fbase,
    nfaces,
    cbase,
    job0,
    backcull,
    cfm,
    eye,
    det,
    usc,
    proj,
    planes,
    near,
    snap,
    width,
    height,
    counts,
    masks,
    jobface,
    zb,
    tiles,
    dirty,
    tally,
):
    """:func:`_select` with occlusion culling, one thread: the jobs in order of their
    spheres' nearest depth, each tested against (and then written into) the depth bound."""
    near_keep = near * (1.0 + 1e-6) + 1e-9
    njobs = job0[len(job0) - 1]
    key = np.empty(njobs)
    owner = np.empty(njobs, np.int64)
    q = 0
    for j in range(njobs):
        while job0[q + 1] <= j:
            q += 1
        owner[j] = q
        m = cfm[slot[q]]
        cl = cbase[q] + j - job0[q]
        c0, c1, c2 = c_centre[cl, 0], c_centre[cl, 1], c_centre[cl, 2]
        ez = m[2, 0] * c0 + m[2, 1] * c1 + m[2, 2] * c2 + m[2, 3]
        sc = 0.0
        for c in range(3):
            sc = max(sc, math.sqrt(m[0, c] ** 2 + m[1, c] ** 2 + m[2, c] ** 2))
        key[j] = ez - c_radius[cl] * sc
    wu, wv, wz, we = (
        np.empty(3 * CLUSTER),
        np.empty(3 * CLUSTER),
        np.empty(3 * CLUSTER),
        np.empty(3 * CLUSTER),
    )
    wr, keys_u, keys_v = np.empty(3 * CLUSTER), np.empty(3 * CLUSTER), np.empty(3 * CLUSTER)
    for j in np.argsort(key):
        q = owner[j]
        counts[j] = _cluster(
            j,
            q,
            j - job0[q],
            vertices,
            faces,
            c_centre,
            c_radius,
            c_vrange,
            c_axis,
            c_cos,
            c_sin,
            c_thick,
            c_perim,
            slot,
            vbase,
            fbase,
            nfaces,
            cbase,
            backcull,
            cfm,
            eye,
            det,
            usc,
            proj,
            planes,
            near_keep,
            snap,
            width,
            height,
            masks,
            jobface,
            wu,
            wv,
            wz,
            we,
            wr,
            keys_u,
            keys_v,
            True,
            zb,
            tiles,
            dirty,
            tally,
        )


@njit(cache=True, nogil=True, boundscheck=False)
def _emit(faces, masks, counts, jobface, starts, out):
    """The kept faces' indices, job after job, at ``starts`` (one thread: it writes only what
    is kept, and a second parallel region per frame costs a wake-up of every thread)."""
    for j in range(len(counts)):
        if counts[j] == 0:
            continue
        at = starts[j]
        f0 = jobface[j]
        for w in range(_MASK_WORDS):
            bits = masks[j, w]
            i = 0
            while bits:
                if bits & np.uint64(1):
                    f = f0 + 64 * w + i
                    out[at] = faces[f, 0]
                    out[at + 1] = faces[f, 1]
                    out[at + 2] = faces[f, 2]
                    at += 3
                bits >>= np.uint64(1)
                i += 1


class TriangleCuller:
    """Per-scene state of the exact culler: the meshes' clusters concatenated (each mesh's
    faces, vertices and clusters at its ``*base`` offsets), and buffers reused from frame to
    frame that grow with what is drawn."""

    def __init__(
        self,
        vertices: np.ndarray,
        faces: np.ndarray,
        mesh_vbase: np.ndarray,
        mesh_fbase: np.ndarray,
        mesh_nfaces: np.ndarray,
        mesh_cbase: np.ndarray,
        centre: np.ndarray,
        radius: np.ndarray,
        vrange: np.ndarray,
        axis: np.ndarray,
        cos_a: np.ndarray,
        sin_a: np.ndarray,
        thickness: np.ndarray,
        perimeter: np.ndarray,
        snap_px: float = 2.0**-4,
    ) -> None:
        self.vertices, self.faces = vertices, faces
        self.snap_px = float(snap_px)
        self.mesh_vbase, self.mesh_fbase = mesh_vbase, mesh_fbase
        self.mesh_nfaces, self.mesh_cbase = mesh_nfaces, mesh_cbase
        self.clusters = (centre, radius, vrange, axis, cos_a, sin_a, thickness, perimeter)
        self._out = np.empty(0, np.uint32)
        self._depth: DepthBound | None = None
        # the last occlusion pass: clusters tested against the depth bound, those with a
        # bounded depth, those dropped; triangles tested, bounded, dropped, written as occluders
        self.tally = np.zeros(8, np.int64)
        self.occluded = False  # whether the last frame was occlusion-culled
        self.break_even = BREAK_EVEN
        self._wait = 0  # frames until occlusion culling is tried again

    def select(
        self,
        slots: np.ndarray,
        mesh: np.ndarray,
        backcull: np.ndarray,
        cfm: np.ndarray,
        eye: np.ndarray,
        det: np.ndarray,
        K: np.ndarray,
        width: int,
        height: int,
        near: float,
        planes: np.ndarray,
        occlusion: bool = False,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Indices of the kept faces of instances ``slots`` (rows of ``cfm``, (N, 3, 4)
        camera_from_model), whose meshes are ``mesh``; those flagged in ``backcull`` are drawn
        with back-face culling; ``eye`` (Q, 3) is the camera centre in each one's model frame
        and ``det`` (Q,) the determinant of its camera_from_model. With ``occlusion``, also
        drops what lies behind what is certainly drawn (:mod:`genie_gl.render.occlusion`; one
        thread, clusters nearest first) when it paid on the last frame that tried it (it
        dropped at least ``break_even``, by default :data:`BREAK_EVEN`, of the triangles it
        tested), or that frame was :data:`PROBE_FRAMES` ago; the frame is the same either way.
        Returns (indices uint32, first index per slot, index
        count per slot), instance after instance."""
        nf = self.mesh_nfaces[mesh]
        nclus = -(-nf // CLUSTER)
        job0 = np.zeros(len(slots) + 1, np.int64)
        np.cumsum(nclus, out=job0[1:])
        njobs = int(job0[-1])
        proj = np.array([K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]], dtype=np.float64)
        counts = np.empty(njobs, np.int64)
        masks = np.empty((njobs, _MASK_WORDS), np.uint64)
        jobface = np.empty(njobs, np.int64)
        args = (
            self.vertices,
            self.faces,
            *self.clusters,
            slots.astype(np.int64),
            self.mesh_vbase[mesh],
            self.mesh_fbase[mesh],
            nf,
            self.mesh_cbase[mesh],
            job0,
            np.ascontiguousarray(backcull),
            cfm,
            np.ascontiguousarray(eye, np.float64),
            np.ascontiguousarray(det, np.float64),
            uniform_scale(cfm[slots]),
            proj,
            planes,
            float(near),
            self.snap_px,
            float(width),
            float(height),
        )
        # threads only for big frames: a parallel launch costs a wake-up of every thread,
        # milliseconds when the machine is busy
        threads = numba.get_num_threads()
        single = threads == 1 or int(nf.sum()) < PARALLEL_FACES
        chunks = 1 if single else 8 * threads
        if single and threads > 1:
            numba.set_num_threads(1)
        try:
            run = occlusion and self._wait <= 0
            self._wait -= 1 if occlusion else 0
            self.occluded = run
            if run:
                depth = self._depth
                if depth is None or (depth.width, depth.height) != (width, height):
                    depth = self._depth = DepthBound(width, height)
                depth.clear()
                self.tally[:] = 0
                _select_nearest_first(
                    *args, counts, masks, jobface, depth.z, depth.tiles, depth.dirty, self.tally
                )
                pays = self.tally[5] >= self.break_even * max(int(self.tally[3]), 1)
                self._wait = 0 if pays else PROBE_FRAMES
            else:
                self.tally[:] = 0
                _select(*args, chunks, counts, masks, jobface)
            starts = np.zeros(njobs + 1, np.int64)
            np.cumsum(3 * counts, out=starts[1:])
            total = int(starts[-1])
            if len(self._out) < total:  # grows with what is drawn, by half again at a time
                self._out = np.empty(max(total, len(self._out) * 3 // 2), np.uint32)
            _emit(self.faces, masks, counts, jobface, starts, self._out)
        finally:
            if single and threads > 1:
                numba.set_num_threads(threads)
        first = starts[job0[:-1]]
        return self._out[:total], first, starts[job0[1:]] - first


def uniform_scale(cfm: np.ndarray) -> np.ndarray:
    """(Q,) float64: per (3, 4) camera_from_model, its scale when its 3 x 3 part is a rotation
    times one scale (distances to planes then scale with it), else 0."""
    M = cfm[:, :, :3]
    gram = np.einsum("nki,nkj->nij", M, M)
    s2 = np.trace(gram, axis1=1, axis2=2) / 3
    uniform = np.abs(gram - s2[:, None, None] * np.eye(3)).max(axis=(1, 2)) <= 1e-9 * s2
    return np.where(uniform, np.sqrt(s2), 0.0)
