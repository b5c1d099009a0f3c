"""Helpers of the render tests: exact ray casting of boxes, interior pixels (the GL fixtures
and the guard every test runs under live in tests/conftest.py)."""

import numpy as np
import pytest

from genie_gl.render import Renderer


def ray_dirs(sensor):
    """(H, W, 3) float64 camera-frame rays with z = 1 through every pixel centre."""
    u, v = np.meshgrid(np.arange(sensor.width, dtype=float), np.arange(sensor.height, dtype=float))
    K = sensor.K
    y = (v - K[1, 2]) / K[1, 1]
    x = (u - K[0, 2] - K[0, 1] * y) / K[0, 0]
    return np.stack([x, y, np.ones_like(x)], axis=-1)


def cast_boxes(sensor, pose, boxes):
    """Exact ray casting of oriented boxes (slab method), independent of any rasteriser.

    boxes: list of (world_from_box (4, 4), half_extents (3,), instance id).
    Returns depth (H, W) float64 (0 = miss) and instance (H, W) uint32; the camera may sit
    inside a box (then the exit point is what it sees).
    """
    d_cam = ray_dirs(sensor).reshape(-1, 3)
    R, t = pose[:3, :3], pose[:3, 3]
    best = np.full(len(d_cam), np.inf)
    ids = np.zeros(len(d_cam), np.uint32)
    for T, half, iid in boxes:
        box_from_world = np.linalg.inv(T)
        o = box_from_world[:3, :3] @ t + box_from_world[:3, 3]
        d = d_cam @ (box_from_world[:3, :3] @ R).T
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (-np.asarray(half) - o) / d
            t2 = (np.asarray(half) - o) / d
        tmin = np.nanmax(np.minimum(t1, t2), axis=1)
        tmax = np.nanmin(np.maximum(t1, t2), axis=1)
        hit = tmax >= np.maximum(tmin, 0)
        tt = np.where(tmin > 0, tmin, tmax)
        closer = hit & (tt > 0) & (tt < best)
        best[closer] = tt[closer]
        ids[closer] = iid
    depth = np.where(np.isfinite(best), best, 0.0)  # rays have z = 1: t is the depth
    return depth.reshape(sensor.height, sensor.width), ids.reshape(sensor.height, sensor.width)


def interior(ids, margin=1):
    """(H, W) bool: pixels whose whole (2·margin+1)² neighbourhood has the same id."""
    H, W = ids.shape
    ok = np.ones_like(ids, dtype=bool)
    p = np.pad(ids, margin, mode="edge")
    for dy in range(-margin, margin + 1):
        for dx in range(-margin, margin + 1):
            ok &= p[margin + dy : margin + dy + H, margin + dx : margin + dx + W] == ids
    ok[:margin], ok[-margin:], ok[:, :margin], ok[:, -margin:] = False, False, False, False
    return ok


@pytest.fixture(params=["gl", "cpu"])
def draw(request, glctx):
    """Makes a renderer of a scene with each raster in turn (the oracle tests run over both):
    GL in the test's context, or the CPU raster (no GL)."""
    if request.param == "gl":
        return lambda scene, **kw: Renderer(scene, context=glctx, raster="gl", **kw)
    return lambda scene, **kw: Renderer(scene, raster="cpu", **kw)
