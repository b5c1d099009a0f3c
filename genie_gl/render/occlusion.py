"""Exact occlusion culling: a conservative depth buffer of what is certainly drawn.

The culler (:mod:`genie_gl.render.cull`) visits a frame's clusters nearest first. Every
triangle it keeps that the GPU will certainly draw is written into :class:`DepthBound`'s
buffer at the pixel centres it certainly covers, with a depth no nearer than any the GPU can
give it there. A later cluster, or triangle, whose nearest possible GPU depth lies strictly
behind that buffer at every pixel centre it could cover is dropped.

Why this changes no pixel: with the depth test "greater" on reversed depth (``near / z``), a
pixel ends as the first fragment, in draw order, of those with the greatest depth. The buffer
holds, per pixel, a depth the GPU's own fragment of some drawn triangle reaches at least, so
the pixel's final depth is at least that; a fragment strictly below it is never the greatest
and removing it changes neither the depth nor which fragment wins (nor its ids, colour or
normal, which are the winner's own). Ties need strictness only, not an order.

Depths are compared as q = 1/z. Per triangle, :func:`triangle_depths` bounds the q the GPU
writes at a pixel centre it covers: the exact plane through the GPU's vertex values lies
within their range there, and what float32 arithmetic adds is bounded from llvmpipe's set-up
(a plane at the framebuffer's origin, ``a0 + dadx x + dady y``; its coefficients from the
vertex differences and the inverse area): relative errors of 2^-24 times the size of every
term, the triangle's vertex error (the float32 eye coordinates) and its position error (the
window coordinates, moving the plane by at most its gradient times that error). A triangle
too thin for its gradient to be bounded (an altitude under eight position errors) is neither
dropped nor written. :func:`cluster_depth` gives the same bound for every face of a cluster
before its vertices are transformed, from its sphere, normal cone and thinnest face.

The buffer holds eye z (float32, rounded up), per tile of 8 x 8 pixels its maximum (made again
when a write has lowered a pixel of it); "nothing drawn" is a large finite value (the kernels
are compiled with fast-math, which assumes no infinities).
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit

TILE = 8  # pixels per tile side
EMPTY = np.float32(1e30)  # eye z of a pixel with nothing certainly drawn yet
UNBOUNDED = 1e300  # a q bound that says "no bound": never dropped, never written
EPS32 = 2.0**-24  # float32 unit roundoff
ROUND = 16 * EPS32  # window coordinates' own rounding, per px of |u| + |v| + W + H
THIN = 10.0  # a cluster's faces must be this many position errors thick on screen
_GROW = np.float32(1 + 2.0**-20)


class DepthBound:
    """The culler's conservative depth buffer for one image size.

    Attributes
    ----------
    z : (H, W) float32, per pixel an eye z (m) that the frame's final depth is certainly no
        farther than (:data:`EMPTY` where nothing is known).
    tiles : (ceil(H / 8), ceil(W / 8)) float32, per tile the maximum of ``z`` over its pixels.
    dirty : (ceil(H / 8), ceil(W / 8)) uint8, 1 where ``tiles`` must be made again.
    """

    def __init__(self, width: int, height: int) -> None:
        self.width, self.height = int(width), int(height)
        self.z = np.empty((height, width), np.float32)
        th, tw = -(-height // TILE), -(-width // TILE)
        self.tiles = np.empty((th, tw), np.float32)
        self.dirty = np.empty((th, tw), np.uint8)

    def clear(self) -> None:
        self.z.fill(EMPTY)
        self.tiles.fill(EMPTY)
        self.dirty.fill(0)


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def triangle_depths(ua, va, za, ub, vb, zb, uc, vc, zc, err, e, snap, width, height):
    """(q_lo, q_hi): bounds of the 1/z the GPU writes at any pixel centre it covers with the
    triangle whose window coordinates are (u, v) and eye depths z (all > 0). ``err``: the
    largest absolute error of the float32 eye coordinates; ``e``: of the window coordinates
    (px, per axis); ``snap``: how far a covered pixel centre may lie outside the triangle
    the GPU interpolates over (its sub-pixel snapping). (0, UNBOUNDED) when moving the
    vertices by e could take the triangle's area near zero (no bound on its gradient)."""
    qa, qb, qc = 1.0 / za, 1.0 / zb, 1.0 / zc
    qmax = max(qa, max(qb, qc))
    qmin = min(qa, min(qb, qc))
    rho = err * qmax + 4 * EPS32
    du1, dv1, du2, dv2 = ub - ua, vb - va, uc - ua, vc - va
    det = abs(du1 * dv2 - du2 * dv1)
    l1 = abs(du1) + abs(dv1)
    l2 = abs(du2) + abs(dv2)
    l3 = abs(uc - ub) + abs(vc - vb)
    # moving vertex i by d changes the area (twice) by d x (the opposite edge)
    flip = e * (l1 + l2 + l3) + 8 * e * e
    if not det > 2 * flip:
        return 0.0, UNBOUNDED
    dq1, dq2 = qb - qa, qc - qa
    g = abs(dq1 * dv2 - dq2 * dv1) / det + abs(du1 * dq2 - du2 * dq1) / det
    length = max(l1, max(l2, l3))
    inv = (l1 + l2 + l3 - length + 4 * e) / (det - flip)  # the two shorter edges span it
    cond = (abs(du1 * dv2) + abs(du2 * dv1)) / det
    return _bounds(qmin, qmax, g, rho, e, inv, length, cond, snap, width, height)


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _bounds(qmin, qmax, g, rho, e, inv, length, cond, snap, width, height):
    """The q range the GPU can write over a triangle with vertex q in [qmin, qmax] (relative
    error rho), exact gradient g (L1, per px), vertices off by e (px), the inverse of its
    edge matrix after that move at most ``inv``, longest edge ``length`` (L1, px), area
    condition ``cond``. The GPU's plane runs through its own vertices and values: its
    gradient gp differs from g by at most inv (2 rho qmax + 2 e g). Float32 rounding of the
    plane's coefficients (gradients from the inverse area, the value at the framebuffer's
    origin) and of its evaluation at a pixel adds 16 roundings of every term's size; a
    covered pixel centre may lie ``snap`` + e outside the triangle."""
    gp = g + inv * (2 * rho * qmax + 2 * e * g)
    span = 2.0 * (width + height) + 3 * length
    coef = 3 * (qmax - qmin + 2 * rho * qmax) * inv * length + cond * gp * length
    slack = 16 * EPS32 * (qmax + gp * span + coef) + gp * (snap + e)
    return qmin * (1 - 2 * rho) - slack, qmax * (1 + 2 * rho) + slack


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def cluster_depth(
    ex,
    ey,
    ez,
    rad,
    near,
    dist,
    cr,
    cos_a,
    sin_a,
    cos_b,
    thick,
    sc,
    proj,
    err,
    e,
    snap,
    width,
    height,
):
    """An upper bound of the 1/z the GPU writes anywhere with any face of a cluster, before its
    vertices are transformed; UNBOUNDED when none follows. The cluster: its bounding sphere in
    the eye frame (centre ``ex, ey, ez``, radius ``rad``), in its model frame the eye's distance
    ``dist`` to its centre and its radius ``cr``, its normal cone (``cos_a``, ``sin_a``) and
    the cosine ``cos_b`` between the cone's axis and the line to the eye, its thinnest face
    ``thick`` (2 area / perimeter), the instance's uniform scale ``sc`` (0: not uniform);
    ``err``, ``e``, ``snap`` as for :func:`triangle_depths`, for all its vertices."""
    zmin = ez - rad
    if sc <= 0.0 or cos_a <= 0.0 or zmin <= near or dist <= cr:
        return UNBOUNDED
    sin_b = math.sqrt(max(0.0, 1.0 - cos_b * cos_b))
    cos_ab = cos_a * cos_b - sin_a * sin_b
    dmin = dist * cos_ab - cr  # the eye's least distance to a face's plane (model)
    if cos_ab <= 0.0 or dmin <= 0.0:
        return UNBOUNDED
    fx, s, fy = proj[0], proj[1], proj[3]
    f_lo = min(fx, fy) - abs(s)
    if f_lo <= 0.0:
        return UNBOUNDED
    c_lo = dmin * sc  # in the eye frame (m)
    # on screen 1/z = (n . ray) / c over a face's plane at distance c from the eye
    g = (1.0 / fx + 1.0 / fy + abs(s) / (fx * fy)) / c_lo
    # each face's least altitude on screen: its altitude, foreshortened by at most
    # c_lo / R over the farthest distance R to it, seen from R
    reach = dist + cr
    h = f_lo * thick * c_lo / (reach * reach * sc)
    if not h > THIN * e:
        return UNBOUNDED
    qmax = 1.0 / zmin
    spread = 1 + (abs(ex) + rad) / zmin + (abs(ey) + rad) / zmin
    length = 4 * rad * (max(fx, fy) + abs(s)) * spread / zmin  # the sphere's extent on screen (L1)
    # a face of least altitude h and longest edge L (L2): twice its area is at least h L, what
    # moving its vertices by e takes from it at most 3 sqrt 2 e L + 8 e^2 < h L / 2, and its
    # two shorter edges sum to at most 2 sqrt 2 L (L1): inv <= (2 sqrt 2 L + 4 e) / (h L / 2) < 7 /
    # h
    return _bounds(
        1.0 / (ez + rad),
        qmax,
        g,
        err * qmax + 4 * EPS32,
        e,
        7.0 / h,
        length,
        2 * length / h,
        snap,
        width,
        height,
    )[1]


