"""Unprojection, merging and every export read back through an independent reader."""
import json

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.cloud import chunks, keep_cloud, random_downsample, to_cloud, unproject, voxel_downsample
from genie_gl.export import semantickitti
from genie_gl.render.projection import look_at


def plane_frame(pose, z=3.0, sensor=None):
    s = sensor or gg.Sensor(64, 48, np.array([[50.0, 0, 30.2], [0, 55.0, 22.7], [0, 0, 1]]))
    d = np.full((s.height, s.width), z, np.float32)
    d[:5] = 0  # no return: no point
    inst = np.where(d > 0, 7, 0).astype(np.uint32)
    return gg.Frame(d, inst, (inst > 0).astype(np.uint16) * 3, None, s, pose)


def test_unprojection_of_an_analytic_frame_is_exact():
    pose = look_at([1.0, 2.0, 3.0], [4.0, -1.0, 0.5])
    f = plane_frame(pose)
    c = unproject(f)
    assert len(c) == (48 - 5) * 64
    cam = (np.linalg.inv(pose) @ np.c_[c.world_xyz, np.ones(len(c))].T).T[:, :3]
    np.testing.assert_allclose(cam[:, 2], 3.0, rtol=1e-6)
    v, u = np.nonzero(f.depth)
    np.testing.assert_allclose(50.0 * cam[:, 0] / cam[:, 2] + 30.2, u, atol=1e-4)
    np.testing.assert_allclose(55.0 * cam[:, 1] / cam[:, 2] + 22.7, v, atol=1e-4)
    assert (c.instance == 7).all() and (c.semantic == 3).all()


def test_far_from_origin_stays_exact():
    shift = np.eye(4)
    shift[:3, 3] = [3e5, -2e5, 10.0]
    near = to_cloud([plane_frame(np.eye(4))])
    far = to_cloud([plane_frame(shift)])
    assert np.abs(far.origin).max() > 1e5
    np.testing.assert_allclose(far.world_xyz - shift[:3, 3], near.world_xyz, atol=1e-4)


@pytest.mark.gl
def test_two_cameras_on_one_box_agree_within_a_millimetre():
    scene = gg.Scene()
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), [0, 0, 0.5], semantic=1)
    s = gg.Sensor.pinhole(160, 120, 140.0)
    frames = gg.capture(scene, s, [look_at([3, 0.3, 2], [0, 0, 0.5]), look_at([2.4, 2.2, 1.8], [0, 0, 0.5])], seed=0)
    c = to_cloud(frames)
    assert set(np.unique(c.camera)) == {0, 1}
    # every point of both cameras lies on the box surface
    p = c.world_xyz - [0, 0, 0.5]
    dist_to_surface = np.abs(np.abs(p).max(1) - 0.5)
    assert dist_to_surface.max() < 1e-3
    from scipy.spatial import cKDTree
    a, b = p[c.camera == 0], p[c.camera == 1]
    d, _ = cKDTree(a).query(b)
    assert np.median(d) < 0.02  # overlapping views of one face


def random_cloud(n=500, seed=0):
    rng = np.random.default_rng(seed)
    return gg.PointCloud(rng.normal(size=(n, 3)).astype(np.float32), rng.integers(0, 10, n).astype(np.uint16),
                         rng.integers(0, 70000, n).astype(np.uint32), np.array([1e5, 2.0, 0.0]),
                         rng.integers(0, 256, (n, 3)).astype(np.uint8))


