"""Which triangle each pixel of a pinhole frame shows, and the geometry to intersect it.

A distorted lens's image is resampled from pinhole views (:mod:`genie_gl.sensors.distortion`);
for labels exact per pixel ray, each lens pixel's own ray is intersected with the triangles
its view shows (:mod:`genie_gl.sensors.ray_hits`). The renderer fills this record when asked
(``Renderer.render(..., triangles=True)``): per pixel, the draw slot and the triangle within
that draw (one more RG32UI target); per frame, what turns that pair into the triangle's three
vertices in the camera frame, in float64; per scene, the meshes' faces and which of them meet
at each point (so that a ray near a triangle the view shows can also try the faces around
it: slivers too thin to cover any pixel centre). Nothing here is made for a frame that does
not ask.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class SceneTriangles:
    """A scene's meshes as the renderer uploaded them (every mesh once, concatenated).

    Attributes
    ----------
    vertices : (V, 3) float32, each mesh's vertices in its model frame, mesh after mesh.
    faces : (F, 3) uint32, each mesh's faces, vertex ids within their own mesh.
    point : (V,) int32, the point of each vertex: the vertices of one mesh at one position are
        one point (a mesh may store a vertex more than once: split along seams, or by the
        renderer's clusters); -1 for a vertex no face uses.
    ring_start : (P + 1,) int64 and ring_faces : (3 F,) int32: the faces (rows of ``faces``)
        that meet at point p are ``ring_faces[ring_start[p]:ring_start[p + 1]]``.
    """

    vertices: np.ndarray
    faces: np.ndarray
    point: np.ndarray
    ring_start: np.ndarray
    ring_faces: np.ndarray

    @classmethod
    def build(cls, vertices: np.ndarray, faces: np.ndarray, vbase: np.ndarray, fbase: np.ndarray,
              nfaces: np.ndarray) -> "SceneTriangles":
        """The record of meshes concatenated as ``vertices`` and ``faces`` (mesh i's faces are
        rows ``fbase[i]:fbase[i] + nfaces[i]``, its vertices start at row ``vbase[i]``)."""
        vertices = np.ascontiguousarray(vertices, np.float32)
        faces = np.ascontiguousarray(faces, np.uint32)
        F, V = len(faces), len(vertices)
        nfaces = np.asarray(nfaces, np.int64)
        by_row = np.argsort(np.asarray(fbase, np.int64), kind="stable")
        mesh = np.repeat(by_row, nfaces[by_row])                   # each face's mesh
        if len(mesh) != F:
            raise ValueError(f"SceneTriangles.build: nfaces add up to {len(mesh)}, faces has {F} rows")
        used = (faces.astype(np.int64) + np.asarray(vbase, np.int64)[mesh][:, None]).ravel()
        # one point per (mesh, position): the position's float32 bits (+0.0 turns -0.0 into 0.0)
        rows = np.zeros((V, 4), np.uint32)
        rows[:, :3] = (vertices + np.float32(0.0)).view(np.uint32)
        rows[used, 3] = np.repeat(mesh, 3)
        seen = np.zeros(V, bool)
        seen[used] = True
        point = np.full(V, -1, np.int32)
        key = np.ascontiguousarray(rows[seen]).view(np.dtype((np.void, 16))).ravel()
        _, inverse = np.unique(key, return_inverse=True)
        point[seen] = inverse.ravel()
        P = int(inverse.max()) + 1 if len(inverse) else 0
        at = point[used]
        start = np.zeros(P + 1, np.int64)
        np.cumsum(np.bincount(at, minlength=P), out=start[1:])
        return cls(vertices, faces, point, start, (np.argsort(at, kind="stable") // 3).astype(np.int32))


@dataclass(frozen=True, eq=False)
class PixelTriangles:
    """The triangle each pixel of one pinhole frame shows.

    Attributes
    ----------
    pixel : (H, W, 2) uint32, per pixel (draw slot + 1, triangle within that slot's draw);
        (0, 0) where no triangle was drawn. Written for every fragment that won the depth
        test, nearer than the sensor's minimum range or beyond its maximum too.
    first : (S,) int64, per slot, its draw's first triangle in ``indices`` (-1: not drawn).
    count : (S,) int64, per slot, its draw's triangles (0: not drawn).
    base_vertex : (S,) int64, per slot, the row of ``scene.vertices`` its mesh starts at.
    backcull : (S,) bool, per slot, drawn with back-face culling (its back faces show nothing).
    camera_from_model : (S, 3, 4) float64, per slot.
    indices : (3 T,) uint32, the frame's index buffer (vertex ids within each mesh).
    instance : (S,) uint32 and semantic : (S,) uint16, per slot, its ids.
    scene : SceneTriangles, the meshes.
    clip_near_m : float, the z of the GPU's near plane: nothing nearer was drawn.
    """

    pixel: np.ndarray
    first: np.ndarray
    count: np.ndarray
    base_vertex: np.ndarray
    backcull: np.ndarray
    camera_from_model: np.ndarray
    indices: np.ndarray
    instance: np.ndarray
    semantic: np.ndarray
    scene: SceneTriangles
    clip_near_m: float

    def __post_init__(self) -> None:
        S = len(self.first)
        checks = [("pixel", self.pixel, None, np.uint32), ("first", self.first, (S,), np.int64),
                  ("count", self.count, (S,), np.int64), ("base_vertex", self.base_vertex, (S,), np.int64),
                  ("backcull", self.backcull, (S,), np.bool_),
                  ("camera_from_model", self.camera_from_model, (S, 3, 4), np.float64),
                  ("indices", self.indices, None, np.uint32), ("instance", self.instance, (S,), np.uint32),
                  ("semantic", self.semantic, (S,), np.uint16)]
        for name, arr, shape, dtype in checks:
            if arr.dtype != dtype or (shape is not None and arr.shape != shape):
                raise ValueError(f"PixelTriangles.{name}: expected {shape or ''} {np.dtype(dtype).name}, "
                                 f"got {arr.shape} {arr.dtype}")
        if self.pixel.ndim != 3 or self.pixel.shape[2] != 2:
            raise ValueError(f"PixelTriangles.pixel: expected (H, W, 2), got {self.pixel.shape}")

    def vertices_of(self, v: int, u: int) -> np.ndarray | None:
        """(3, 3) float64: the camera-frame vertices (rows) of the triangle pixel (v, u)
        shows, or None where it shows none."""
        slot1, prim = (int(x) for x in self.pixel[v, u])
        if slot1 == 0:
            return None
        s = slot1 - 1
        at = 3 * (int(self.first[s]) + prim)
        p = self.scene.vertices[self.base_vertex[s] + self.indices[at:at + 3].astype(np.int64)].astype(np.float64)
        m = self.camera_from_model[s]
        return p @ m[:, :3].T + m[:, 3]