@njit(cache=True, nogil=True, boundscheck=False)
def _tile_max(z, tiles, dirty, ty, tx):
    if dirty[ty, tx]:
        m = np.float32(0.0)
        for v in range(ty * TILE, min(z.shape[0], (ty + 1) * TILE)):
            for u in range(tx * TILE, min(z.shape[1], (tx + 1) * TILE)):
                m = max(m, z[v, u])
        tiles[ty, tx] = m
        dirty[ty, tx] = 0
    return tiles[ty, tx]


@njit(cache=True, nogil=True, boundscheck=False)
def hidden(z, tiles, dirty, ulo, uhi, vlo, vhi, q_hi):
    """True when every pixel centre of columns ulo..uhi, rows vlo..vhi (whole numbers, within
    the image) lies strictly behind the buffer for a surface of 1/z at most ``q_hi``. Small
    boxes are read pixel by pixel, larger ones tile by tile (whole tiles: coarser, never
    wrong)."""
    if q_hi >= UNBOUNDED:
        return False
    u0, u1, v0, v1 = int(ulo), int(uhi), int(vlo), int(vhi)
    if (u1 - u0 + 1) * (v1 - v0 + 1) <= 2 * TILE * TILE:
        for v in range(v0, v1 + 1):
            for u in range(u0, u1 + 1):
                if z[v, u] * q_hi >= 1.0:
                    return False
        return True
    for ty in range(v0 // TILE, v1 // TILE + 1):
        for tx in range(u0 // TILE, u1 // TILE + 1):
            if _tile_max(z, tiles, dirty, ty, tx) * q_hi >= 1.0:
                return False
    return True


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _inner(pu, pv, qu, qv, length, sg, at, lo, hi):
    """Narrow [lo, hi] to the u of row v = ``at`` lying more than e inside edge p->q
    (``length``: the edge's length times e)."""
    d = sg * (qv - pv)
    c = sg * ((qu - pu) * (at - pv) + (qv - pv) * pu)
    if d > 0:
        hi = min(hi, (c - length) / d)
    elif d < 0:
        lo = max(lo, (c - length) / d)
    elif c - length <= 0:
        lo, hi = 1.0, 0.0
    return lo, hi


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def write(z, dirty, ua, va, ub, vb, uc, vc, e, z_far):
    """Write eye depth ``z_far`` (rounded up) at every pixel centre lying more than ``e``
    inside the triangle (which any triangle whose vertices each move by at most e still
    covers), where it is nearer than what the buffer holds."""
    area2 = (ub - ua) * (vc - va) - (vb - va) * (uc - ua)
    sg = 1.0 if area2 > 0 else -1.0
    e = e * 1.001
    height, width = z.shape
    vlo = max(math.ceil(min(va, min(vb, vc)) + e), 0.0)
    vhi = min(math.floor(max(va, max(vb, vc)) - e), height - 1.0)
    ulo0 = max(math.ceil(min(ua, min(ub, uc)) + e), 0.0)
    uhi0 = min(math.floor(max(ua, max(ub, uc)) - e), width - 1.0)
    zf = np.float32(z_far) * _GROW
    lab = math.sqrt((ub - ua) ** 2 + (vb - va) ** 2) * e
    lbc = math.sqrt((uc - ub) ** 2 + (vc - vb) ** 2) * e
    lca = math.sqrt((ua - uc) ** 2 + (va - vc) ** 2) * e
    at = vlo
    while at <= vhi:
        lo, hi = ulo0, uhi0
        lo, hi = _inner(ua, va, ub, vb, lab, sg, at, lo, hi)
        lo, hi = _inner(ub, vb, uc, vc, lbc, sg, at, lo, hi)
        lo, hi = _inner(uc, vc, ua, va, lca, sg, at, lo, hi)
        v = int(at)
        for u in range(int(math.ceil(lo)), int(math.floor(hi)) + 1):
            if zf < z[v, u]:
                z[v, u] = zf
                dirty[v // TILE, u // TILE] = 1
        at += 1.0
