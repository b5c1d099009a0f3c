"""Merging, down-sampling, chunking and cleaning of clouds (paper §3.4.2)."""

from __future__ import annotations

from collections.abc import Sequence

import numba
import numpy as np

from ..validation.arguments import expect, expect_sequence
from ..errors import ConfigError
from ..frame import Frame
from .pointcloud import PointCloud
from . import kernels
from .tally import MAX_TILES, WINDOW, FrameTally, frame_inputs, tally_frames, too_small
from .unproject import rotate, unproject_into, world_normals


ORIGIN_GRID_M = 100.0  # the cloud's origin is the cameras' mean snapped to this grid


def choose_origin(frames: Sequence[Frame]) -> np.ndarray:
    """The cloud's float64 origin: the mean of the camera centres snapped to a 100 m grid
    (zero for no frames, and for a scene around the world origin), wherever the scene lies,
    so float32 coordinates stay small: a point within 1.6 km of the origin keeps 0.1 mm
    (float32 rounds to 2⁻²⁴ of the distance), i.e. any point within 1.5 km of the cameras'
    mean, whether the site sits at the world origin or 1e7 m away."""
    return origin_of([f.world_from_camera for f in frames])


def origin_of(poses: Sequence[np.ndarray]) -> np.ndarray:
    """:func:`choose_origin` of frames taken at ``poses`` ((4, 4) world_from_camera): known
    before they are rendered."""
    centres = np.array([np.asarray(p, np.float64)[:3, 3] for p in poses])
    if len(centres) == 0:
        return np.zeros(3)
    return (
        np.round(centres.mean(0) / ORIGIN_GRID_M) * ORIGIN_GRID_M + 0.0
    )  # + 0.0: no -0.0 in headers


def voxel_downsample(cloud: PointCloud, voxel_m: float) -> PointCloud:
    """Keep the first point (in order) of each occupied voxel of size ``voxel_m``."""
    keys = np.floor(cloud.xyz / voxel_m).astype(np.int64)
    keys -= keys.min(0)
    dims = keys.max(0) + 1
    flat = (keys[:, 0] * dims[1] + keys[:, 1]) * dims[2] + keys[:, 2]
    _, first = np.unique(flat, return_index=True)
    return cloud.select(np.sort(first))


def random_downsample(cloud: PointCloud, n: int, *, rng: np.random.Generator) -> PointCloud:
    """Exactly ``n`` points drawn without replacement (all points, in order, if fewer)."""
    if len(cloud) <= n:
        return cloud
    return cloud.select(np.sort(rng.choice(len(cloud), n, replace=False)))


def to_cloud(
    frames: Sequence[Frame],
    *,
    voxel_m: float | None = None,
    max_points: int | None = None,
    rng: np.random.Generator | None = None,
    origin: np.ndarray | None = None,
    precision: str = "float32",
) -> PointCloud:
    """Merge frames into one world-frame cloud with semantic, instance, colour, normal, camera.

    Every frame is unprojected straight into its slice of the merged arrays (no per-frame
    clouds, no concatenation). voxel_m : optional voxel down-sampling; max_points : random
    down-sampling to at most that many points (needs ``rng``).

    Precision: ``xyz`` is relative to the float64 ``origin`` (the cameras' mean, snapped to
    100 m, by default).
    ``precision="float32"`` keeps 0.1 mm within 1.6 km of the origin (float32 rounding is
    |xyz|·2⁻²⁴); ``"float64"`` gives float64 ``xyz``, each frame unprojected relative to its
    own camera first, so a site of any size (20 km and more) keeps 0.1 mm.
    """
    if precision not in ("float32", "float64"):
        raise ConfigError(f"to_cloud: precision must be 'float32' or 'float64', got {precision!r}")
    frames = expect_sequence(frames, Frame, "to_cloud: frames")
    if max_points is not None and rng is None:
        raise ConfigError("to_cloud: max_points needs an rng (numpy.random.Generator)")
    origin = choose_origin(frames) if origin is None else np.asarray(origin, np.float64)
    counts = np.array([kernels.count_valid(f.depth) for f in frames], np.int64)
    ends = np.cumsum(counts)
    n = int(ends[-1])
    # spare room: the unprojection kernel writes past the last valid point (see unproject_into)
    xyz = np.empty((n + 2, 3), np.float32)
    sem, inst = np.empty(n + 1, np.uint16), np.empty(n + 1, np.uint32)
    with_rgb = all(f.rgb is not None for f in frames)
    with_normal = all(f.normal is not None for f in frames)
    rgb = np.empty((n + 1, 3), np.uint8) if with_rgb else None
    normal = np.empty((n, 3), np.float32) if with_normal else None
    wide = np.empty((n, 3), np.float64) if precision == "float64" else None
    for f, a, b in zip(frames, ends - counts, ends):
        # frame k's writes past its points land on frame k+1's first slots, which it then fills
        at = origin if wide is None else np.round(f.world_from_camera[:3, 3])
        unproject_into(f, at, xyz[a:], sem[a:], inst[a:], None if rgb is None else rgb[a:], n=b - a)
        if wide is not None:  # small float32 offsets from the camera, made float64 here
            wide[a:b] = xyz[a:b].astype(np.float64) + (at - origin)
        if with_normal:
            normal[a:b] = world_normals(f)
    camera = np.repeat(np.arange(len(frames), dtype=np.uint16), counts)
    cloud = PointCloud(
        xyz[:n] if wide is None else wide,
        sem[:n],
        inst[:n],
        origin,
        None if rgb is None else rgb[:n],
        normal,
        camera,
    )
    if voxel_m:
        cloud = voxel_downsample(cloud, voxel_m)
    if max_points is not None:
        cloud = random_downsample(cloud, max_points, rng=rng)
    return cloud


