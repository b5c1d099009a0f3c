"""A mesh made ready to draw and cull: faces cleaned, cut into clusters, bounds and cones.

One compiled pass per mesh (numba, cached on disk), linear in its faces:

1. faces with a non-finite vertex or zero area are dropped (reported once, naming the mesh);
2. the kept faces are put in Morton order of their centroids (a three-pass radix sort of
   30-bit codes) and cut into runs of :data:`CLUSTER` faces, each run with its own vertices
   (a vertex shared by two runs is stored twice), so that a run is small in space and uses a
   short private range of the vertex buffer;
3. per run: the bounding sphere (centre of its box, radius to its farthest vertex), its
   vertex range, and what back-face culling of a whole run needs (:class:`Clusters`).

A mesh placed by many instances is prepared once (the renderer keys this by mesh), so the
cost of a scene's upload grows with its meshes, not with its instances.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from ..jit import njit
from ..scene.model import Mesh

log = logging.getLogger(__name__)

# faces per cluster: per frame a cluster costs its culling tests (sphere, normal cone, occlusion)
# and a draw's set-up, a face the cell test; on the benchmark scenes, the CPU raster's
# steady frame on one thread with 128 / 256 / 512 faces, in turns: the instanced hall 1 /
# 0.81-0.84 / 0.75-0.77, the 10 M scene of 221 meshes 1 / 0.91 / 0.89; the 1 M scene, a
# generated scene and the lens frames within the noise; the 100 k scene 1.01-1.24x with 512
# in three runs (noisy, but the one scene that may lose; tools/cluster_size.py,
# docs/rasters.md)
CLUSTER = 512


@dataclass(frozen=True, eq=False)
class Clusters:
    """A mesh's drawable faces in clusters of :data:`CLUSTER` faces (the last may be shorter).

    Attributes
    ----------
    vertices : (V', 3) float32, model frame; each cluster's vertices stored apart.
    faces : (F', 3) uint32, indices into ``vertices``, in cluster order; F' <= F.
    centre : (C, 3) float64, the centre of each cluster's bounding box (model frame, m).
    radius : (C,) float64, distance from ``centre`` to the cluster's farthest vertex (m).
    vrange : (C, 2) int64, first and last + 1 vertex a cluster uses.
    axis : (C, 3) float64, unit mean normal of the cluster's faces (zero: no cone).
    cos_a, sin_a : (C,) float64, cosine and sine of the largest angle between ``axis`` and a
        face normal of the cluster (cos_a <= 0: the faces face every way; no cone).
    thickness : (C,) float64, the smallest 2 · area / perimeter of the cluster's faces (m).
    perimeter : (C,) float64, the smallest perimeter of the cluster's faces (m).
    lo, hi : (3,) float64, the box of the kept faces' vertices (NaN when there are none).
    bound : float, the distance from the box's centre to the farthest of those vertices (m).
    dropped_nonfinite, dropped_degenerate : faces dropped for a NaN/Inf vertex, for zero area.
    """

    vertices: np.ndarray
    faces: np.ndarray
    centre: np.ndarray
    radius: np.ndarray
    vrange: np.ndarray
    axis: np.ndarray
    cos_a: np.ndarray
    sin_a: np.ndarray
    thickness: np.ndarray
    perimeter: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    bound: float
    dropped_nonfinite: int
    dropped_degenerate: int

    @property
    def count(self) -> int:
        return len(self.radius)


@njit(cache=True, nogil=True, boundscheck=False)
def _keep_and_codes(v, faces):
    """Per face: kept (finite, non-zero area; 0 non-finite, 1 degenerate, 2 kept) and the
    30-bit Morton code of its centroid within the kept centroids' box."""
    n = len(faces)
    state = np.empty(n, np.uint8)
    cen = np.empty((n, 3))
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for f in range(n):
        a, b, c = faces[f, 0], faces[f, 1], faces[f, 2]
        finite = True
        for k in range(3):
            if not (math.isfinite(v[a, k]) and math.isfinite(v[b, k]) and math.isfinite(v[c, k])):
                finite = False
        if not finite:
            state[f] = 0
            continue
        e1x, e1y, e1z = (
            np.float64(v[b, 0]) - v[a, 0],
            np.float64(v[b, 1]) - v[a, 1],
            np.float64(v[b, 2]) - v[a, 2],
        )
        e2x, e2y, e2z = (
            np.float64(v[c, 0]) - v[a, 0],
            np.float64(v[c, 1]) - v[a, 1],
            np.float64(v[c, 2]) - v[a, 2],
        )
        nx, ny, nz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
        if not (nx * nx + ny * ny + nz * nz > 0):
            state[f] = 1
            continue
        state[f] = 2
        for k in range(3):
            x = (np.float64(v[a, k]) + np.float64(v[b, k]) + np.float64(v[c, k])) / 3.0
            cen[f, k] = x
            lo[k] = min(lo[k], x)
            hi[k] = max(hi[k], x)
    codes = np.zeros(n, np.uint32)
    dropped = np.zeros(2, np.int64)
    for f in range(n):
        if state[f] != 2:
            dropped[state[f]] += 1
            continue
        code = np.uint32(0)
        for k in range(3):
            span = hi[k] - lo[k]
            q = int((cen[f, k] - lo[k]) / span * 1023.0) if span > 0 else 0
            q = min(max(q, 0), 1023)
            for bit in range(10):
                code |= np.uint32(((q >> bit) & 1) << (3 * bit + k))
        codes[f] = code
    return state, codes, dropped


@njit(cache=True, nogil=True, boundscheck=False)
def _radix_order(keys, state):
    """Indices of the kept faces (state == 2) sorted by 30-bit key, stable (three passes of
    ten bits: linear in the number of faces)."""
    m = 0
    for f in range(len(keys)):
        if state[f] == 2:
            m += 1
    order = np.empty(m, np.int64)
    j = 0
    for f in range(len(keys)):
        if state[f] == 2:
            order[j] = f
            j += 1
    tmp = np.empty(m, np.int64)
    count = np.empty(1025, np.int64)
    for shift in (0, 10, 20):
        count[:] = 0
        for i in range(m):
            count[((keys[order[i]] >> shift) & 1023) + 1] += 1
        for d in range(1024):
            count[d + 1] += count[d]
        for i in range(m):
            d = (keys[order[i]] >> shift) & 1023
            tmp[count[d]] = order[i]
            count[d] += 1
        order, tmp = tmp, order
    return order


@njit(cache=True, nogil=True, boundscheck=False)
def _build(v, faces, order, cluster):
    """Vertices and faces in cluster order, and each cluster's sphere, range and cone."""
    m = len(order)
    nc = (m + cluster - 1) // cluster
    stamp = np.full(len(v), -1, np.int64)
    local = np.empty(len(v), np.int64)
    # pass 1: vertices per cluster
    vstart = np.zeros(nc + 1, np.int64)
    for c in range(nc):
        k = 0
        for i in range(c * cluster, min(m, (c + 1) * cluster)):
            f = order[i]
            for j in range(3):
                x = faces[f, j]
                if stamp[x] != c:
                    stamp[x] = c
                    k += 1
        vstart[c + 1] = vstart[c] + k
    out_v = np.empty((vstart[nc], 3), np.float32)
    out_f = np.empty((m, 3), np.uint32)
    centre = np.zeros((nc, 3))
    radius = np.zeros(nc)
    vrange = np.empty((nc, 2), np.int64)
    axis = np.zeros((nc, 3))
    cos_a = np.full(nc, -1.0)
    sin_a = np.zeros(nc)
    thick = np.full(nc, np.inf)
    perim = np.full(nc, np.inf)
    stamp[:] = -1
    for c in range(nc):
        at = vstart[c]
        for i in range(c * cluster, min(m, (c + 1) * cluster)):
            f = order[i]
            for j in range(3):
                x = faces[f, j]
                if stamp[x] != c:
                    stamp[x] = c
                    local[x] = at
                    out_v[at, 0], out_v[at, 1], out_v[at, 2] = v[x, 0], v[x, 1], v[x, 2]
                    at += 1
                out_f[i, j] = local[x]
        v0, v1 = vstart[c], vstart[c + 1]
        vrange[c, 0], vrange[c, 1] = v0, v1
        lo0 = lo1 = lo2 = np.inf
        hi0 = hi1 = hi2 = -np.inf
        for q in range(v0, v1):
            x, y, z = np.float64(out_v[q, 0]), np.float64(out_v[q, 1]), np.float64(out_v[q, 2])
            lo0, lo1, lo2 = min(lo0, x), min(lo1, y), min(lo2, z)
            hi0, hi1, hi2 = max(hi0, x), max(hi1, y), max(hi2, z)
        c0, c1, c2 = (lo0 + hi0) / 2, (lo1 + hi1) / 2, (lo2 + hi2) / 2
        r2 = 0.0
        for q in range(v0, v1):
            dx, dy, dz = out_v[q, 0] - c0, out_v[q, 1] - c1, out_v[q, 2] - c2
            r2 = max(r2, dx * dx + dy * dy + dz * dz)
        centre[c, 0], centre[c, 1], centre[c, 2] = c0, c1, c2
        radius[c] = math.sqrt(r2)
        # normal cone: the mean unit normal and the widest angle from it
        ax = ay = az = 0.0
        for i in range(c * cluster, min(m, (c + 1) * cluster)):
            a, b, d = out_f[i, 0], out_f[i, 1], out_f[i, 2]
            e1 = (
                np.float64(out_v[b, 0]) - out_v[a, 0],
                np.float64(out_v[b, 1]) - out_v[a, 1],
                np.float64(out_v[b, 2]) - out_v[a, 2],
            )
            e2 = (
                np.float64(out_v[d, 0]) - out_v[a, 0],
                np.float64(out_v[d, 1]) - out_v[a, 1],
                np.float64(out_v[d, 2]) - out_v[a, 2],
            )
            e3 = (
                np.float64(out_v[d, 0]) - out_v[b, 0],
                np.float64(out_v[d, 1]) - out_v[b, 1],
                np.float64(out_v[d, 2]) - out_v[b, 2],
            )
            nx = e1[1] * e2[2] - e1[2] * e2[1]
            ny = e1[2] * e2[0] - e1[0] * e2[2]
            nz = e1[0] * e2[1] - e1[1] * e2[0]
            area2 = math.sqrt(nx * nx + ny * ny + nz * nz)
            p = (
                math.sqrt(e1[0] ** 2 + e1[1] ** 2 + e1[2] ** 2)
                + math.sqrt(e2[0] ** 2 + e2[1] ** 2 + e2[2] ** 2)
                + math.sqrt(e3[0] ** 2 + e3[1] ** 2 + e3[2] ** 2)
            )
            thick[c] = min(thick[c], area2 / p)
            perim[c] = min(perim[c], p)
            ax += nx / area2
            ay += ny / area2
            az += nz / area2
        n = math.sqrt(ax * ax + ay * ay + az * az)
        if n > 0:
            ax, ay, az = ax / n, ay / n, az / n
            lo_cos = 1.0
            for i in range(c * cluster, min(m, (c + 1) * cluster)):
                a, b, d = out_f[i, 0], out_f[i, 1], out_f[i, 2]
                e1x, e1y, e1z = (
                    np.float64(out_v[b, 0]) - out_v[a, 0],
                    np.float64(out_v[b, 1]) - out_v[a, 1],
                    np.float64(out_v[b, 2]) - out_v[a, 2],
                )
                e2x, e2y, e2z = (
                    np.float64(out_v[d, 0]) - out_v[a, 0],
                    np.float64(out_v[d, 1]) - out_v[a, 1],
                    np.float64(out_v[d, 2]) - out_v[a, 2],
                )
                nx, ny, nz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
                lo_cos = min(
                    lo_cos, (nx * ax + ny * ay + nz * az) / math.sqrt(nx * nx + ny * ny + nz * nz)
                )
            if lo_cos > 1e-3:  # narrower than a half-space: usable as a cone
                axis[c, 0], axis[c, 1], axis[c, 2] = ax, ay, az
                # widen by a little for the rounding of the normals above
                cos_a[c] = max(lo_cos - 1e-9, 0.0)
                sin_a[c] = math.sqrt(max(0.0, 1.0 - cos_a[c] * cos_a[c]))
    box = np.full((2, 3), np.nan)
    mesh_r = 0.0
    if len(out_v):
        for k in range(3):
            box[0, k], box[1, k] = np.inf, -np.inf
        for q in range(len(out_v)):
            for k in range(3):
                box[0, k] = min(box[0, k], np.float64(out_v[q, k]))
                box[1, k] = max(box[1, k], np.float64(out_v[q, k]))
        for q in range(len(out_v)):
            d2 = 0.0
            for k in range(3):
                d2 += (out_v[q, k] - (box[0, k] + box[1, k]) / 2) ** 2
            mesh_r = max(mesh_r, d2)
    return (
        out_v,
        out_f,
        centre,
        radius,
        vrange,
        axis,
        cos_a,
        sin_a,
        thick,
        perim,
        box,
        math.sqrt(mesh_r),
    )


def prepare(mesh: Mesh, name: str) -> Clusters:
    """The clusters of ``mesh`` (``name`` only names it in the warning about dropped faces)."""
    v = np.ascontiguousarray(mesh.vertices, dtype=np.float32)
    f = np.ascontiguousarray(mesh.faces, dtype=np.uint32)
    state, codes, dropped = _keep_and_codes(v, f)
    order = _radix_order(codes, state)
    nonfinite, degenerate = int(dropped[0]), int(dropped[1])
    if nonfinite or degenerate:
        log.warning(
            "mesh %r: skipped %d of %d faces (%d with NaN/Inf vertices, %d degenerate)",
            name,
            nonfinite + degenerate,
            len(f),
            nonfinite,
            degenerate,
        )
    out_v, out_f, centre, radius, vrange, axis, cos_a, sin_a, thick, perim, box, mesh_r = _build(
        v, f, order, CLUSTER
    )
    return Clusters(
        out_v,
        out_f,
        centre,
        radius,
        vrange,
        axis,
        cos_a,
        sin_a,
        thick,
        perim,
        box[0],
        box[1],
        float(mesh_r),
        nonfinite,
        degenerate,
    )
