"""Rendered buffers against analytic truths: planes, spheres, boxes, cv2.projectPoints."""

import cv2
import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.sensors.pose import look_at

from .conftest import cast_boxes, interior, ray_dirs

pytestmark = pytest.mark.gl

# odd size, non-square pixels, principal point off-centre
SENSOR = gg.Sensor(161, 97, np.array([[150.0, 0, 77.3], [0, 171.0, 52.8], [0, 0, 1]]))
REL_DEPTH = 1e-5


def random_pose(rng, eye_scale=1.0):
    q = trimesh.transformations.random_rotation_matrix(rng.random(3))
    q[:3, 3] = rng.normal(size=3) * eye_scale
    return q


def quad(corners):
    return gg.Mesh(np.asarray(corners, float), np.array([[0, 1, 2], [0, 2, 3]]))


def test_tilted_plane_depth_is_exact(draw):
    rng = np.random.default_rng(1)
    pose = random_pose(rng, 5.0)
    # plane through p0 with a normal tilted 40 deg from the optical axis (camera frame)
    p0 = np.array([0.2, -0.1, 3.0])
    n = np.array([np.sin(np.radians(40)), 0.0, -np.cos(np.radians(40))])
    a = np.cross(n, [0, 1, 0])
    a /= np.linalg.norm(a)
    b = np.cross(n, a)
    corners_cam = [p0 + 3 * (sa * a + sb * b) for sa, sb in [(-1, -1), (1, -1), (1, 1), (-1, 1)]]
    corners = [pose[:3, :3] @ c + pose[:3, 3] for c in corners_cam]
    scene = gg.Scene()
    scene.add(quad(corners), semantic=7, instance=42)
    with draw(scene) as r:
        f = r.render(SENSOR, pose)
    d = ray_dirs(SENSOR)
    expected = (n @ p0) / (d @ n)
    hit = f.depth > 0
    assert hit.mean() > 0.9
    np.testing.assert_allclose(f.depth[hit], expected[hit], rtol=REL_DEPTH)
    assert (f.instance[hit] == 42).all() and (f.semantic[hit] == 7).all()
    assert f.rgb is not None and f.rgb[hit].max() > 0


def test_sphere_depth_matches_closed_form(draw):
    r_s, centre = 1.0, np.array([0.3, -0.2, 4.0])
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=r_s)
    scene = gg.Scene()
    pose = np.eye(4)
    scene.add(sphere, centre, semantic=1)
    with draw(scene) as r:
        f = r.render(SENSOR, pose)
    d = ray_dirs(SENSOR)
    # |t d - c|^2 = r^2, smallest root; d has z = 1 so t is the depth
    A = (d * d).sum(-1)
    B = -2 * (d @ centre)
    C = centre @ centre - r_s**2
    disc = B * B - 4 * A * C
    t = (-B - np.sqrt(np.maximum(disc, 0))) / (2 * A)
    inside = interior((disc > 0).astype(np.uint32), 2) & (disc > 0)
    assert inside.sum() > 1000
    # The mesh is inscribed: it is hit at or behind the sphere, by at most the largest gap
    # between a face plane and the sphere, over the cosine of the incidence angle.
    tri = sphere.vertices[sphere.faces]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    plane_dist = np.abs((normals * tri[:, 0]).sum(1)) / np.linalg.norm(normals, axis=1)
    gap = r_s - plane_dist.min()
    hit = t[..., None] * d
    n_hit = (hit - centre) / r_s
    cos_inc = np.abs((n_hit * d).sum(-1)) / np.linalg.norm(d, axis=-1)
    err = f.depth[inside] - t[inside]
    assert err.min() > -1e-6
    assert (err <= 1.01 * gap / cos_inc[inside] * np.linalg.norm(d, axis=-1)[inside] + 1e-6).all()
    assert np.median(err) < 2 * gap
    assert (f.instance[inside] == 1).all()


def test_boxes_depth_and_ids_match_exact_ray_casting(draw):
    rng = np.random.default_rng(7)
    scene, boxes = gg.Scene(), []
    pose = look_at([0.0, -6.0, 2.0], [0.0, 0.0, 0.5])
    for i in range(12):
        ext = rng.uniform(0.3, 1.5, 3)
        T = random_pose(rng, 1.5)
        if i == 0:  # seen edge-on: a vertical edge pointing straight at the camera
            T = trimesh.transformations.rotation_matrix(np.pi / 4, [0, 0, 1])
            T[:3, 3] = [0.0, -2.0, 0.5]
        iid = scene.add(trimesh.creation.box(ext), T, semantic=i % 5)
        boxes.append((T, ext / 2, iid))
    with draw(scene) as r:
        f = r.render(SENSOR, pose)
    depth, ids = cast_boxes(SENSOR, pose, boxes)
    core = interior(ids, 1)
    assert core.sum() > 0.5 * ids.size
    assert (f.instance[core] == ids[core]).all()
    hit = core & (ids > 0)
    np.testing.assert_allclose(f.depth[hit], depth[hit], rtol=REL_DEPTH)
    assert (f.depth[core & (ids == 0)] == 0).all()
    sem = {iid: i % 5 for i, (_, _, iid) in enumerate(boxes)}
    assert all(f.semantic[y, x] == sem[f.instance[y, x]] for y, x in zip(*np.nonzero(hit)))
    # disagreement is confined to silhouettes
    assert (f.instance != ids).mean() < 0.01