def chunks(
    cloud: PointCloud,
    size_m: float,
    *,
    min_points: int = 1,
    max_points: int | None = None,
    rng: np.random.Generator | None = None,
) -> list[tuple[tuple[int, int], PointCloud]]:
    """Crop the cloud into square (x, y) tiles of ``size_m``; returns ((i, j), tile) pairs in
    (i, j) order, each tile's points in their original order.

    Tiles with fewer than ``min_points`` points are left out. With ``max_points`` (and ``rng``)
    each tile is randomly down-sampled to that many points before its points are gathered:
    the same points, drawn the same way, as ``random_downsample(tile, max_points, rng=rng)``.
    """
    if max_points is not None and rng is None:
        raise ValueError("chunks: max_points needs an rng (numpy.random.Generator)")
    if len(cloud) == 0:
        return []
    order, keys, starts, i0, j0, span = kernels.tile_order(cloud.xyz, float(size_m))
    out = []
    for key, a, b in zip(keys.tolist(), starts[:-1].tolist(), starts[1:].tolist()):
        if b - a < min_points:
            continue
        idx = order[a:b]
        if max_points is not None and b - a > max_points:
            idx = idx[np.sort(rng.choice(b - a, max_points, replace=False))]
        out.append(((key // span + i0, key % span + j0), cloud.select(idx)))
    return out


def keep_cloud(
    cloud: PointCloud,
    *,
    min_points: int = 1000,
    min_labelled_share: float = 0.05,
    background: int = 0,
) -> tuple[bool, str]:
    """The paper's cleaning: drop clouds with too few points, too small a labelled share, or
    background only. Returns (keep, reason)."""
    if len(cloud) < min_points:
        return False, f"{len(cloud)} points < {min_points}"
    share = float((cloud.semantic != background).mean())
    if share == 0:
        return False, "background only"
    if share < min_labelled_share:
        return False, f"labelled share {share:.3f} < {min_labelled_share}"
    return True, "ok"


def frame_chunks(
    frames: Sequence[Frame],
    size_m: float,
    *,
    min_points: int = 1,
    max_points: int | None = None,
    rng: np.random.Generator | None = None,
    origin: np.ndarray | None = None,
    tally: FrameTally | None = None,
) -> tuple[list[tuple[tuple[int, int], PointCloud]], int]:
    """``chunks(to_cloud(frames), ...)`` without the merged cloud: the same tiles with the
    same points, drawn the same way; returns (tiles, number of points of the merged cloud).

    The merged cloud of a 40-camera scene holds ~12 M points (~220 MB) of which the chunks
    keep a few hundred thousand. Here no cloud is written: each frame is read once to count
    the points per tile, keeping its runs of pixels per tile (:mod:`.tile_runs`), then,
    once every tile's choice of ranks is drawn, its runs give just the chosen points (their
    labels gathered by pixel).

    ``tally``: a :class:`~genie_gl.cloud.tally.FrameTally` that counted these frames as they
    were made (taken when of these frames, this origin and tile size; else closed and the
    frames counted here): the same tiles either way.
    """
    if not frames:
        raise ValueError("frame_chunks: no frames")
    if max_points is not None and rng is None:
        raise ValueError("frame_chunks: max_points needs an rng (numpy.random.Generator)")
    if tally is not None:
        expect(tally, FrameTally, "frame_chunks: tally")
    origin = choose_origin(frames) if origin is None else np.asarray(origin, np.float64)
    size = float(size_m)
    # pass 1: points per tile, counted in a window of tiles around each camera; the frame's
    # runs of pixels per tile kept for pass 2 (None: it reached beyond the window, or had
    # more runs than the room given). Counted already by ``tally`` when it is of these frames.
    if tally is not None and tally.matches(frames, origin, size):
        inputs, tallies = tally.results()
    else:
        if tally is not None:
            tally.close()
        inputs = [frame_inputs(f, origin) for f in frames]
        # the kernels release the GIL: the frames are counted on as many threads as numba may use
        tallies = tally_frames(frames, inputs, origin, size, threads=numba.get_num_threads())
    per_tile: dict[tuple[int, int], int] = {}
    windows: list[tuple[int, int, np.ndarray] | None] = []
    for (
        window,
        i0,
        j0,
        counts,
    ) in tallies:  # summed in frame order: the same integers however counted
        windows.append(window)
        for a, b in zip(*np.nonzero(counts)):
            key = (int(i0 + a), int(j0 + b))
            per_tile[key] = per_tile.get(key, 0) + int(counts[a, b])
    total = sum(per_tile.values())
    # the draws, tile by tile in (i, j) order, exactly as chunks() makes them
    kept: list[tuple[int, int]] = []
    start, sizes, chosen, next_q = [], [], [], []
    offset = q = 0
    for key in sorted(per_tile):
        c = per_tile[key]
        if c < min_points:
            continue
        kept.append(key)
        if max_points is not None and c > max_points:
            chosen.append(np.sort(rng.choice(c, max_points, replace=False)))
            start.append(offset)
            next_q.append(q)
            offset += c
            q += max_points
            sizes.append(max_points)
        else:
            start.append(-1)
            next_q.append(-1)
            sizes.append(c)
    if not kept:
        return [], total
    I0, J0 = min(k[0] for k in per_tile), min(k[1] for k in per_tile)
    shape = (max(k[0] for k in per_tile) - I0 + 1, max(k[1] for k in per_tile) - J0 + 1)
    if shape[0] * shape[1] > MAX_TILES:
        raise too_small(size_m, shape[0] * size, shape[1] * size)
    grid = np.full(shape, -1, np.int64)
    for t, (i, j) in enumerate(kept):
        grid[i - I0, j - J0] = t
    ends = np.cumsum(sizes)
    m_all = int(ends[-1])
    with_rgb = all(f.rgb is not None for f in frames)
    with_normal = all(f.normal is not None for f in frames)
    out_xyz, out_sem, out_inst = (
        np.empty((m_all, 3), np.float32),
        np.empty(m_all, np.uint16),
        np.empty(m_all, np.uint32),
    )
    out_rgb = np.empty((m_all, 3), np.uint8) if with_rgb else None
    out_normal = np.empty((m_all, 3), np.float32) if with_normal else None
    out_camera = np.empty(m_all, np.uint16)
    seen = np.zeros(len(kept), np.int64)
    taken = (ends - sizes).astype(np.int64)
    ranks = np.concatenate(chosen) if chosen else np.zeros(0, np.int64)
    next_q_a = np.array(next_q, np.int64)
    end_q = np.where(next_q_a >= 0, next_q_a + max_points if max_points is not None else 0, -1)
    start_a = np.array(start, np.int64)
    # the chosen ranks as a mask over every down-sampled tile's points, if a frame has no runs
    picked = None
    if any(w is None for w in windows):
        picked = np.zeros(offset, bool)
        for t in np.flatnonzero(start_a >= 0).tolist():
            picked[start_a[t] + ranks[next_q_a[t] : end_q[t]]] = True
    cap = max(f.depth.size for f in frames)
    src, dst = np.empty(cap, np.int64), np.empty(cap, np.int64)
    # pass 2: write the chosen points, gather their labels by pixel
    for k, (f, (depth, tx, ty, M, (_, pick, _), (_, pick_runs)), window) in enumerate(
        zip(frames, inputs, windows)
    ):
        if window is None:  # no runs: every pixel's tile computed again
            m = pick(
                depth,
                tx,
                ty,
                M,
                size,
                I0,
                J0,
                grid,
                seen,
                start_a,
                picked,
                taken,
                src,
                dst,
                out_xyz,
            )
        else:
            i0, j0, runs = window
            m = pick_runs(
                runs,
                depth,
                tx,
                ty,
                M,
                _window_tiles(grid, i0 - I0, j0 - J0),
                seen,
                next_q_a,
                end_q,
                ranks,
                taken,
                src,
                dst,
                out_xyz,
            )
        s, d = src[:m], dst[:m]
        # labels gathered by flat pixel index (C order, as the kernel numbers pixels)
        out_sem[d], out_inst[d], out_camera[d] = np.take(f.semantic, s), np.take(f.instance, s), k
        if with_rgb or with_normal:
            v, u = np.divmod(s, depth.shape[1])
            if with_rgb:
                out_rgb[d] = f.rgb[v, u]
            if with_normal:
                out_normal[d] = rotate(f.normal[v, u], f.world_from_camera)
    merged = PointCloud(out_xyz, out_sem, out_inst, origin, out_rgb, out_normal, out_camera)
    tiles = [(key, merged.select(slice(a, b))) for key, a, b in zip(kept, ends - sizes, ends)]
    return tiles, total


def _window_tiles(grid: np.ndarray, a0: int, b0: int) -> np.ndarray:
    """(WINDOW * WINDOW,) int64: the output tile (``grid``'s value, -1 for none) of each tile
    code of a frame's runs (a * WINDOW + b) when its window starts at grid cell (a0, b0),
    possibly outside the grid."""
    out = np.full((WINDOW, WINDOW), -1, np.int64)
    A, B = grid.shape
    a_lo, a_hi, b_lo, b_hi = max(0, -a0), min(WINDOW, A - a0), max(0, -b0), min(WINDOW, B - b0)
    if a_lo < a_hi and b_lo < b_hi:
        out[a_lo:a_hi, b_lo:b_hi] = grid[a0 + a_lo : a0 + a_hi, b0 + b_lo : b0 + b_hi]
    return out.reshape(-1)
