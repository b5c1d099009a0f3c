"""Exact culling of what cannot change a pixel (numba, parallel, cached on disk).

Per frame, for the instances that survive frustum culling, :meth:`TriangleCuller.select`
keeps the triangles that may change a pixel and writes their indices, instance by instance,
into one index array the renderer uploads and draws with one multi-draw call.

A triangle is dropped only when it cannot write a pixel:

* its cluster (a run of :data:`CLUSTER` faces of one mesh, close in space, with a bounding
  sphere) lies wholly outside the frustum, or
* all three vertices are in front of the near plane and the triangle's screen bounding box,
  widened by an error bound, holds no pixel centre of the image (a sub-pixel triangle
  between centres, or one outside the image), or
* it is drawn with back-face culling and faces away by more than moving each vertex by its
  error bound could change (the GPU would cull it too).

The error bound covers what separates this float64 test from the GPU's float32 vertex
transform and its sub-pixel snapping (1/256 pixel on llvmpipe; the tests catch a bound of
1/1024): ``1/64`` pixel plus a relative term scaled by the size of the numbers involved. A
triangle the GPU would rasterise is therefore never dropped, and the culled render is the
unculled render bit for bit (tests compare both on generated and benchmark scenes).
"""
from __future__ import annotations

import logging
import math

import numba
import numpy as np
from numba import njit, prange

from ..scene.model import Mesh

log = logging.getLogger(__name__)

# numba's own work queue first: its threads sleep between kernels (OpenMP's spin, taking
# cores from llvmpipe's rasteriser threads), and the TBB found here is refused with a warning
numba.config.THREADING_LAYER_PRIORITY = ["workqueue", "omp", "tbb"]

CLUSTER = 128          # faces per cluster (bounding sphere per cluster)
BASE_EPS_PX = 1.0 / 64  # pixels: covers sub-pixel snapping and rounding of window coordinates
REL_EPS = 1e-6          # relative error bound of the float32 eye coordinates (~16 ulp)
PARALLEL_FACES = 200_000  # below this many faces in view, one thread culls a frame


def sanitize(mesh: Mesh, name: str) -> np.ndarray:
    """Faces of ``mesh`` safe to rasterise: drops faces with non-finite or coincident vertices.

    Returns (F', 3) uint32. Dropped faces are reported once, as a warning naming the mesh.
    """
    faces = mesh.faces
    if len(faces) == 0:
        return faces
    v = mesh.vertices.astype(np.float64)
    tri = v[faces]
    finite = np.isfinite(tri).all(axis=(1, 2))
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    keep = finite & (area2 > 0)
    if not keep.all():
        log.warning("mesh %r: skipped %d of %d faces (%d with NaN/Inf vertices, %d degenerate)",
                    name, int((~keep).sum()), len(faces), int((~finite).sum()),
                    int((finite & ~(area2 > 0)).sum()))
    return np.ascontiguousarray(faces[keep])


def _morton(q: np.ndarray) -> np.ndarray:
    """Morton code of (n, 3) integers in [0, 1024)."""
    code = np.zeros(len(q), np.int64)
    for bit in range(10):
        for axis in range(3):
            code |= ((q[:, axis] >> bit) & 1) << (3 * bit + axis)
    return code