@pytest.mark.parametrize(
    "point", [[0.0, 0.0, 2.0], [0.9, 0.5, 3.0], [-1.1, -0.6, 2.5], [2.7, 1.3, 6.0]]
)
def test_projected_point_lands_where_cv2_puts_it(draw, point):
    rng = np.random.default_rng(3)
    pose = random_pose(rng, 10.0)
    p_cam = np.array(point)
    side = 0.02 * p_cam[2]  # half side: a ~6 px square facing the camera
    corners_cam = [
        p_cam + side * np.array([sx, sy, 0]) for sx, sy in [(-1, -1), (1, -1), (1, 1), (-1, 1)]
    ]
    scene = gg.Scene()
    scene.add(quad([pose[:3, :3] @ c + pose[:3, 3] for c in corners_cam]), instance=9)
    with draw(scene) as r:
        f = r.render(SENSOR, pose)
    v, u = np.nonzero(f.instance == 9)
    assert len(u) >= 16
    R_wc = pose[:3, :3].T
    rvec, _ = cv2.Rodrigues(R_wc)
    tvec = -R_wc @ pose[:3, 3]
    p_world = pose[:3, :3] @ p_cam + pose[:3, 3]
    uv, _ = cv2.projectPoints(p_world.reshape(1, 3), rvec, tvec, SENSOR.K, None)
    assert np.hypot(u.mean() - uv[0, 0, 0], v.mean() - uv[0, 0, 1]) < 0.5


@pytest.mark.parametrize(
    "dist", [[-0.25, 0.06, 0.001, -0.001, 0.0], [0.1, -0.05, 0.001, -0.002, 0.01, 0.02, 0.0, 0.0]]
)
def test_distorted_render_puts_points_where_cv2_projects_them(dist):
    """A distorted sensor's frame against ground truth: square markers in front of a wall that
    fills the view, their centres projected with cv2.projectPoints through the lens; the
    wall's depth is exactly 3 m at every pixel (z does not change under distortion), so a
    wide render too small for the distorted field shows up as missing rows or columns."""
    sensor = gg.Sensor(320, 240, np.array([[300.0, 0, 161.0], [0, 360.0, 118.5], [0, 0, 1]]), dist)
    targets = np.array(
        [[16, 14], [303, 16], [18, 225], [300, 224], [160, 120], [160, 14], [15, 118], [304, 130]],
        np.float64,
    )
    rays = cv2.undistortPoints(
        targets.reshape(-1, 1, 2),
        sensor.K,
        sensor.dist,
        None,
        None,
        None,
        (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12),
    ).reshape(-1, 2)
    z_face, half = 1.96, 0.02
    scene = gg.Scene()
    scene.add(trimesh.creation.box((40.0, 40.0, 0.2)), [0, 0, 3.1], instance=1)
    centres = np.c_[rays * z_face, np.full(len(rays), z_face)]
    for k, c in enumerate(centres):
        scene.add(
            trimesh.creation.box((2 * half, 2 * half, 0.004)), c + [0, 0, 0.002], instance=10 + k
        )
    f = gg.capture(scene, sensor, [np.eye(4)], seed=0, workers=1)[0]
    assert f.depth.shape == (240, 320)
    assert (f.depth > 0).all()  # the wall fills the whole view
    wall = f.instance == 1
    np.testing.assert_allclose(f.depth[wall], 3.0, rtol=1e-5)
    uv = cv2.projectPoints(
        centres.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), sensor.K, sensor.dist
    )[0].reshape(-1, 2)
    for k, (u, v) in enumerate(uv):
        assert f.instance[int(round(v)), int(round(u))] == 10 + k
        vs, us = np.nonzero(f.instance == 10 + k)
        assert len(us) >= 20
        assert f.depth[int(round(v)), int(round(u))] == pytest.approx(z_face, rel=1e-5)
        # the marker's pixels surround the projected centre (a lens is smooth over ~10 px)
        assert abs(us.mean() - u) < 0.75 and abs(vs.mean() - v) < 0.75
