"""Edge supersampling with ids never blended: render at ``s`` times the resolution, reduce.

Each output pixel takes the ``s x s`` samples of its block in the high-resolution render and
keeps the **majority instance** among them (no return counts as a candidate too; a tie goes
to the id of the pixel's centre ray, else to the nearer surface). Its depth is the harmonic mean of
that instance's samples — exact on
a plane, since 1/z is affine in the pixel position and the samples sit symmetrically about
the pixel centre — and its semantic id, normal and colour come from the same samples. So a
pixel's id is always one of its own samples' ids: no id that is not in the scene, no
depth halfway between a box and the wall behind it. One instance can also hide part of
itself (a rack's front beam before its back beam): its samples are split where their sorted
depths jump by more than ``STEP`` (1 %), and the largest group (ties: the nearest) gives the
depth, so no depth halfway between two parts of one object either.

The high-resolution camera puts the block's samples symmetrically about the low-resolution
pixel centre: ``f' = s·f``, ``c' = s·(c + 0.5) − 0.5`` (pixel centres at integer
coordinates, DESIGN.md).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import cv2
import numpy as np

from ..frame import Frame
from ..sensors.camera import Sensor
from ..lens.distortion import render_through_lens

NO_RETURN_DEPTH = 1.0e9  # how far "no return" counts when a tie is broken by depth
STEP = 0.01  # a relative jump between sorted depths that separates two surfaces


def supersample_sensor(sensor: Sensor, s: int) -> Sensor:
    """The camera whose ``s x s`` pixel blocks tile ``sensor``'s pixels (same lens model: a
    distorted sensor's normalised coordinates do not change with the pixel size)."""
    K = sensor.K.copy()
    K[0, 0] *= s
    K[0, 1] *= s
    K[1, 1] *= s
    K[0, 2] = s * (sensor.cx + 0.5) - 0.5
    K[1, 2] = s * (sensor.cy + 0.5) - 0.5
    kw = {"width": sensor.width * s, "height": sensor.height * s, "K": K}
    if hasattr(sensor, "effects"):
        kw["effects"] = ()
    if hasattr(sensor, "name"):
        kw["name"] = f"{sensor.name}-x{s}"
    return dataclasses.replace(sensor, **kw)


def _blocks(a: np.ndarray, s: int) -> np.ndarray:
    """(H·s, W·s, ...) -> (H·W, s·s, ...): each output pixel's samples in one row."""
    H, W = a.shape[0] // s, a.shape[1] // s
    b = a.reshape(H, s, W, s, *a.shape[2:]).swapaxes(1, 2)
    return b.reshape(H * W, s * s, *a.shape[2:])


def _run_lengths(a: np.ndarray) -> np.ndarray:
    """Rows of ``a`` sorted ascending: for every entry, the length of the run of equal values
    it belongs to."""
    n, k = a.shape
    cols = np.arange(k)
    first = np.ones((n, 1), bool)
    start = np.maximum.accumulate(
        np.where(np.concatenate([first, a[:, 1:] != a[:, :-1]], 1), cols, 0), axis=1
    )
    r = a[:, ::-1]
    end = (
        k
        - 1
        - np.maximum.accumulate(
            np.where(np.concatenate([first, r[:, 1:] != r[:, :-1]], 1), cols, 0), axis=1
        )[:, ::-1]
    )
    return end - start + 1


def majority(ids: np.ndarray, depth: np.ndarray, prefer: np.ndarray | None = None) -> np.ndarray:
    """Per row of ``ids`` (N, k), the column of a sample of the most frequent id; a tie goes
    to ``prefer`` (N,) when it is one of the tied ids (the pixel centre's own id: no bias to
    either side of an edge), else to the smallest depth (``depth`` (N, k), 0 = no return =
    farthest). Returns (N,) int."""
    n = len(ids)
    order = np.argsort(ids, axis=1, kind="stable")
    a = np.take_along_axis(ids, order, 1)
    count = _run_lengths(a).astype(np.float64)
    z = np.take_along_axis(depth, order, 1).astype(np.float64)
    z = np.where(z > 0, z, NO_RETURN_DEPTH)
    score = count * (8 * NO_RETURN_DEPTH) - z  # most samples, then nearest
    if prefer is not None:
        score += (a == np.asarray(prefer)[:, None]) * (4 * NO_RETURN_DEPTH)
    best = np.argmax(score, axis=1)
    return order[np.arange(n), best]


def surface(depth: np.ndarray, mask: np.ndarray, step: float = STEP) -> np.ndarray:
    """(N, k) bool: of the samples ``mask`` selects in each row (returns only), those of the
    largest group whose sorted depths never jump by more than ``step`` (relative); ties to
    the nearest group."""
    n = len(depth)
    z = np.where(mask & (depth > 0), depth.astype(np.float64), np.inf)
    order = np.argsort(z, axis=1, kind="stable")
    zs = np.take_along_axis(z, order, 1)
    with np.errstate(invalid="ignore"):
        jump = zs[:, 1:] > zs[:, :-1] * (1 + step)
    label = np.concatenate([np.zeros((n, 1), np.int64), np.cumsum(jump, 1)], 1)
    count = np.where(np.isfinite(zs), _run_lengths(label), -1)
    best = np.argmax(count, axis=1)
    keep_sorted = (label == label[np.arange(n), best][:, None]) & np.isfinite(zs)
    keep = np.zeros_like(keep_sorted)
    np.put_along_axis(keep, order, keep_sorted, 1)
    return keep