def cluster_order(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Faces in Morton order of their centroids, cut in runs of :data:`CLUSTER` faces, each
    run with its own vertices (a vertex shared by two runs is stored twice), so that a run is
    small in space (a tight sphere) and uses a short, private range of vertices. Returns
    (vertices (V', 3) float32, faces (F, 3) uint32); unused vertices go."""
    if len(faces) > CLUSTER:
        c = vertices.astype(np.float64)[faces].mean(axis=1)
        lo, span = c.min(axis=0), np.ptp(c, axis=0)
        q = np.clip((c - lo) / np.where(span > 0, span, 1) * 1023, 0, 1023).astype(np.int64)
        faces = faces[np.argsort(_morton(q), kind="stable")]
    run = (np.arange(len(faces)) // CLUSTER).repeat(3)
    key = run * len(vertices) + faces.ravel().astype(np.int64)  # (run, vertex), sorted by run first
    uniq, inverse = np.unique(key, return_inverse=True)
    return (np.ascontiguousarray(vertices[uniq % len(vertices)], dtype="<f4"),
            np.ascontiguousarray(inverse.reshape(-1, 3), dtype="<u4"))


def clusters(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Runs of :data:`CLUSTER` faces: bounding-sphere centres (C, 3) and radii (C,), float64,
    in the mesh's frame (the centre of the run's box, the radius to its farthest vertex), and
    the range of vertex indices each run uses, (C, 2) int64 (first, last + 1)."""
    n = len(faces)
    c = -(-n // CLUSTER)
    centres, radii, vrange = np.zeros((c, 3)), np.zeros(c), np.zeros((c, 2), np.int64)
    v = vertices.astype(np.float64)
    for k in range(c):
        idx = faces[k * CLUSTER:(k + 1) * CLUSTER].ravel()
        p = v[idx]
        lo, hi = p.min(axis=0), p.max(axis=0)
        centres[k] = (lo + hi) / 2
        radii[k] = np.sqrt(((p - centres[k]) ** 2).sum(axis=1).max())
        vrange[k] = idx.min(), idx.max() + 1
    return centres, radii, vrange


@njit(cache=True, nogil=True, parallel=True, boundscheck=False, error_model="numpy", fastmath=True)
def _select(vertices, faces, jobs, cfm, backcull, csph_c, csph_r, vrange, proj, planes, near, width, height,
            window, out, counts):
    """Faces of each job (slot, first face, face count, vertex base, cluster, out offset,
    scratch base) that may cover a pixel centre, written to ``out[offset:]``; their number to
    ``counts``. ``window`` is scratch for the window coordinates (u, v, z, eps) of vertices."""
    fx, s, cx, fy, cy = proj[0], proj[1], proj[2], proj[3], proj[4]
    scale = fx + abs(s) + fy
    near_keep = near * (1.0 + 1e-6) + 1e-9
    for q in prange(len(jobs)):
        slot, f0, nf, vb = jobs[q, 0], jobs[q, 1], jobs[q, 2], jobs[q, 3]
        cl, at, sb = jobs[q, 4], jobs[q, 5], jobs[q, 6]
        m = cfm[slot]
        bc = backcull[q]
        counts[q] = 0
        # cluster sphere against the frustum (camera frame)
        c0, c1, c2 = csph_c[cl, 0], csph_c[cl, 1], csph_c[cl, 2]
        ex = m[0, 0] * c0 + m[0, 1] * c1 + m[0, 2] * c2 + m[0, 3]
        ey = m[1, 0] * c0 + m[1, 1] * c1 + m[1, 2] * c2 + m[1, 3]
        ez = m[2, 0] * c0 + m[2, 1] * c1 + m[2, 2] * c2 + m[2, 3]
        sc = 0.0
        rmag = 0.0
        for c in range(3):
            sc = max(sc, math.sqrt(m[0, c] ** 2 + m[1, c] ** 2 + m[2, c] ** 2))
            for r in range(3):
                rmag = max(rmag, abs(m[r, c]))
        rad = csph_r[cl] * sc * (1 + 1e-6) + 1e-9
        outside = False
        for p in range(planes.shape[0]):
            if planes[p, 0] * ex + planes[p, 1] * ey + planes[p, 2] * ez + planes[p, 3] < -rad:
                outside = True
        if outside:
            continue
        # window coordinates of the run's vertices (runs sharing a vertex write the same value)
        tmag = abs(m[0, 3]) + abs(m[1, 3]) + abs(m[2, 3])
        for j in range(vrange[cl, 0], vrange[cl, 1]):
            px = np.float64(vertices[vb + j, 0])
            py = np.float64(vertices[vb + j, 1])
            pz = np.float64(vertices[vb + j, 2])
            x = m[0, 0] * px + m[0, 1] * py + m[0, 2] * pz + m[0, 3]
            y = m[1, 0] * px + m[1, 1] * py + m[1, 2] * pz + m[1, 3]
            z = m[2, 0] * px + m[2, 1] * py + m[2, 2] * pz + m[2, 3]
            k = sb + j
            window[k, 2] = z
            if z > 0:
                iz = 1.0 / z
                window[k, 0] = fx * x * iz + s * y * iz + cx
                window[k, 1] = fy * y * iz + cy
                err = REL_EPS * (tmag + 3 * rmag * (abs(px) + abs(py) + abs(pz)))
                window[k, 3] = BASE_EPS_PX + scale * err * (1 + (abs(x) + abs(y)) * iz) * iz
        n = 0
        for f in range(f0, f0 + nf):
            ia, ib, ic = faces[f, 0], faces[f, 1], faces[f, 2]
            a, b, c = sb + ia, sb + ib, sb + ic
            keep = True
            if window[a, 2] > near_keep and window[b, 2] > near_keep and window[c, 2] > near_keep:
                ea, eb, ec = window[a, 3], window[b, 3], window[c, 3]
                ua, va, ub = window[a, 0], window[a, 1], window[b, 0]
                vb_, uc, vc = window[b, 1], window[c, 0], window[c, 1]
                ulo = max(math.ceil(min(ua - ea, min(ub - eb, uc - ec))), 0.0)
                uhi = min(math.floor(max(ua + ea, max(ub + eb, uc + ec))), width - 1.0)
                vlo = max(math.ceil(min(va - ea, min(vb_ - eb, vc - ec))), 0.0)
                vhi = min(math.floor(max(va + ea, max(vb_ + eb, vc + ec))), height - 1.0)
                keep = ulo <= uhi and vlo <= vhi
                if keep and bc:
                    # back-facing (front faces are clockwise on screen: negative area in (u, v)
                    # with v down) beyond what moving each vertex by its error bound can flip
                    area2 = (ub - ua) * (vc - va) - (vb_ - va) * (uc - ua)
                    e = max(ea, max(eb, ec))
                    per = abs(ub - ua) + abs(vb_ - va) + abs(uc - ua) + abs(vc - va)
                    keep = area2 <= 2 * e * per + 4 * e * e + 1e-9
            if keep:
                out[at + 3 * n] = ia
                out[at + 3 * n + 1] = ib
                out[at + 3 * n + 2] = ic
                n += 1
        counts[q] = n


@njit(cache=True, nogil=True, parallel=True, boundscheck=False)
def _compact(buf, jobs, counts, starts, out):
    for q in prange(len(jobs)):
        src, dst = jobs[q, 5], starts[q]
        for k in range(3 * counts[q]):
            out[dst + k] = buf[src + k]


class TriangleCuller:
    """Per-scene state of the exact culler: vertices, faces and clusters of all meshes
    concatenated, with scratch arrays reused from frame to frame."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, mesh_vbase: np.ndarray, mesh_nverts: np.ndarray,
                 mesh_fbase: np.ndarray, mesh_nfaces: np.ndarray, mesh_cbase: np.ndarray,
                 centres: np.ndarray, radii: np.ndarray, vrange: np.ndarray) -> None:
        self.vertices, self.faces = vertices, faces
        self.mesh_vbase, self.mesh_nverts = mesh_vbase, mesh_nverts
        self.mesh_fbase, self.mesh_nfaces, self.mesh_cbase = mesh_fbase, mesh_nfaces, mesh_cbase
        self.centres, self.radii, self.vrange = centres, radii, vrange
        self._window = np.empty((0, 4))
        self._buf = np.empty(0, np.uint32)
        self._out = np.empty(0, np.uint32)

    def select(self, slots: np.ndarray, mesh: np.ndarray, backcull: np.ndarray, cfm: np.ndarray, K: np.ndarray,
               width: int, height: int, near: float, planes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Indices of the kept faces of instances ``slots`` (whose meshes are ``mesh``; those
        flagged in ``backcull`` are drawn with back-face culling), instance after instance;
        returns (indices uint32, first index per slot, index count per slot)."""
        nv, nf = self.mesh_nverts[mesh], self.mesh_nfaces[mesh]
        scratch_at = np.concatenate([[0], np.cumsum(nv)[:-1]]).astype(np.int64)
        total_v = int(nv.sum())
        if len(self._window) < total_v:
            self._window = np.empty((total_v, 4))
        proj = np.array([K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]], dtype=np.float64)
        # one job per cluster of each instance
        nclus = -(-nf // CLUSTER)
        job_inst = np.repeat(np.arange(len(slots)), nclus)
        first_job = np.concatenate([[0], np.cumsum(nclus)[:-1]]).astype(np.int64)
        k = np.arange(len(job_inst)) - first_job[job_inst]
        jobs = np.empty((len(job_inst), 7), np.int64)
        jobs[:, 0] = slots[job_inst]
        jobs[:, 1] = self.mesh_fbase[mesh][job_inst] + k * CLUSTER
        jobs[:, 2] = np.minimum(CLUSTER, nf[job_inst] - k * CLUSTER)
        jobs[:, 3] = self.mesh_vbase[mesh][job_inst]
        jobs[:, 4] = self.mesh_cbase[mesh][job_inst] + k
        jobs[:, 5] = 3 * np.concatenate([[0], np.cumsum(jobs[:-1, 2])]) if len(jobs) else 0
        jobs[:, 6] = scratch_at[job_inst]
        total_i = 3 * int(nf.sum())
        if len(self._buf) < total_i:
            self._buf = np.empty(total_i, np.uint32)
            self._out = np.empty(total_i, np.uint32)
        counts = np.empty(len(jobs), np.int64)
        # threads only for big frames: a parallel launch costs a wake-up of every thread,
        # milliseconds when the machine is busy
        threads = numba.get_num_threads()
        if threads > 1 and total_i < 3 * PARALLEL_FACES:
            numba.set_num_threads(1)
        starts = np.zeros(len(jobs) + 1, np.int64)
        try:
            _select(self.vertices, self.faces, jobs, cfm, backcull[job_inst], self.centres, self.radii,
                    self.vrange, proj, planes, float(near), float(width), float(height), self._window, self._buf,
                    counts)
            np.cumsum(3 * counts, out=starts[1:])
            _compact(self._buf, jobs, counts, starts, self._out)
        finally:
            numba.set_num_threads(threads)
        per_slot = np.add.reduceat(3 * counts, first_job) if len(jobs) else np.zeros(0, np.int64)
        return self._out[:starts[-1]], starts[first_job], per_slot
