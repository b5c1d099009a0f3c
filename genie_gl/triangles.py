"""Which triangle each pixel of a pinhole frame shows, and the geometry to intersect it.

A distorted lens's image is resampled from pinhole views (:mod:`genie_gl.sensors.distortion`);
for labels exact per pixel ray, each lens pixel's own ray is intersected with the triangles
its view shows (:mod:`genie_gl.sensors.ray_hits`). The renderer fills this record when asked
(``Renderer.render(..., triangles=True)``): per pixel, the draw slot and the triangle within
that draw (one more RG32UI target); per frame, what turns that pair into the triangle's three
vertices in the camera frame, in float64. Nothing here is made for a frame that does not ask.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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
    base_vertex : (S,) int64, per slot, the row of ``vertices`` its mesh starts at.
    camera_from_model : (S, 3, 4) float64, per slot.
    indices : (3 T,) uint32, the frame's index buffer (vertex ids within each mesh).
    instance : (S,) uint32 and semantic : (S,) uint16, per slot, its ids.
    vertices : (V, 3) float32, every mesh's vertices in its model frame (the renderer's).
    """

    pixel: np.ndarray
    first: np.ndarray
    count: np.ndarray
    base_vertex: np.ndarray
    camera_from_model: np.ndarray
    indices: np.ndarray
    instance: np.ndarray
    semantic: np.ndarray
    vertices: np.ndarray

    def __post_init__(self) -> None:
        S = len(self.first)
        checks = [("pixel", self.pixel, None, np.uint32), ("first", self.first, (S,), np.int64),
                  ("count", self.count, (S,), np.int64), ("base_vertex", self.base_vertex, (S,), np.int64),
                  ("camera_from_model", self.camera_from_model, (S, 3, 4), np.float64),
                  ("indices", self.indices, None, np.uint32), ("instance", self.instance, (S,), np.uint32),
                  ("semantic", self.semantic, (S,), np.uint16), ("vertices", self.vertices, None, np.float32)]
        for name, arr, shape, dtype in checks:
            if arr.dtype != dtype or (shape is not None and arr.shape != shape):
                raise ValueError(f"PixelTriangles.{name}: expected {shape or ''} {np.dtype(dtype).name}, "
                                 f"got {arr.shape} {arr.dtype}")
        if self.pixel.ndim != 3 or self.pixel.shape[2] != 2:
            raise ValueError(f"PixelTriangles.pixel: expected (H, W, 2), got {self.pixel.shape}")
        if self.vertices.ndim != 2 or self.vertices.shape[1] != 3:
            raise ValueError(f"PixelTriangles.vertices: expected (V, 3), got {self.vertices.shape}")

    def vertices_of(self, v: int, u: int) -> np.ndarray | None:
        """(3, 3) float64: the camera-frame vertices (rows) of the triangle pixel (v, u)
        shows, or None where it shows none."""
        slot1, prim = (int(x) for x in self.pixel[v, u])
        if slot1 == 0:
            return None
        s = slot1 - 1
        at = 3 * (int(self.first[s]) + prim)
        p = self.vertices[self.base_vertex[s] + self.indices[at:at + 3].astype(np.int64)].astype(np.float64)
        m = self.camera_from_model[s]
        return p @ m[:, :3].T + m[:, 3]
