"""The free floor: where a moving body fits, as a raster over the layout's bounds.

Placement and trajectories share one definition of what stands on the floor. Without a
scene it is the layout's furnished regions (leaves whose type has an asset group:
:func:`furnished_rects`). With a scene it is what the scene really holds: every instance
that rises above the floor and starts below the body's top, as its oriented bounding box
(the mesh's own box turned by its transform), so walls, columns and the assets themselves
count and a lane whose vehicles stand at one end stays walkable at the other.

The raster is conservative. An obstacle's footprint is widened by one cell every way before
it is filled, so every cell the footprint touches is marked (a wall thinner than a cell too);
``clearance_m`` is the distance from a cell's centre
to the nearest marked cell's centre, and a cell is *free* when that distance is at least the
body's clearance plus one cell diagonal. Then every point of a free cell lies at least the
body's clearance from every obstacle, and a path that stays on free cells never comes nearer.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy import ndimage, sparse

from ..errors import ConfigError
from ..layout.model import Layout

FLOOR_TOP_M = 0.02  # an instance whose top lies below this is the floor itself (or a marking)
SEE_M = 3.0  # free floor this near a furnished region is aisle: a scan along it sees the region


def furnished_rects(layout: Layout) -> np.ndarray:
    """(n, 4) float64 (x0, y0, x1, y1) of the leaves the scene stage furnishes (their type has
    an asset group): what placement's low mounts and trajectories without a scene avoid."""
    rects = [
        (g.x, g.y, g.x + g.w, g.y + g.h)
        for g in layout.leaves()
        if layout.region_types[g.type].asset_group is not None
    ]
    return np.array(rects, np.float64).reshape(-1, 4)


def outside_rects(xy: np.ndarray, rects: np.ndarray, margin_m: float) -> np.ndarray:
    """(n,) bool: points ``xy`` (n, 2) farther than ``margin_m`` outside every rectangle."""
    px, py = xy[:, :1], xy[:, 1:]
    inside = (
        (px > rects[:, 0] - margin_m)
        & (px < rects[:, 2] + margin_m)
        & (py > rects[:, 1] - margin_m)
        & (py < rects[:, 3] + margin_m)
    )
    return ~inside.any(1)


def instance_boxes(scene, *, top_m: float = 2.2) -> list[np.ndarray]:
    """The oriented boxes of what stands on ``scene``'s floor: per instance rising above
    FLOOR_TOP_M and starting below ``top_m``, (8, 3) float64 world corners of its mesh's box."""
    out = []
    for inst in scene.instances:
        b = scene.meshes[inst.mesh].bounds
        if not np.all(np.isfinite(b)):
            continue
        corners = np.array([[x, y, z, 1.0] for x in b[:, 0] for y in b[:, 1] for z in b[:, 2]])
        world = (corners @ inst.world_from_model.T)[:, :3]
        if world[:, 2].max() <= FLOOR_TOP_M or world[:, 2].min() >= top_m:
            continue
        out.append(world)
    return out


