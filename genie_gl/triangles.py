"""Which triangle each pixel of a pinhole frame shows, and the geometry to intersect it.

A distorted lens's image is resampled from pinhole views (:mod:`genie_gl.lens.distortion`);
for labels exact per pixel ray, each lens pixel's own ray is intersected with the triangles
its view shows (:mod:`genie_gl.lens.ray_hits`). The renderer fills this record when asked
(``Renderer.render(..., triangles=True)``): per pixel, the draw slot and the triangle within
that draw (one more RG32UI target); per frame, what turns that pair into the triangle's three
vertices in the camera frame, in float64 (the frame's index buffer and the scene's
vertices). Nothing here is made for a frame that does not ask.
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
    faces : (F, 3) uint32, each mesh's faces (vertex ids within their own mesh), mesh after mesh.
    """

    vertices: np.ndarray
    faces: np.ndarray

    @classmethod
    def build(cls, vertices: np.ndarray, faces: np.ndarray) -> "SceneTriangles":
        """The record of the meshes' concatenated ``vertices`` and ``faces``."""
        return cls(
            np.ascontiguousarray(vertices, np.float32), np.ascontiguousarray(faces, np.uint32)
        )


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
    mesh_first : (S,) int64 and mesh_count : (S,) int64, per slot, its mesh's rows of
        ``scene.faces`` (every face of the mesh drawn, also those the frame's culling dropped
        because they cover no pixel centre).
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
    mesh_first: np.ndarray
    mesh_count: np.ndarray
    scene: SceneTriangles
    clip_near_m: float

    def __post_init__(self) -> None:
        S = len(self.first)
        checks = [
            ("pixel", self.pixel, None, np.uint32),
            ("first", self.first, (S,), np.int64),
            ("count", self.count, (S,), np.int64),
            ("base_vertex", self.base_vertex, (S,), np.int64),
            ("backcull", self.backcull, (S,), np.bool_),
            ("camera_from_model", self.camera_from_model, (S, 3, 4), np.float64),
            ("indices", self.indices, None, np.uint32),
            ("instance", self.instance, (S,), np.uint32),
            ("semantic", self.semantic, (S,), np.uint16),
            ("mesh_first", self.mesh_first, (S,), np.int64),
            ("mesh_count", self.mesh_count, (S,), np.int64),
        ]
        for name, arr, shape, dtype in checks:
            if arr.dtype != dtype or (shape is not None and arr.shape != shape):
                raise ValueError(
                    f"PixelTriangles.{name}: expected {shape or ''} {np.dtype(dtype).name}, "
                    f"got {arr.shape} {arr.dtype}"
                )
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
        p = self.scene.vertices[
            self.base_vertex[s] + self.indices[at : at + 3].astype(np.int64)
        ].astype(np.float64)
        m = self.camera_from_model[s]
        return p @ m[:, :3].T + m[:, 3]