def test_semantickitti_reads_back_as_its_api_does(tmp_path):
    c = random_cloud()
    b = gg.export(c, tmp_path, format="semantickitti", sequence=3, frame=1)
    assert b == tmp_path / "sequences" / "03" / "velodyne" / "000001.bin"
    scan = np.fromfile(b, dtype=np.float32).reshape(-1, 4)
    label = np.fromfile(tmp_path / "sequences/03/labels/000001.label", dtype=np.uint32)
    np.testing.assert_array_equal(scan[:, :3], c.xyz)
    np.testing.assert_array_equal(label & 0xFFFF, c.semantic)
    np.testing.assert_array_equal(label >> 16, c.instance & 0xFFFF)
    assert semantickitti.pack_labels(np.array([10]), np.array([3]))[0].tobytes() == bytes([0x0A, 0, 3, 0])
    poses = (tmp_path / "sequences/03/poses.txt").read_text().splitlines()
    assert float(poses[1].split()[3]) == pytest.approx(1e5)
    calib = dict(line.split(":") for line in (tmp_path / "sequences/03/calib.txt").read_text().splitlines())
    assert set(calib) == {"P0", "P1", "P2", "P3", "Tr"} and len(calib["Tr"].split()) == 12
    import yaml
    cfg = yaml.safe_load((tmp_path / "genie-gl.yaml").read_text())
    assert {"labels", "color_map", "learning_map", "learning_map_inv", "learning_ignore", "content"} <= set(cfg)


def test_ply_reads_in_plyfile_and_open3d(tmp_path):
    c = random_cloud()
    path = gg.export(c, tmp_path, format="ply")
    import plyfile
    v = plyfile.PlyData.read(str(path))["vertex"].data
    np.testing.assert_array_equal(np.stack([v["x"], v["y"], v["z"]], 1), c.xyz)
    np.testing.assert_array_equal(v["semantic"], c.semantic)
    np.testing.assert_array_equal(v["instance"], c.instance)
    np.testing.assert_array_equal(np.stack([v["red"], v["green"], v["blue"]], 1), c.rgb)
    o3d = pytest.importorskip("open3d")
    pc = o3d.io.read_point_cloud(str(path))
    np.testing.assert_allclose(np.asarray(pc.points), c.xyz, rtol=1e-6)
    np.testing.assert_allclose(np.asarray(pc.colors) * 255, c.rgb, atol=0.5)


def test_pcd_and_npz_read_back(tmp_path):
    c = random_cloud()
    z = np.load(gg.export(c, tmp_path, format="npz"))
    np.testing.assert_array_equal(z["xyz"], c.xyz)
    np.testing.assert_array_equal(z["origin"], c.origin)
    path = gg.export(c, tmp_path, format="pcd")
    raw = path.read_bytes()
    header, body = raw.split(b"DATA binary\n", 1)
    rec = np.frombuffer(body, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<u4"),
                                     ("label", "<u4"), ("instance", "<u4")])
    np.testing.assert_array_equal(rec["label"], c.semantic)
    o3d = pytest.importorskip("open3d")
    np.testing.assert_allclose(np.asarray(o3d.io.read_point_cloud(str(path)).points), c.xyz, rtol=1e-6)
    with pytest.raises(gg.ConfigError, match="did you mean 'ply'"):
        gg.export(c, tmp_path, format="plyy")


def test_exports_are_byte_identical_for_the_same_input(tmp_path):
    c = random_cloud()
    for fmt in ("ply", "pcd", "npz"):
        a = gg.export(c, tmp_path / "a", format=fmt).read_bytes()
        b = gg.export(c, tmp_path / "b", format=fmt).read_bytes()
        assert a == b


def test_sampling_and_cleaning():
    c = random_cloud(5000)
    v = voxel_downsample(c, 0.5)
    keys = np.floor(v.xyz / 0.5).astype(int)
    assert len(np.unique(keys, axis=0)) == len(v)
    s = to_cloud([plane_frame(np.eye(4))], max_points=100, rng=np.random.default_rng(0))
    assert len(s) == 100
    assert keep_cloud(c, min_points=10)[0]
    assert keep_cloud(c.select(c.semantic == 0), min_points=1) == (False, "background only")
    assert not keep_cloud(c, min_points=10**6)[0]