def reduce(hi: Frame, sensor: Sensor, s: int, centre: Frame | None = None) -> Frame:
    """The ``sensor`` frame made from ``hi``, rendered with :func:`supersample_sensor`.

    Blocks of one instance (most of an image) are reduced with area averages (of 1/z, of the
    normals, of the colour); only blocks on a silhouette go through :func:`majority`.
    ``centre``, the frame rendered at the sensor's own resolution (its pixel-centre rays),
    gives the depth and normal wherever its instance is the one the block keeps: the exact
    depth on the centre ray, where an average over a block would round a crease."""
    H, W = sensor.height, sensor.width
    instance = np.ascontiguousarray(hi.instance[::s, ::s])  # each block's first sample
    semantic = np.ascontiguousarray(hi.semantic[::s, ::s])
    d = hi.depth
    inv = np.zeros_like(d)
    np.divide(1.0, d, out=inv, where=d > 0)
    mean_inv = cv2.resize(inv, (W, H), interpolation=cv2.INTER_AREA)
    with np.errstate(divide="ignore"):
        depth = np.where((instance > 0) & (mean_inv > 0), 1.0 / mean_inv, 0.0).astype(np.float32)
    ids = _blocks(hi.instance, s)
    zb = _blocks(d, s)
    mixed = np.flatnonzero((ids != ids[:, :1]).any(1) | (zb.max(1) > zb.min(1) * (1 + STEP)))
    normal = None
    if hi.normal is not None:
        normal = cv2.resize(hi.normal, (W, H), interpolation=cv2.INTER_AREA).reshape(H * W, 3)
    if len(mixed):
        ids = ids[mixed]
        zb = zb[mixed]
        pick = majority(ids, zb, None if centre is None else centre.instance.ravel()[mixed])
        rows = np.arange(len(mixed))
        chosen = ids[rows, pick]
        same = surface(zb, ids == chosen[:, None])
        hit = same & (zb > 0)
        n_hit = hit.sum(1)
        sum_inv = np.where(hit, 1.0 / np.where(zb > 0, zb, 1.0).astype(np.float64), 0.0).sum(1)
        z = np.where((chosen > 0) & (n_hit > 0), n_hit / np.maximum(sum_inv, 1e-300), 0.0)
        depth.ravel()[mixed] = z
        instance.ravel()[mixed] = chosen
        semantic.ravel()[mixed] = _blocks(hi.semantic, s)[mixed][rows, pick]
        if normal is not None:
            normal[mixed] = (_blocks(hi.normal, s)[mixed] * same[..., None]).sum(1)
    if centre is not None:  # the centre ray's own depth wherever it saw the instance kept
        keep = ((centre.instance == instance) & (centre.depth > 0)).ravel()
        depth.ravel()[keep] = centre.depth.ravel()[keep]
        if normal is not None and centre.normal is not None:
            normal[keep] = centre.normal.reshape(-1, 3)[keep]
    if normal is not None:
        norm = np.linalg.norm(normal, axis=1, keepdims=True)
        normal = (
            np.where(norm > 0, normal / np.maximum(norm, 1e-30), 0.0)
            .astype(np.float32)
            .reshape(H, W, 3)
        )
        normal[instance == 0] = 0
    rgb = (
        None if hi.rgb is None else cv2.resize(hi.rgb, (W, H), interpolation=cv2.INTER_AREA)
    )  # colour is no label
    meta = {**(hi.meta or {}), "supersample": s}
    return Frame(depth, instance, semantic, rgb, sensor, hi.world_from_camera, normal, meta)


def supersampled(render: Callable[..., Frame], s: int) -> Callable[..., Frame]:
    """``render`` (``(sensor, pose, **kw) -> Frame``, e.g. ``Renderer.render``) made to render
    every frame at ``s`` times the resolution and reduce it (with a render at the sensor's own
    resolution for the centre rays' depth, ``1/s²`` more pixels); ``s = 1`` returns ``render``.

    A distorted sensor resampled exactly (each pixel from its own ray's hit) is supersampled
    through its lens: :func:`~genie_gl.lens.distortion.render_through_lens` finds the
    returned function's ``lens`` attribute and renders the lens's image at ``s`` times its
    resolution (``s x s`` exact rays per pixel, symmetric about its centre ray), reduced as
    above (a reduced pinhole view would have no triangle per pixel to intersect)."""
    if s == 1:
        return render

    def wrapped(sensor: Sensor, pose: np.ndarray, **kw) -> Frame:
        centre = render(sensor, pose, **{**kw, "depth_only": True})
        return reduce(render(supersample_sensor(sensor, s), pose, **kw), sensor, s, centre)

    def lens(sensor: Sensor, pose: np.ndarray, **kw) -> Frame:
        centre = render_through_lens(render, sensor, pose, **{**kw, "depth_only": True})
        return reduce(
            render_through_lens(render, supersample_sensor(sensor, s), pose, **kw),
            sensor,
            s,
            centre,
        )

    wrapped.lens = lens
    return wrapped
