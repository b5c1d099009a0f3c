"""The CPU rasteriser: per pixel centre, the nearest triangle along its ray (numba, parallel).

:class:`~genie_gl.render.cpu.renderer.CPURenderer` (what ``Renderer(scene, raster="cpu")``
makes) draws with this instead of OpenGL. It visits the same
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

Where a pixel's winner is decided: :func:`~genie_gl.render.cpu.coverage._wins`, the one
depth test, for every hit of every triangle: the nearest float64 depth wins; ties (equal
float64 z) go to the lower (instance slot, face). The winners are handed on as
:class:`~genie_gl.render.fragments.Fragments` (1 / z and slot << 32 | face per pixel) and
shaded by :mod:`genie_gl.render.shading`. Each thread draws column
strips of its own (no pixel is written by two threads), so a frame does not depend on the
number of threads or on the order the clusters are visited.

What this gives against the OpenGL raster: depth exact along each pixel's ray (the GL path
interpolates float32 eye coordinates over a snapped triangle), coverage decided at the pixel
centre in float64 (GL: sub-pixel fixed point and its fill rule), no GL context, no clear and
no read-back. Sub-pixel triangles, most of a scene of millions, cost a box test each.

This module runs a frame (which clusters may show, nearest first, which thread draws which
columns) and fills the frame's arrays; :mod:`genie_gl.render.cpu.coverage` draws one cluster.
"""

from __future__ import annotations

import copy
import math

import numba
import numpy as np

from ...jit import njit, prange, serial_copy
from ..clusters import CLUSTER
from ..geometry import DepthBuffers, FrameInstances, IdsOut, SceneGeometry, View, projection
from ..shading import in_range_f32
from .bins import PIXEL_CENTRES, Samples
from .bounds import _bound_cluster
from .coverage import SHIFT, TILE, Centres, Scratch, draw_strip

PARALLEL_FACES = 5_000  # below this many faces in view, one thread draws a frame


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
def _raster(geo, inst, view, samples, T, zb, who, tmin, tally, cull, ids_out):
    """Draw the clusters of the visible instances ``inst`` (a
    :class:`~genie_gl.render.geometry.FrameInstances`: jobs job0[q]..job0[q+1] are instance
    q's) of the scene ``geo`` (:class:`~genie_gl.render.geometry.SceneGeometry`) seen in
    ``view`` (:class:`~genie_gl.render.geometry.View`) nearest first into ``zb`` (float64
    1 / z, 0 where nothing) and ``who`` (slot << 32 | face where ``zb`` holds a hit; not
    cleared, so anything elsewhere), per pixel centre (H x W flattened) or, unless
    ``samples`` is :data:`~genie_gl.render.cpu.bins.PIXEL_CENTRES`, per ray of
    ``samples`` (:class:`~genie_gl.render.cpu.bins.Samples`), with T threads: thread t draws the
    columns of strip t, the strips cut where the clusters' centres split evenly (whole
    tiles), so each thread's occlusion tiles see every occluder of its strip and no pixel is
    written by two. ``ids_out``: an :class:`~genie_gl.render.geometry.IdsOut`, filled per
    strip once it is drawn when its arrays are not of one element."""
    proj, near, width, height = view.proj, view.near, view.width, view.height
    job0 = inst.job0
    ids, sems, near_m, far_m = ids_out.ids, ids_out.sems, ids_out.near_m, ids_out.far_m
    out_depth, out_instance, out_semantic = ids_out.depth, ids_out.instance, ids_out.semantic
    W = int(width)
    H = int(height)
    cell0 = samples.cell0
    sampled = len(cell0) > 1
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
        alive[j] = _bound_cluster(q, j - job0[q], geo, inst, view, cull, bounds[j])
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
    if sampled:  # (a tile without rays starts hidden)
        tmin[:, :] = samples.tiles
    else:
        tmin[:, :] = 0.0
    buf = DepthBuffers(zb, who, tmin, np.zeros(tmin.shape, np.uint8))
    centres = Centres(xs, ys, sys_)
    tally[:, :] = 0
    for t in prange(T):
        if cut[t] >= cut[t + 1]:
            continue
        col_lo, col_hi = float(cut[t]), float(cut[t + 1] - 1)
        # each thread clears its strip (``who`` is read only where ``zb`` holds a hit)
        for r in range(H):
            if sampled:
                zb[cell0[r * W + cut[t]] : cell0[r * W + cut[t + 1]]] = 0.0
            else:
                zb[r * W + cut[t] : r * W + cut[t + 1]] = 0.0
        work = Scratch(
            np.empty(3 * CLUSTER),
            np.empty(3 * CLUSTER),
            np.empty(3 * CLUSTER),
            np.empty(3 * CLUSTER),
            np.empty(3 * CLUSTER),
            np.empty(3 * CLUSTER, np.uint64),
            np.empty(CLUSTER, np.int64),
            np.empty(4),
        )
        draw_strip(
            order, bounds, whose, job0, col_lo, col_hi, geo, inst, view, centres, samples, buf,
            work, tally[t], cull,
        )  # fmt: skip
        # the strip's depth and ids at once (as :func:`_shade` makes them)
        # (the depths first, in a loop without a branch the compiler vectorises; z > 0
        # wherever it is in range, so the ids follow from the float32 depth)
        if len(out_depth) > 1 and not sampled:
            for r in range(H):
                a, b = r * W + cut[t], r * W + cut[t + 1]
                zr, dr = zb[a:b], out_depth[a:b]
                for i in range(len(zr)):
                    dr[i] = in_range_f32(zr[i], near_m, far_m)
                wr, ir, sr = who[a:b], out_instance[a:b], out_semantic[a:b]
                for i in range(len(zr)):
                    if dr[i] > 0.0:
                        sl = wr[i] >> np.int64(32)
                        ir[i] = ids[sl]
                        sr[i] = sems[sl]
                    else:
                        ir[i] = 0
                        sr[i] = 0