def reference_points(f):
    """World points of a frame's valid pixels from first principles, float64: K⁻¹ (skew
    included) for an ideal lens, OpenCV's undistortPoints for a distorted one; scale by depth,
    apply the pose."""
    import cv2
    s = f.sensor
    v, u = np.nonzero(f.depth)
    if np.any(s.dist):
        xy = cv2.undistortPoints(np.stack([u, v], -1).astype(np.float64).reshape(-1, 1, 2), s.K, s.dist, None,
                                 None, None, (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)).reshape(-1, 2)
    else:
        xy = (np.linalg.inv(s.K) @ np.stack([u, v, np.ones_like(u)]).astype(np.float64))[:2].T
    d = f.depth[v, u].astype(np.float64)
    cam = np.c_[xy * d[:, None], d]
    return cam @ f.world_from_camera[:3, :3].T + f.world_from_camera[:3, 3]


@pytest.mark.parametrize("lens", ["pinhole", "skew", "distorted"])
def test_unprojection_matches_first_principles_for_every_lens(lens):
    K = np.array([[50.0, 0, 30.2], [0, 55.0, 22.7], [0, 0, 1]])
    dist = np.zeros(5)
    if lens == "skew":
        K[0, 1] = 0.8
    if lens == "distorted":
        dist = np.array([-0.2, 0.05, 0.001, -0.002, 0.0])
    s = gg.Sensor(64, 48, K, dist=dist)
    rng = np.random.default_rng(1)
    d = rng.uniform(0.5, 20, (48, 64)).astype(np.float32)
    d[rng.random(d.shape) < 0.3] = 0  # scattered holes: the compaction must skip exactly these
    d[-1, -1] = 0  # the last pixel invalid: the spare slot takes its write
    inst = rng.integers(1, 2**31, d.shape).astype(np.uint32)
    sem = rng.integers(0, 2**16, d.shape).astype(np.uint16)
    rgb = rng.integers(0, 256, (48, 64, 3)).astype(np.uint8)
    f = gg.Frame(d, inst, sem, rgb, s, look_at([1.0, 2.0, 3.0], [4.0, -1.0, 0.5]))
    c = unproject(f, camera_index=3)
    m = d > 0
    np.testing.assert_allclose(c.world_xyz, reference_points(f), atol=2e-5 * 20)
    assert (c.instance == inst[m]).all() and (c.semantic == sem[m]).all() and (c.rgb == rgb[m]).all()
    assert (c.camera == 3).all()
    # merging writes every frame into its slice of one array: same as concatenating
    g = f.replace(depth=np.roll(d, 7), world_from_camera=np.eye(4))
    merged = to_cloud([f, g, f])
    parts = [unproject(x, origin=merged.origin, camera_index=i) for i, x in enumerate([f, g, f])]
    for name in ("xyz", "semantic", "instance", "rgb", "camera"):
        np.testing.assert_array_equal(getattr(merged, name), np.concatenate([getattr(p, name) for p in parts]))


def test_chunks_down_sample_each_tile_as_random_downsample_does():
    c = random_cloud(20000)
    eager = [(k, random_downsample(t, 300, rng=r)) for r in [np.random.default_rng(5)] for k, t in chunks(c, 2.5)]
    lazy = chunks(c, 2.5, max_points=300, rng=np.random.default_rng(5))
    assert [k for k, _ in lazy] == [k for k, _ in eager]
    for (_, a), (_, b) in zip(lazy, eager):
        np.testing.assert_array_equal(a.xyz, b.xyz)
        np.testing.assert_array_equal(a.instance, b.instance)
    # tiles: every point in its tile, tiles in (i, j) order, points in their original order
    tiles = chunks(c, 2.5)
    assert sum(len(t) for _, t in tiles) == len(c)
    assert [k for k, _ in tiles] == sorted(k for k, _ in tiles)
    for (i, j), t in tiles:
        ij = np.floor(t.xyz[:, :2] / 2.5)
        assert (ij == [i, j]).all()
