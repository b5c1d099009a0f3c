"""Whether a mesh is one closed convex body, decided once per mesh (the planner's scene analysis).

A closed convex mesh cannot see itself: no ray leaves one of its faces and meets another, so
effects of light bouncing between its surfaces (multipath) have nothing to do in a view of it
alone. The test is trimesh's (``Trimesh.is_convex`` after processing), compiled and linear in
the faces, with no ``Trimesh`` built:

* vertices merged where they coincide (one sort of the vertices);
* closed and consistently wound: each directed edge a->b appears once, and so does b->a;
* one connected body (faces joined across their edges);
* locally convex: across every edge, the far vertex of the neighbouring face lies below the
  plane of the face by more than ``PLANAR`` times the mesh's size (its box diagonal), counting
  only pairs of faces of non-zero area.

(A closed mesh whose faces are wound inconsistently is called not convex here, where trimesh
may say convex: the planner then keeps the effect, which costs time, never a wrong frame.)

:func:`is_convex` keeps its answer per mesh object (a ``Mesh`` never changes), so a scene
planned again, or a mesh placed in many scenes, is analysed once.
"""

from __future__ import annotations

import math
import weakref

import numpy as np

from ..jit import njit
from .model import Mesh

PLANAR = 1e-5  # trimesh's tol.planar: local convexity threshold, relative to the mesh's size
ZERO_AREA = 1e-12  # trimesh's tol.zero: faces of less area take no part in the local test

_CACHE: "weakref.WeakKeyDictionary[Mesh, bool]" = weakref.WeakKeyDictionary()
_BY_CONTENT: dict[str, bool] = {}  # by Mesh.digest(): the same geometry in a new Mesh (a new scene)
_BY_CONTENT_MAX = 4096


@njit(cache=True, nogil=True)
def _find(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(cache=True, nogil=True, boundscheck=False)
def _closed_convex(v, f, planar, zero_area):
    n, nf = len(v), len(f)
    # directed edges bucketed by their first vertex (a counting sort: linear)
    start = np.zeros(n + 1, np.int64)
    for t in range(nf):
        for k in range(3):
            start[f[t, k] + 1] += 1
    for i in range(n):
        start[i + 1] += start[i]
    fill = start[:-1].copy()
    dst = np.empty(3 * nf, np.int64)
    face = np.empty(3 * nf, np.int64)
    for t in range(nf):
        for k in range(3):
            a, b = f[t, k], f[t, (k + 1) % 3]
            dst[fill[a]] = b
            face[fill[a]] = t
            fill[a] += 1
    parent = np.arange(nf)
    unit = np.empty((nf, 3))
    big = np.empty(nf, np.bool_)
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for t in range(nf):
        a, b, c = f[t, 0], f[t, 1], f[t, 2]
        e1 = v[b] - v[a]
        e2 = v[c] - v[a]
        nx = e1[1] * e2[2] - e1[2] * e2[1]
        ny = e1[2] * e2[0] - e1[0] * e2[2]
        nz = e1[0] * e2[1] - e1[1] * e2[0]
        norm = math.sqrt(nx * nx + ny * ny + nz * nz)
        big[t] = norm / 2 > zero_area
        s = 1.0 / norm if norm > 0 else 0.0
        unit[t, 0], unit[t, 1], unit[t, 2] = nx * s, ny * s, nz * s
        for k in range(3):
            for d in range(3):
                lo[d] = min(lo[d], v[f[t, k], d])
                hi[d] = max(hi[d], v[f[t, k], d])
    scale = math.sqrt((hi[0] - lo[0]) ** 2 + (hi[1] - lo[1]) ** 2 + (hi[2] - lo[2]) ** 2)
    worst = -np.inf
    pairs = 0
    for a in range(n):
        for e in range(start[a], start[a + 1]):
            b = dst[e]
            # this edge once from a, its reverse once from b
            same = 0
            for g in range(start[a], start[a + 1]):
                if dst[g] == b:
                    same += 1
            if same != 1:
                return False
            across = -1
            for g in range(start[b], start[b + 1]):
                if dst[g] == a:
                    if across >= 0:
                        return False
                    across = face[g]
            if across < 0:
                return False
            t = face[e]
            ra, rb = _find(parent, t), _find(parent, across)
            if ra != rb:
                parent[ra] = rb
            if big[t] and big[across]:
                far = f[across, 0]
                for k in range(3):
                    if f[across, k] != a and f[across, k] != b:
                        far = f[across, k]
                p = (
                    (v[far, 0] - v[a, 0]) * unit[t, 0]
                    + (v[far, 1] - v[a, 1]) * unit[t, 1]
                    + (v[far, 2] - v[a, 2]) * unit[t, 2]
                )
                worst = max(worst, p)
                pairs += 1
    root = _find(parent, 0)
    for t in range(nf):
        if _find(parent, t) != root:
            return False
    return pairs > 0 and worst < planar * scale


def convex_arrays(vertices: np.ndarray, faces: np.ndarray) -> bool:
    """True when the triangles (vertices (V, 3), faces (F, 3)) form one closed convex body."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64).reshape(-1, 3)
    if len(f) < 4 or not np.isfinite(v).all():
        return False
    # merge coincident vertices (what trimesh's processing does)
    order = np.lexsort(v.T[::-1])
    new = np.ones(len(v), bool)
    new[1:] = (v[order[1:]] != v[order[:-1]]).any(axis=1)
    merged = np.empty(len(v), np.int64)
    merged[order] = np.cumsum(new) - 1
    f = merged[f]
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 2] != f[:, 0])]
    if len(f) < 4:
        return False
    return bool(_closed_convex(v[order[new]], np.ascontiguousarray(f), PLANAR, ZERO_AREA))


def is_convex(mesh: Mesh) -> bool:
    """True for a closed convex mesh, or a single triangle (no surface of it faces another);
    decided once per mesh object, and once per geometry (a new ``Mesh`` of the same vertices
    and faces, as a new scene of the same assets makes, finds the answer by its digest)."""
    if len(mesh.faces) < 4:
        return len(mesh.faces) <= 1
    known = _CACHE.get(mesh)
    if known is None:
        digest = mesh.digest()  # ~0.1 ms against ~2 ms for the test of a 5,120-face sphere
        known = _BY_CONTENT.get(digest)
        if known is None:
            known = convex_arrays(mesh.vertices, mesh.faces)
            if len(_BY_CONTENT) >= _BY_CONTENT_MAX:
                _BY_CONTENT.clear()
            _BY_CONTENT[digest] = known
        _CACHE[mesh] = known
    return known