# the same kernel on the calling thread alone (frames drawn side by side, one per thread)
_raster_serial = serial_copy(_raster, "_raster_serial")


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
        boxes = _cluster_boxes(
            culler.vertices,
            culler.clusters[2],
            culler.mesh_vbase,
            culler.mesh_cbase,
            -(-culler.mesh_nfaces // CLUSTER),
        )
        self.geometry = SceneGeometry(
            *(np.ascontiguousarray(culler.vertices[:, a]) for a in range(3)),  # float32, per axis
            culler.faces,
            *boxes,
            *culler.clusters,
        )
        self.counts = np.zeros(8, np.int64)  # the last frame's tally (see _draw_cluster)

    def twin(self) -> Rasteriser:
        """A rasteriser of the same scene (its arrays shared, not copied) with buffers of
        its own: for a frame drawn while this one draws another."""
        twin = copy.copy(self)
        twin._buffers, twin.tally = None, np.zeros_like(self.tally)
        twin.counts = np.zeros_like(self.counts)
        return twin

    def face_vbase(
        self, mesh_vbase: np.ndarray, mesh_fbase: np.ndarray, mesh_nfaces: np.ndarray
    ) -> np.ndarray:
        """(F,) int64: per face of the joined arrays, the first vertex row of its mesh."""
        if self._face_vbase is None:
            out = np.zeros(len(self.culler.faces), np.int64)
            for vb, fb, nf in zip(mesh_vbase, mesh_fbase, mesh_nfaces):
                out[fb : fb + nf] = vb
            self._face_vbase = out
        return self._face_vbase

    def draw(
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
        cull: bool = True,
        ids_out: tuple | None = None,
        samples: Samples = PIXEL_CENTRES,
        serial: bool = False,
    ) -> tuple[np.ndarray, np.ndarray]:
        """(inverse depth, hit): per pixel (H*W) 1 / z of the nearest hit (float64, 0: nothing) at
        or beyond
        ``near`` and its (slot << 32 | face) where the inverse depth is not 0; arguments as
        :meth:`genie_gl.render.cull.TriangleCuller.select`; ``cull=False`` tests every face
        against every pixel centre of its box (the reference, slow). ``ids_out``: (ids,
        semantic ids, near_m, far_m, frame arrays) for a frame of depth and ids alone, which
        each thread then fills for its strip as :meth:`shade` would (no :meth:`shade` after).
        ``samples``: the frame's rays when they are not its pixel centres
        (:class:`~genie_gl.render.cpu.bins.Samples`, binned on this ``K``'s pixel grid):
        then the two arrays hold a value per ray, in the samples' order. ``serial``: draw on
        the calling thread alone (no parallel launch: other threads may draw other frames at
        the same time, each with a rasteriser of its own)."""
        c = self.culler
        nf = c.mesh_nfaces[mesh]
        nclus = -(-nf // CLUSTER)
        job0 = np.zeros(len(slots) + 1, np.int64)
        np.cumsum(nclus, out=job0[1:])
        proj = projection(K)
        threads = numba.get_num_threads()
        T = 1 if serial or threads == 1 or int(nf.sum()) < PARALLEL_FACES else threads
        sampled = len(samples.cell0) > 1
        npx = samples.xy.shape[1] if sampled else width * height
        tiles = samples.tiles.shape if sampled else (-(-height // TILE), -(-width // TILE))
        buf = self._buffers
        if buf is None or buf[0].shape != (npx,) or buf[2].shape != tiles:
            buf = self._buffers = (np.empty(npx), np.empty(npx, np.int64), np.empty(tiles))
        depth, hit, tmin = buf
        inst = FrameInstances(
            slots.astype(np.int64),
            c.mesh_vbase[mesh],
            c.mesh_fbase[mesh],
            nf,
            c.mesh_cbase[mesh],
            job0,
            np.ascontiguousarray(backcull),
            cfm,
            np.ascontiguousarray(eye, np.float64),
            np.ascontiguousarray(det, np.float64),
        )
        view = View(proj, planes, float(near), float(width), float(height))
        (_raster_serial if serial else _raster)(
            self.geometry,
            inst,
            view,
            samples,
            T,
            depth,
            hit,
            tmin,
            self.tally[:T],
            bool(cull),
            self._ids_out(ids_out),
        )
        self.counts = self.tally[:T].sum(axis=0)
        return depth, hit

    @staticmethod
    def _ids_out(ids_out: tuple | None) -> IdsOut:
        """:func:`_raster`'s ``ids_out`` (one-element arrays: no strip shading)."""
        if ids_out is None:
            return IdsOut(
                np.zeros(1, np.uint32),
                np.zeros(1, np.uint32),
                0.0,
                0.0,
                np.zeros(1, np.float32),
                np.zeros(1, np.uint32),
                np.zeros(1, np.uint16),
            )
        ids, sems, near_m, far_m, out = ids_out
        return IdsOut(
            ids,
            sems,
            float(near_m),
            float(far_m),
            out["depth"].reshape(-1),
            out["instance"].reshape(-1),
            out["semantic"].reshape(-1),
        )
