"""Rays that are not pixel centres, binned for the CPU raster: a distorted lens's pixel rays.

A frame of the CPU raster is drawn against the rays of a pinhole grid's pixel centres, or
against any rays of a view's frame binned on such a grid (:class:`Samples`): a face is then
tested against the rays of the bins of its box (:func:`genie_gl.render.cpu.coverage._draw_cluster`).
:func:`lens_samples` bins a lens's pixel rays on a grid of each view that holds them
(:func:`genie_gl.lens.distortion.lens_views`: one front view, or the faces of a cube around
the camera for a fisheye past ~150 degrees), so that
:meth:`~genie_gl.render.cpu.renderer.CPURenderer._lens_frame` draws the lens's frame with the
raster's own kernel and winner rule.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...lens.distortion import DistortionMaps
from .coverage import SHIFT, TILE


class Samples(NamedTuple):
    """Rays binned on a view's pixel grid, for a frame whose rays are not its pixel centres (a
    lens's own pixel rays, seen through a pinhole view that holds them). Cell (u, v) of the
    view, the positions [u, u + 1) x [v, v + 1) in its pixels, holds rays ``cell0[v W + u]``
    to ``cell0[v W + u + 1] - 1``; ray i is ``(xy[0, i], xy[1, i], 1)`` in the view frame, and its
    winner is written at row i of the depth buffers. :data:`PIXEL_CENTRES` (``cell0`` of one
    element) stands for the view's own pixel centres (:class:`Centres`).

    Attributes
    ----------
    cell0 : (H W + 1,) int32, each cell's first ray.
    xy : (2, N) float64, the rays' x and y on the view's z = 1 plane, cell after cell (a
        row per coordinate: the kernel's loop over a row of cells reads both contiguously).
    tiles : (ceil(H / 2**vshift), ceil(W / TILE)) float64, what each occlusion tile of the
        grid (TILE bins wide, 2 ** ``vshift`` tall) starts a frame with: 0 (nothing drawn
        yet), inf where the tile holds no ray (nothing there can be seen: a face whose box
        covers only such tiles is skipped).
    vshift : int, log2 of an occlusion tile's height in bins (:func:`lens_samples` makes a
        tile TILE x TILE view pixels, as for pixel centres: taller tiles hide fewer faces).
    """

    cell0: np.ndarray
    xy: np.ndarray
    tiles: np.ndarray
    vshift: int


PIXEL_CENTRES = Samples(np.zeros(1, np.int32), np.zeros((2, 1)), np.zeros((1, 1)), 0)


class LensSamples(NamedTuple):
    """A lens's pixel rays that one of its pinhole views holds, binned on that view's pixel
    grid for the raster: ``samples`` (:class:`~genie_gl.render.cpu.coverage.Samples`, rays in
    the view frame on z = 1), ``ray_of`` (H W,) int64 per lens pixel its ray's row of the
    samples (-1: this view does not serve it), ``pixel`` (N,) int64 the lens pixel (row-major)
    of each ray, in the samples' order, and ``z_scale`` (N,) float64 the camera z per view z
    along each ray (None for the front view, whose z is the camera's), ``grid`` (K, width,
    height) the bins: the pinhole grid of the view's frame the raster draws on."""

    samples: Samples
    ray_of: np.ndarray
    pixel: np.ndarray
    z_scale: np.ndarray | None
    grid: tuple[np.ndarray, int, int]


def unserved(views: tuple[DistortionMaps, ...]) -> np.ndarray:
    """(k,) int64: the lens pixels (row-major) no view serves (they have no ray); cached."""
    got = views[0].cache.get("unserved")
    if got is None:
        served = np.zeros(views[0].valid.size, bool)
        for m in views:
            served |= m.valid.ravel()
        got = views[0].cache["unserved"] = np.flatnonzero(~served)
    return got


