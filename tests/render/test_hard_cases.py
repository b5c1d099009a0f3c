"""Hard cases stay numerically stable: depth range, huge coordinates, grazing angles, bad meshes."""

import logging

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.sensors.pose import look_at

from .conftest import cast_boxes, interior, ray_dirs

pytestmark = pytest.mark.gl

SENSOR = gg.Sensor.pinhole(128, 96, 110.0)


def quad(corners):
    return gg.Mesh(np.asarray(corners, float), np.array([[0, 1, 2], [0, 2, 3]]))


def facing_quad(z, x0, x1, y0, y1):
    return quad([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]])


def test_planes_1mm_apart_at_50m_with_far_near_ratio_1e5(draw):
    sensor = gg.Sensor.pinhole(128, 96, 110.0, near_m=0.1, far_m=1e4)
    scene = gg.Scene()
    scene.add(facing_quad(50.0, -40, 40, -40, 40), instance=1)  # behind, full view
    scene.add(facing_quad(49.999, -40, 0, -40, 40), instance=2)  # 1 mm in front, left half
    with draw(scene) as r:
        f = r.render(sensor, np.eye(4))
    left, right = f.instance[:, :62], f.instance[:, 66:]
    assert (left == 2).all() and (right == 1).all()
    np.testing.assert_allclose(f.depth[:, :62], 49.999, rtol=1e-6)
    np.testing.assert_allclose(f.depth[:, 66:], 50.0, rtol=1e-6)


@pytest.mark.parametrize("offset", [1e5, 1e6])
def test_scene_far_from_origin_renders_to_the_millimetre(draw, offset):
    rng = np.random.default_rng(5)
    pose0 = look_at([0.3, -7.0, 2.5], [0.0, 0.0, 0.5])
    boxes, scene0, scene1 = [], gg.Scene(), gg.Scene()
    shift = np.eye(4)
    shift[:3, 3] = [offset, -offset, 0.0]
    for _ in range(8):
        ext = rng.uniform(0.3, 1.5, 3)
        T = trimesh.transformations.rotation_matrix(rng.uniform(0, np.pi), [0, 0, 1])
        T[:3, 3] = rng.uniform(-2, 2, 3)
        iid = scene0.add(trimesh.creation.box(ext), T)
        scene1.add(trimesh.creation.box(ext), shift @ T)
        boxes.append((T, ext / 2, iid))
    with draw(scene0) as r0, draw(scene1) as r1:
        f0 = r0.render(SENSOR, pose0)
        f1 = r1.render(SENSOR, shift @ pose0)
    depth, ids = cast_boxes(SENSOR, pose0, boxes)
    core = interior(ids) & (ids > 0)
    assert (f1.instance[core] == ids[core]).all()
    assert np.abs(f1.depth[core] - depth[core]).max() < 1e-3  # the millimetre
    np.testing.assert_allclose(f1.depth[core], f0.depth[core], rtol=1e-5)


def test_grazing_incidence_85_degrees(draw):
    # a floor seen at 85 deg incidence at the image centre
    tilt = np.radians(85.0)
    pose = np.eye(4)
    pose[:3, :3] = trimesh.transformations.rotation_matrix(-(np.pi / 2 - tilt), [1, 0, 0])[:3, :3]
    h = 1.0
    pose[:3, 3] = [0, 0, 0]
    # plane y = h in the world = camera frame rotated; build it in world coordinates
    scene = gg.Scene()
    scene.add(
        quad([[-500, h, 0.0], [500, h, 0.0], [500, h, 2000.0], [-500, h, 2000.0]]), instance=3
    )
    with draw(scene) as r:
        f = r.render(SENSOR, pose)
    d = ray_dirs(SENSOR) @ pose[:3, :3].T  # world rays (camera rays with z = 1, rotated)
    with np.errstate(divide="ignore"):
        t = h / d[..., 1]
    expected = np.where((t > 0) & (t * d[..., 2] < 2000) & (t < 1e4), t, 0.0)
    hit = interior((expected > 0).astype(np.uint32), 1) & (expected > 0)
    assert hit.sum() > 1000 and np.isfinite(f.depth).all()
    np.testing.assert_allclose(f.depth[hit], expected[hit], rtol=1e-5)
    centre = SENSOR.height // 2, SENSOR.width // 2
    n = np.array([0.0, 1.0, 0.0]) @ pose[:3, :3]  # plane normal in camera frame
    assert abs(np.degrees(np.arccos(abs(n[2])))) == pytest.approx(85.0, abs=0.01)
    assert f.instance[centre] == 3


