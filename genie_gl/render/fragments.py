"""What a raster decided for each pixel of one frame, before any shading: the contract of
both rasters (as PyTorch3D's rasteriser hands its ``Fragments`` to a shader).

A frame's rays are its pixel centres (``K^-1 (u, v, 1)``, row-major on the H x W grid), or,
drawn by the CPU raster through a distorted lens, each pixel's own ray (binned on a grid of a
view's frame: :class:`~genie_gl.render.cpu.bins.Samples`; the GL raster draws a lens's pinhole
views, resampled after). Per ray, a raster decides the winner: the triangle (instance slot,
face) nearest along the ray within the near plane, and its view z. Each raster decides it in
one place, with one tie rule:

- ``cpu`` (:func:`genie_gl.render.cpu.coverage._wins`): the nearest float64 depth along
  the ray (exact intersection with the triangle's plane; coverage by float64 edge functions
  at the pixel centre); ties (equal float64 z) go to the lower (instance slot, face).
- ``gl`` (the GPU's depth test, set up in :meth:`genie_gl.render.gl.renderer.GLRenderer._issue`):
  the greatest reversed depth ``near / z`` of a float32 depth buffer (``depth_func ">"``:
  the nearest), coverage by the GPU's fixed-point rasterisation and fill rule; a tie keeps
  the fragment drawn first (back-face-culled instances' draw before the others', each in
  slot order, each instance's triangles in index order).

The raster fills a :class:`Fragments`; :mod:`genie_gl.render.shading` turns it into the
frame's arrays (range applied, ids to semantic ids, colour, normals, the triangle under each
pixel) and the :class:`~genie_gl.frame.Frame`. Where the GL raster's shader computes a
target (colour, normals, the triangle target, and the depth and ids it writes into its
packed target), its fragments hold that target as read back: computing them on the CPU from
the winner would change the GL raster's bytes (float32 interpolation in its shader).

:class:`DrawnTriangles` is the per-slot half of :class:`~genie_gl.triangles.PixelTriangles`:
what turns a pixel's (slot, triangle) into vertices, filled by the raster that drew the
frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np


@dataclass(frozen=True, eq=False)
class Fragments:
    """Per pixel of one frame, the winner its raster decided.

    Attributes
    ----------
    height, width : int, the grid (pixels).
    inverse_z : (H W,) float64 or None, 1 / view z (1/m) of the winning hit, 0 where no
        triangle is hit (the CPU raster; None from the GL raster, whose depth is a target).
    winner : (H W,) int64 or None, slot << 32 | face (face: its row of the scene's joined
        faces) of the winning hit, where ``inverse_z`` is not 0 (anything elsewhere).
    arrays : dict of the frame's arrays (:func:`~genie_gl.render.memory.frame_buffers`):
        the GL raster's targets read back into them (``packed``: float32 view z bits and
        instance id per pixel, or ``depth``, ``instance``, ``semantic``; ``rgba``, ``normal``,
        ``primitive`` as its shader wrote them); from the CPU raster, empty arrays the shading
        fills.
    shaded : bool, whether ``depth``, ``instance`` and ``semantic`` already hold the frame's
        values (the CPU raster fills them strip by strip in a frame of depth and ids alone).
    """

    height: int
    width: int
    inverse_z: np.ndarray | None
    winner: np.ndarray | None
    arrays: dict[str, np.ndarray]
    shaded: bool = False

    @property
    def slot(self) -> np.ndarray:
        """(H W,) int64: the winner's instance slot (valid where ``inverse_z`` is not 0)."""
        return self.winner >> np.int64(32)

    @property
    def face(self) -> np.ndarray:
        """(H W,) int64: the winner's face in the joined faces (valid as :attr:`slot`)."""
        return self.winner & np.int64(0xFFFFFFFF)


class DrawnTriangles(NamedTuple):
    """Per slot, what turns a pixel's (slot + 1, triangle within the slot's draw) into the
    triangle's vertices: the fields of :class:`~genie_gl.triangles.PixelTriangles` after
    ``pixel`` and before ``scene``, in its order.

    Attributes
    ----------
    first : (S,) int64, the draw's first triangle in ``indices`` (-1: not drawn).
    count : (S,) int64, the draw's triangles (0: not drawn).
    base_vertex : (S,) int64, the row of the scene's vertices its mesh starts at.
    backcull : (S,) bool, drawn with back-face culling.
    camera_from_model : (S, 3, 4) float64.
    indices : (3 T,) uint32, the frame's index buffer (vertex ids within each mesh).
    instance : (S,) uint32 and semantic : (S,) uint16, its ids.
    mesh_first, mesh_count : (S,) int64, its mesh's rows of the scene's faces.
    """

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


def no_triangles(ids: np.ndarray, semantic: np.ndarray) -> DrawnTriangles:
    """The :class:`DrawnTriangles` of a frame that draws nothing yet, for slots of instance
    ids ``ids`` (S,) and semantic ids ``semantic`` (S,)."""
    n = len(ids)
    return DrawnTriangles(
        np.full(n, -1, np.int64),
        np.zeros(n, np.int64),
        np.zeros(n, np.int64),
        np.zeros(n, bool),
        np.zeros((n, 3, 4)),
        np.zeros(0, np.uint32),
        ids,
        semantic.astype(np.uint16),
        np.zeros(n, np.int64),
        np.zeros(n, np.int64),
    )
