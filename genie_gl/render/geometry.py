"""The records the CPU raster's kernels read: a scene's uploaded clusters, one frame's drawn
instances, its view, and the buffers a frame is drawn into.

Each is a :class:`typing.NamedTuple` of arrays and numbers: numba takes one as a single
argument (a tuple of the same types, its fields read by name, no copy), and a kernel that
takes it is cached on disk like any other. They replace the kernels' long positional
argument lists; the arithmetic on their fields is unchanged.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class SceneGeometry(NamedTuple):
    """A scene's meshes as uploaded, mesh after mesh, and their clusters
    (:mod:`genie_gl.render.clusters`), concatenated.

    Attributes
    ----------
    X, Y, Z : (V,) float32, the vertices' model-frame coordinates, one array per axis.
    faces : (F, 3) uint32, vertex ids within each face's own mesh.
    lo, hi : (C, 3) float64, each cluster's box in its model frame.
    centre : (C, 3) float64 and radius : (C,) float64, each cluster's bounding sphere.
    vrange : (C, 2) int64, each cluster's vertex rows within its mesh.
    axis : (C, 3) float64, cos_a, sin_a : (C,) float64, each cluster's normal cone.
    thickness, perimeter : (C,) float64, its thinnest face's height and least perimeter.
    """

    X: np.ndarray
    Y: np.ndarray
    Z: np.ndarray
    faces: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    centre: np.ndarray
    radius: np.ndarray
    vrange: np.ndarray
    axis: np.ndarray
    cos_a: np.ndarray
    sin_a: np.ndarray
    thickness: np.ndarray
    perimeter: np.ndarray


class FrameInstances(NamedTuple):
    """The Q instances a frame draws, in draw order (:class:`~genie_gl.render.visibility.Seen`
    turned into the kernels' arrays).

    Attributes
    ----------
    slot : (Q,) int64, each one's slot (its row of ``camera_from_model``).
    vbase, fbase : (Q,) int64, its mesh's first vertex and face row in the joined arrays.
    nfaces : (Q,) int64, its mesh's faces.
    cbase : (Q,) int64, its mesh's first cluster.
    job0 : (Q + 1,) int64, cumulative cluster counts: instance q's clusters are the frame's
        jobs ``job0[q]`` to ``job0[q + 1]``.
    backcull : (Q,) bool, drawn with back-face culling.
    camera_from_model : (N, 3, 4) float64, per slot (every slot, drawn or not).
    eye : (Q, 3) float64, the camera centre in each one's model frame.
    det : (Q,) float64, the determinant of each one's camera_from_model.
    """

    slot: np.ndarray
    vbase: np.ndarray
    fbase: np.ndarray
    nfaces: np.ndarray
    cbase: np.ndarray
    job0: np.ndarray
    backcull: np.ndarray
    camera_from_model: np.ndarray
    eye: np.ndarray
    det: np.ndarray


class View(NamedTuple):
    """A pinhole frame's view: the rays are the pixel centres ``K^-1 (u, v, 1)``.

    Attributes
    ----------
    proj : (5,) float64, (fx, s, cx, fy, cy) of K.
    planes : (P, 4) float64, the frustum's planes (inside where n·x + d >= 0).
    near : float, m, the near plane: no hit nearer.
    width, height : float, the grid in pixels.
    """

    proj: np.ndarray
    planes: np.ndarray
    near: float
    width: float
    height: float


class DepthBuffers(NamedTuple):
    """What a frame is drawn into (H x W flattened, row-major), and its occlusion tiles.

    Attributes
    ----------
    inverse_z : (H W,) float64, 1 / z of the nearest hit, 0 where nothing.
    winner : (H W,) int64, slot << 32 | face where ``inverse_z`` holds a hit (not cleared:
        anything elsewhere).
    tiles : (H / 8, W / 8) float64, per occlusion tile the least inverse depth it holds.
    dirty : (H / 8, W / 8) uint8, tiles written since their last refresh.
    """

    inverse_z: np.ndarray
    winner: np.ndarray
    tiles: np.ndarray
    dirty: np.ndarray


class IdsOut(NamedTuple):
    """A frame of depth and ids alone, filled by the raster strip by strip as it is drawn
    (one-element arrays: no such pass).

    Attributes
    ----------
    ids : (N,) uint32 and sems : (N,) uint16 or uint32, per slot its instance and semantic id.
    near_m, far_m : float, m, the sensor's range.
    depth : (H W,) float32, instance : (H W,) uint32, semantic : (H W,) uint16, the frame's.
    """

    ids: np.ndarray
    sems: np.ndarray
    near_m: float
    far_m: float
    depth: np.ndarray
    instance: np.ndarray
    semantic: np.ndarray


def projection(K: np.ndarray) -> np.ndarray:
    """(5,) float64: (fx, s, cx, fy, cy) of a pinhole K."""
    return np.array([K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]], dtype=np.float64)