def test_camera_inside_a_closed_mesh_sees_its_inner_walls(draw):
    scene = gg.Scene()
    T = np.eye(4)
    iid = scene.add(trimesh.creation.box((4.0, 3.0, 2.5)), T)
    pose = look_at([0.4, -0.3, 0.2], [1.0, 1.0, 0.0])
    with draw(scene) as r:
        f = r.render(SENSOR, pose, normals=True)
    depth, ids = cast_boxes(SENSOR, pose, [(T, np.array([2.0, 1.5, 1.25]), iid)])
    assert (ids == iid).all() and (f.instance == iid).all()
    rel = np.abs(f.depth / depth - 1)
    assert np.median(rel) < 1e-6 and rel.max() < 5e-5  # the worst pixels sit on wall creases
    assert np.isfinite(f.normal).all()


def test_empty_scene_gives_no_returns(draw):
    with draw(gg.Scene()) as r:
        f = r.render(SENSOR, np.eye(4))
    assert not f.depth.any() and not f.instance.any() and not f.semantic.any()
    assert f.depth.dtype == np.float32 and f.instance.dtype == np.uint32


def test_nan_and_degenerate_triangles_are_skipped_with_a_warning(draw, caplog):
    v = np.array([[-1, -1, 3], [1, -1, 3], [1, 1, 3], [-1, 1, 3], [np.nan, 0, 3], [0, 0, 3]], float)
    f = np.array([[0, 1, 2], [0, 2, 3], [0, 4, 1], [5, 5, 2], [0, 1, 1]])
    scene = gg.Scene()
    scene.add(gg.Mesh(v, f), instance=4)
    with caplog.at_level(logging.WARNING), draw(scene) as r:
        frame = r.render(SENSOR, np.eye(4), normals=True)
    assert "skipped 3 of 5 faces" in caplog.text
    assert np.isfinite(frame.depth).all() and np.isfinite(frame.normal).all()
    np.testing.assert_allclose(frame.depth[frame.depth > 0], 3.0, rtol=1e-6)
    assert (frame.depth > 0).sum() == pytest.approx((2 * 110 / 3) ** 2, rel=0.05)


def test_objects_beyond_far_and_before_near_are_clipped(draw):
    sensor = gg.Sensor.pinhole(64, 48, 50.0, near_m=1.0, far_m=20.0)
    scene = gg.Scene()
    scene.add(facing_quad(30.0, -50, 50, -50, 50), instance=1)  # beyond far
    scene.add(facing_quad(0.5, -0.1, 0.1, -0.1, 0.1), instance=2)  # before near
    scene.add(facing_quad(10.0, 0, 5, -5, 5), instance=3)
    with draw(scene) as r:
        f = r.render(sensor, np.eye(4))
    assert set(np.unique(f.instance)) == {0, 3}
    assert f.depth.max() == pytest.approx(10.0)


def test_depth_only_mode_matches_full_mode(draw):
    scene = gg.Scene()
    scene.add(trimesh.creation.icosphere(3, radius=1.0), [0, 0, 4.0])
    with draw(scene) as r:
        full = r.render(SENSOR, np.eye(4))
        fast = r.render(SENSOR, np.eye(4), depth_only=True)
    assert fast.rgb is None
    np.testing.assert_array_equal(full.depth, fast.depth)
    np.testing.assert_array_equal(full.instance, fast.instance)
