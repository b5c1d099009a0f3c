"""Occlusion culling: what lies behind a surface that is certainly drawn is not drawn, and no
pixel changes (depth bytes, ids, normals against the unculled render), equal depths included;
the conservative depth buffer's own kernels against their definitions."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.render import Renderer
from genie_gl.render.cull import BREAK_EVEN, PROBE_FRAMES
from genie_gl.render.occlusion import EMPTY, DepthBound, hidden, triangle_depths, write
from genie_gl.sensors.pose import look_at

pytestmark = pytest.mark.gl

SENSOR = gg.Sensor.pinhole(160, 120, 100.0)


def drawn(glctx, scene, pose, *, occlusion, cull=True, **kw):
    with Renderer(scene, context=glctx, cull=cull) as r:
        r.cull_min_faces = 0
        r.occlusion_min_faces = 0 if occlusion else 1 << 62
        frame = r.render(SENSOR, pose, **kw)
        return frame, r.stats["triangles_drawn"]


def at(x, y, z):
    T = np.eye(4)
    T[:3, 3] = [x, y, z]
    return T


def wall_scene(hidden_balls: bool, grid: bool = False) -> gg.Scene:
    """A 2 m x 2 m wall 3 m ahead of the camera (66 px of the 160 x 120 image across); balls
    6 m ahead beside it (seen) and, with ``hidden_balls``, behind it (wholly hidden): 4, or
    12 on a grid with ``grid``."""
    scene = gg.Scene()
    scene.add(trimesh.creation.box(extents=[2.0, 2.0, 0.1]), at(0, 0, 3), semantic=1)
    ball = trimesh.creation.icosphere(2, radius=0.3)
    for x in (-2.6, 2.6):
        scene.add(ball, at(x, 0.0, 6.0), semantic=2)
    if hidden_balls:
        spots = (
            [(x, y) for x in (-0.6, -0.2, 0.2, 0.6) for y in (-0.4, 0.0, 0.4)]
            if grid
            else [(-0.6, -0.5), (0.0, 0.3), (0.6, -0.2), (0.2, 0.6)]
        )
        for x, y in spots:
            scene.add(ball, at(x, y, 6.0 + x), semantic=3)
    return scene


def test_what_lies_behind_the_wall_is_not_drawn_and_no_pixel_changes(glctx):
    pose = np.eye(4)  # at the origin, looking down +z
    with_balls = wall_scene(True)
    full, n_all = drawn(glctx, with_balls, pose, occlusion=False, cull=False, normals=True)
    plain, n_plain = drawn(glctx, with_balls, pose, occlusion=False, normals=True)
    occl, n_occl = drawn(glctx, with_balls, pose, occlusion=True, normals=True)
    _, n_without = drawn(glctx, wall_scene(False), pose, occlusion=False)
    for f in (plain, occl):
        assert (
            f.depth.tobytes() == full.depth.tobytes()
            and f.normal.tobytes() == full.normal.tobytes()
        )
        assert np.array_equal(f.instance, full.instance) and np.array_equal(
            f.semantic, full.semantic
        )
    assert not (full.semantic == 3).any() and (full.semantic == 2).sum() > 100
    # the hidden balls' triangles go (but for a few near their silhouettes, seen too nearly
    # edge-on for their depth to be bounded): drawn about as many as without them
    behind = n_plain - n_without  # drawn without occlusion culling: they cover pixel centres
    assert behind > 200 and n_occl - n_without <= 0.05 * behind and n_without < n_all


@pytest.mark.parametrize("pays", [True, False])
def test_occlusion_culling_runs_while_it_pays(glctx, pays):
    """With most of what it tests hidden (12 balls behind the wall) every frame is occlusion-
    culled; with nothing hidden, the first frame tries and the next PROBE_FRAMES do not."""
    scene = wall_scene(pays, grid=True)
    with Renderer(scene, context=glctx) as r:
        r.cull_min_faces = r.occlusion_min_faces = 0
        ran, shares = [], []
        for _ in range(PROBE_FRAMES + 3):
            r.render(SENSOR, np.eye(4), depth_only=True)
            ran.append(r.stats["occlusion_culled"])
            if ran[-1]:
                shares.append(r._culler.tally[5] / r._culler.tally[3])
    if pays:
        assert all(ran) and min(shares) >= BREAK_EVEN
    else:
        assert ran == [True] + [False] * PROBE_FRAMES + [True, False] and max(shares) < BREAK_EVEN


def tie_scene() -> gg.Scene:
    """Coplanar, overlapping quads 2 m ahead (ids tie on equal depth: the first drawn wins),
    a copy of one of them, and a wall behind them all."""
    quad = gg.Mesh(
        np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float),
        np.array([[0, 1, 2], [0, 2, 3], [0, 2, 1], [0, 3, 2]]),
    )
    scene = gg.Scene()
    for T, semantic in ((at(-0.3, 0, 2), 1), (at(0.3, 0.1, 2), 2), (at(-0.3, 0, 2), 3)):
        scene.add(quad, T, semantic=semantic)
    scene.add(trimesh.creation.box(extents=[6.0, 6.0, 0.1]), at(0, 0, 4), semantic=4)
    return scene


def test_equal_depths_keep_the_unculled_winner(glctx):
    for pose in (np.eye(4), look_at(np.array([0.2, -0.1, -0.5]), np.array([0.0, 0.0, 2.0]))):
        full, _ = drawn(glctx, tie_scene(), pose, occlusion=False, cull=False)
        occl, _ = drawn(glctx, tie_scene(), pose, occlusion=True)
        assert occl.depth.tobytes() == full.depth.tobytes()
        assert np.array_equal(occl.instance, full.instance) and np.array_equal(
            occl.semantic, full.semantic
        )
        assert {1, 2, 4} <= set(np.unique(full.semantic))


def test_depth_bound_writes_only_centres_inside_and_hides_only_what_is_behind():
    depth = DepthBound(20, 10)
    depth.clear()
    # a triangle covering the pixel centres of columns 2..9 on row 3 and more
    write(depth.z, depth.dirty, 1.5, 1.5, 12.5, 1.5, 1.5, 8.5, 0.01, 2.0)
    covered = depth.z < EMPTY
    u, v = np.meshgrid(np.arange(20.0), np.arange(10.0))
    inside = (
        (u > 1.5 + 0.02)
        & (v > 1.5 + 0.02)
        & (7 * (u - 1.5) + 11 * (v - 1.5) < 77 - 0.02 * np.hypot(7, 11))
    )
    assert covered.sum() > 20 and not (covered & ~inside).any()
    assert np.all(depth.z[covered] >= np.float32(2.0)) and np.all(
        depth.z[covered] < 2.0 * (1 + 1e-5)
    )
    # behind (q below 1/2) over covered centres only: hidden; at the same depth or nearer: not
    assert hidden(depth.z, depth.tiles, depth.dirty, 3.0, 4.0, 3.0, 3.0, 0.49)
    assert not hidden(depth.z, depth.tiles, depth.dirty, 3.0, 4.0, 3.0, 3.0, 0.5)
    assert not hidden(
        depth.z, depth.tiles, depth.dirty, 14.0, 15.0, 3.0, 3.0, 1e-3
    )  # nothing drawn there


def test_triangle_depth_bounds_hold_the_plane_and_refuse_slivers():
    # a plane z = 2 + 0.01 u seen at 1/z: the bounds hold the vertices' range
    za, zb, zc = 2.0, 2.1, 2.0
    q_lo, q_hi = triangle_depths(
        0.0, 0.0, za, 10.0, 0.0, zb, 0.0, 10.0, zc, 1e-6, 1e-3, 1 / 16, 640.0, 480.0
    )
    spread = 1 / 2.0 - 1 / 2.1
    assert 0 < 1 / 2.1 - q_lo < 0.05 * spread and 0 < q_hi - 1 / 2.0 < 0.05 * spread
    # a sliver thinner than its vertices' error: no bound
    assert (
        triangle_depths(
            0.0, 0.0, za, 10.0, 1e-4, zb, 20.0, 0.0, zc, 1e-6, 1e-3, 1 / 16, 640.0, 480.0
        )[1]
        >= 1e299
    )
