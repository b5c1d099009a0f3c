"""Where a cluster of the CPU raster's frame may land: the inner kernels that bound before
anything is tested.

- :func:`_bound_cluster`: may cluster k of an instance show at all (its sphere against the
  frustum, its normal cone for back-face-culled instances), and the pixel box and nearest
  depth it may cover.
- :func:`_project`: its vertices in the camera frame and on screen, and per axis the cell
  between pixel centres each lies in: a triangle whose three vertices share a cell on either
  axis holds no pixel centre and costs no more than that comparison.
- :func:`_clip_box`: the pixel box of the part of a triangle in front of the near plane.

:mod:`genie_gl.render.cpu.coverage` draws the cluster's triangles with them.
"""

from __future__ import annotations

import math

import numpy as np

from ...jit import njit
from ..cull import _cone_drops, sphere_in_view


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
def shares_cell(keys, a, b, c):
    """Whether vertices a, b and c lie in one cell between pixel centres on either axis, from
    their keys (:func:`_project`: u's cell in the high half of a word, v's in the low half):
    then their triangle holds no pixel centre. Branch-free; a, b, c unsigned."""
    x = (keys[a] ^ keys[b]) | (keys[b] ^ keys[c])
    return ((x >> np.uint64(32)) == 0) | ((x & np.uint64(0xFFFFFFFF)) == 0)


@njit(
    cache=True, nogil=True, boundscheck=False, error_model="numpy", fastmath={"nnan", "ninf", "nsz"}
)
def _project(m, X, Y, Z, v0, nv, proj, near, width, height, wx, wy, wz, wu, wv, keys):
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
        ku = ku if front else own
        kv = kv if front else own
        # both cells in one word: u's in the high half, v's in the low half (each an integer
        # within int32), so a face's three keys are read in three loads (:func:`shares_cell`)
        keys[w] = (np.uint64(np.int64(ku)) << np.uint64(32)) | (
            np.uint64(np.int64(kv)) & np.uint64(0xFFFFFFFF)
        )


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