@dataclass(frozen=True, eq=False)
class FreeFloor:
    """Where a body of radius ``body_radius_m`` can stand.

    Attributes
    ----------
    free : (H, W) bool, cells whose every point keeps ``body_radius_m`` from every obstacle;
        one connected piece is kept, so a path can reach any free cell from any: the one with
        the most aisle (free cells within SEE_M of a furnished region), then the largest.
    clearance_m : (H, W) float32, distance from the cell's centre to the nearest obstacle
        cell's centre (the hall's edge counts as one).
    near_m : (H, W) float32, distance to the nearest furnished region (what is worth seeing).
    origin_xy : (x0, y0) of the raster's corner; row r, column c covers
        [x0 + c·res, x0 + (c+1)·res) x [y0 + r·res, y0 + (r+1)·res).
    resolution_m, body_radius_m : float.
    """

    free: np.ndarray
    clearance_m: np.ndarray
    near_m: np.ndarray
    origin_xy: tuple[float, float]
    resolution_m: float
    body_radius_m: float

    @property
    def shape(self) -> tuple[int, int]:
        return self.free.shape

    def cells(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) int64 of points ``xy`` (n, 2); may lie outside the raster."""
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        col = np.floor((xy[:, 0] - self.origin_xy[0]) / self.resolution_m).astype(np.int64)
        row = np.floor((xy[:, 1] - self.origin_xy[1]) / self.resolution_m).astype(np.int64)
        return row, col

    def centres(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """(n, 2) float64 centres of cells."""
        res = self.resolution_m
        return np.stack(
            [
                self.origin_xy[0] + (np.asarray(cols) + 0.5) * res,
                self.origin_xy[1] + (np.asarray(rows) + 0.5) * res,
            ],
            1,
        )

    def is_free(self, xy: np.ndarray) -> np.ndarray:
        """(n,) bool: points on free cells (outside the raster: False)."""
        row, col = self.cells(xy)
        H, W = self.shape
        ok = (row >= 0) & (row < H) & (col >= 0) & (col < W)
        out = np.zeros(len(row), bool)
        out[ok] = self.free[row[ok], col[ok]]
        return out

    def segment_free(self, a: np.ndarray, b: np.ndarray) -> bool:
        """True when every point of the segment a-b lies on free cells (sampled at a
        quarter cell, which visits every cell the segment crosses)."""
        n = max(
            2,
            int(np.ceil(np.linalg.norm(np.asarray(b) - np.asarray(a)) / (0.25 * self.resolution_m)))
            + 1,
        )
        s = np.linspace(0.0, 1.0, n)[:, None]
        return bool(self.is_free(np.asarray(a) * (1 - s) + np.asarray(b) * s).all())

    def graph(self, prefer_clear_m: float = 0.5) -> tuple[sparse.csr_matrix, np.ndarray]:
        """The free cells as a graph for shortest paths: (W, index) with W an 8-neighbour
        CSR matrix of step costs (length, raised near obstacles so that paths keep to the
        middle of aisles) and ``index`` the (H, W) int64 node of each cell (-1: not free)."""
        H, W = self.shape
        index = np.full((H, W), -1, np.int64)
        rows, cols = np.nonzero(self.free)
        index[rows, cols] = np.arange(len(rows))
        extra = np.maximum(self.clearance_m - self.body_radius_m, 0.0)
        penalty = (1.0 + 2.0 * np.exp(-extra / prefer_clear_m))[rows, cols]
        src, dst, w = [], [], []
        for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
            r2, c2 = rows + dr, cols + dc
            ok = (r2 >= 0) & (r2 < H) & (c2 >= 0) & (c2 < W)
            ok[ok] &= self.free[r2[ok], c2[ok]]
            a, b = index[rows[ok], cols[ok]], index[r2[ok], c2[ok]]
            step = self.resolution_m * np.hypot(dr, dc) * 0.5 * (penalty[a] + penalty[b])
            src += [a, b]
            dst += [b, a]
            w += [step, step]
        n = len(rows)
        G = sparse.csr_matrix(
            (np.concatenate(w), (np.concatenate(src), np.concatenate(dst))), shape=(n, n)
        )
        return G, index


def free_floor(
    layout: Layout,
    scene=None,
    *,
    body_radius_m: float = 0.35,
    resolution_m: float = 0.1,
    top_m: float = 2.2,
) -> FreeFloor:
    """The free floor of ``layout`` (with ``scene``: of what the scene holds) for a body of
    radius ``body_radius_m`` whose top is ``top_m`` above the floor."""
    if not (body_radius_m > 0 and resolution_m > 0):
        raise ConfigError(
            f"free floor: body_radius_m and resolution_m must be > 0, got {body_radius_m}, "
            f"{resolution_m}"
        )
    x0, y0, w, h = layout.bounds
    res = float(resolution_m)
    W, H = max(1, int(np.ceil(w / res - 1e-9))), max(1, int(np.ceil(h / res - 1e-9)))
    blocked = np.zeros((H, W), np.uint8)
    SHIFT = 8  # cv2's sub-pixel bits

    def fill(poly_xy: np.ndarray) -> None:
        pix = (poly_xy - (x0, y0)) / res - 0.5  # pixel coordinates: cell centres at integers
        hull = cv2.convexHull(np.round(pix * (1 << SHIFT)).astype(np.int32))
        cv2.fillConvexPoly(blocked, hull, 1, lineType=cv2.LINE_8, shift=SHIFT)

    furnished = furnished_rects(layout)
    if scene is None:
        for r in furnished:
            fill(
                np.array(
                    [
                        [r[0] - res, r[1] - res],
                        [r[2] + res, r[1] - res],
                        [r[2] + res, r[3] + res],
                        [r[0] - res, r[3] + res],
                    ]
                )
            )
    else:
        square = np.array([[-res, -res], [res, -res], [res, res], [-res, res]])
        for box in instance_boxes(scene, top_m=top_m):
            # the footprint widened by one cell every way (its Minkowski sum with a square)
            fill((box[:, None, :2] + square[None]).reshape(-1, 2))
    padded = np.pad(blocked, 1, constant_values=1)  # the hall's edge is an obstacle
    clearance = (ndimage.distance_transform_edt(padded == 0) * res)[1:-1, 1:-1].astype(np.float32)
    need = body_radius_m + res * np.sqrt(2.0)
    free = clearance >= need
    labels, n = ndimage.label(free, structure=np.ones((3, 3), bool))
    if n == 0:
        raise ConfigError(
            f"free floor: nowhere in the {w:g} x {h:g} m hall keeps {body_radius_m:g} m from every "
            "asset; use a smaller body radius"
        )
    fur = np.ones((H, W), bool)
    if len(furnished):
        fb = np.zeros((H, W), np.uint8)
        for r in furnished:
            pix = (
                np.array([[r[0], r[1]], [r[2], r[1]], [r[2], r[3]], [r[0], r[3]]]) - (x0, y0)
            ) / res - 0.5
            cv2.fillConvexPoly(
                fb,
                np.round(pix * (1 << SHIFT)).astype(np.int32),
                1,
                lineType=cv2.LINE_8,
                shift=SHIFT,
            )
        fur = fb == 0
    near = (
        (ndimage.distance_transform_edt(fur) * res).astype(np.float32)
        if len(furnished)
        else np.full((H, W), np.inf, np.float32)
    )
    # the piece to keep: the one with the most aisle (free floor within SEE_M of a furnished
    # region: what a scan along it sees), then the largest
    aisle = np.bincount(labels.ravel(), weights=(near <= SEE_M).ravel(), minlength=n + 1)[1:]
    sizes = np.bincount(labels.ravel(), minlength=n + 1)[1:]
    best = max(range(n), key=lambda k: (aisle[k], sizes[k], -k))
    free = labels == best + 1
    return FreeFloor(free, clearance, near, (float(x0), float(y0)), res, float(body_radius_m))