# a bin is one view pixel wide and about this many radians of the view's frame tall (a power
# of two of its pixels, BIN_ROWS at most and at least): the faces of a scene are as large in
# angle whatever the lens, so bins of one angle hold as many of them. Taller bins test more
# rays a face and visit fewer rows of bins; on the benchmark scenes, bins of 8 rows of the
# tutorial lens's view (f 536 px) cost 0.8-0.9x those of 4, and 1.1-1.2x for a fisheye's cube
# faces (f 230 px), whose 4 rows span about the same angle as 8 of the tutorial lens's
BIN_RAD = 0.015
BIN_ROWS = (4, 8)


def bin_rows(fy: float) -> int:
    """A bin's height in the pixels of a view of focal length ``fy`` (px): the power of two
    nearest to ``fy`` :data:`BIN_RAD`, within :data:`BIN_ROWS`."""
    rows = 2 ** round(np.log2(max(fy * BIN_RAD, 1.0)))
    return int(min(max(rows, BIN_ROWS[0]), BIN_ROWS[1]))


def _empty_tiles(cell: np.ndarray, W: int, H: int, vshift: int) -> np.ndarray:
    """:attr:`Samples.tiles` of rays in bins ``cell`` (row-major on a W x H grid), tiles
    2 ** ``vshift`` bins tall: 0 where an occlusion tile holds a ray, inf elsewhere."""
    tiles = np.full((-(-H >> vshift), -(-W // TILE)), np.inf)
    tiles[(cell // W) >> vshift, (cell % W) // TILE] = 0.0
    return tiles


def lens_samples(maps: DistortionMaps) -> LensSamples:
    """The rays of the lens pixels ``maps`` serves, binned on a grid of the view's frame (its
    :attr:`LensSamples.grid`: a pinhole K whose pixels, the bins, are one view pixel wide and
    :func:`bin_rows` tall, so as large as the view at most; a ray crossing it at (x, y) goes to
    the bin (floor x, floor y)), each bin's rays in row-major pixel order, the occlusion tiles
    TILE x TILE view pixels; computed once per view (kept in ``maps.cache``)."""
    got = maps.cache.get("lens_samples")
    if got is not None:
        return got
    sel = np.flatnonzero(maps.valid.ravel())
    rx, ry = maps.ray_x.ravel()[sel], maps.ray_y.ravel()[sel]
    H, W = maps.valid.shape
    # the view's own pixels (the lens's focal length, every ray at least a pixel inside, and at
    # most MAX_VIEW_PX a side: :func:`genie_gl.lens.distortion.lens_views`), 1 x rows to a bin
    view = maps.render_sensor
    rows = bin_rows(view.K[1, 1])
    vshift = SHIFT - int(np.log2(rows))
    fx, fy = view.K[0, 0], view.K[1, 1] / rows
    cx, cy = view.K[0, 2], view.K[1, 2] / rows
    Wg, Hg = view.width, -(-view.height // rows)
    K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    cu = np.clip(np.floor(fx * rx + cx), 0, Wg - 1).astype(np.int64)
    cv = np.clip(np.floor(fy * ry + cy), 0, Hg - 1).astype(np.int64)
    cell = cv * Wg + cu
    order = np.argsort(cell, kind="stable")
    cell0 = np.zeros(Wg * Hg + 1, np.int32)
    np.cumsum(np.bincount(cell, minlength=Wg * Hg), out=cell0[1:])
    zs = None if maps.z_scale is None else maps.z_scale.ravel()[sel][order]
    ray_of = np.full(H * W, -1, np.int64)
    ray_of[sel[order]] = np.arange(len(sel))
    got = LensSamples(
        Samples(
            cell0, np.stack([rx[order], ry[order]]), _empty_tiles(cell, Wg, Hg, vshift), vshift
        ),
        ray_of,
        sel[order],
        zs,
        (K, Wg, Hg),
    )
    maps.cache["lens_samples"] = got
    return got
