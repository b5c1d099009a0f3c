"""Unprojection, merging and every export read back through an independent reader."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.cloud import (
    chunks,
    keep_cloud,
    random_downsample,
    to_cloud,
    unproject,
    voxel_downsample,
)
from genie_gl.export import semantickitti
from genie_gl.sensors.pose import look_at


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
    frames = gg.capture(
        scene, s, [look_at([3, 0.3, 2], [0, 0, 0.5]), look_at([2.4, 2.2, 1.8], [0, 0, 0.5])], seed=0
    )
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
    return gg.PointCloud(
        rng.normal(size=(n, 3)).astype(np.float32),
        rng.integers(0, 10, n).astype(np.uint16),
        rng.integers(0, 70000, n).astype(np.uint32),
        np.array([1e5, 2.0, 0.0]),
        rng.integers(0, 256, (n, 3)).astype(np.uint8),
    )


def test_semantickitti_reads_back_as_its_api_does(tmp_path):
    c = random_cloud()
    b = gg.export(c, tmp_path, format="semantickitti", sequence=3, frame=1)
    assert b == tmp_path / "sequences" / "03" / "velodyne" / "000001.bin"
    scan = np.fromfile(b, dtype=np.float32).reshape(-1, 4)
    label = np.fromfile(tmp_path / "sequences/03/labels/000001.label", dtype=np.uint32)
    np.testing.assert_array_equal(scan[:, :3], c.xyz)
    np.testing.assert_array_equal(label & 0xFFFF, c.semantic)
    # ids beyond 16 bits: renumbered in order within the scan, the table beside it restores them
    ids = np.unique(c.instance)
    np.testing.assert_array_equal(label >> 16, np.searchsorted(ids, c.instance) + (ids[0] != 0))
    np.testing.assert_array_equal(semantickitti.read(b)[2], c.instance)
    assert semantickitti.pack_labels(np.array([10]), np.array([3]))[0].tobytes() == bytes(
        [0x0A, 0, 3, 0]
    )
    poses = (tmp_path / "sequences/03/poses.txt").read_text().splitlines()
    assert float(poses[1].split()[3]) == pytest.approx(1e5)
    calib = dict(
        line.split(":") for line in (tmp_path / "sequences/03/calib.txt").read_text().splitlines()
    )
    assert set(calib) == {"P0", "P1", "P2", "P3", "Tr"} and len(calib["Tr"].split()) == 12
    import yaml

    cfg = yaml.safe_load((tmp_path / "genie-gl.yaml").read_text())
    assert {
        "labels",
        "color_map",
        "learning_map",
        "learning_map_inv",
        "learning_ignore",
        "content",
    } <= set(cfg)
    # content: each class's share of the points (SemanticKITTI's frequencies), from the first scan
    for k, share in cfg["content"].items():
        assert share == pytest.approx(np.mean(c.semantic == k))


def test_semantickitti_label_words_are_the_documented_bits(tmp_path):
    """The .label file holds, per point, the little-endian uint32 semantic + 65536 · instance
    (SemanticKITTI's README: lower 16 bits the class, upper 16 the instance), written out by
    hand here for ids that set the high bits of both halves."""
    sem = np.array([0, 1, 9, 255, 40000, 65535], np.uint16)
    inst = np.array(
        [0, 1, 2, 32769, 65535, 4465], np.uint32
    )  # ids beyond 16 bits: renumbered (test_field_readers)
    words = [
        0,
        1 + 65536,
        9 + 2 * 65536,
        255 + 32769 * 65536,
        40000 + 65535 * 65536,
        65535 + 4465 * 65536,
    ]
    raw = b"".join(int(w).to_bytes(4, "little") for w in words)
    assert semantickitti.pack_labels(sem, inst).tobytes() == raw
    c = gg.PointCloud(np.arange(18, dtype=np.float32).reshape(6, 3), sem, inst, np.zeros(3))
    gg.export(c, tmp_path, format="semantickitti")
    assert (tmp_path / "sequences/00/labels/000000.label").read_bytes() == raw
    xyz, s2, i2 = semantickitti.read(tmp_path / "sequences/00/velodyne/000000.bin")
    np.testing.assert_array_equal(s2, sem)
    np.testing.assert_array_equal(i2, inst)


def test_ply_reads_in_plyfile_and_open3d(tmp_path):
    c = random_cloud()
    path = gg.export(c, tmp_path, format="ply")
    import plyfile

    v = plyfile.PlyData.read(str(path))["vertex"].data
    np.testing.assert_array_equal(np.stack([v["x"], v["y"], v["z"]], 1), c.xyz)
    np.testing.assert_array_equal(v["semantic"], c.semantic)
    np.testing.assert_array_equal(v["instance"], c.instance)
    np.testing.assert_array_equal(np.stack([v["red"], v["green"], v["blue"]], 1), c.rgb)
    import open3d as o3d  # installed by the test extra: a missing reader fails, never skips

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
    rec = np.frombuffer(
        body,
        dtype=[
            ("x", "<f4"),
            ("y", "<f4"),
            ("z", "<f4"),
            ("rgb", "<u4"),
            ("label", "<u4"),
            ("instance", "<u4"),
        ],
    )
    np.testing.assert_array_equal(rec["label"], c.semantic)
    import open3d as o3d  # installed by the test extra: a missing reader fails, never skips

    np.testing.assert_allclose(
        np.asarray(o3d.io.read_point_cloud(str(path)).points), c.xyz, rtol=1e-6
    )
    with pytest.raises(gg.ConfigError, match="did you mean 'ply'"):
        gg.export(c, tmp_path, format="plyy")


def test_pcd_header_and_packed_colour_as_pcl_reads_them(tmp_path):
    """PCL's header words (upper-case types) and rgb packed as 0x00RRGGBB, written out by hand
    and read back by Open3D; the origin in the comment; npz and ply with normals round-trip."""
    import open3d as o3d
    import plyfile

    from genie_gl.export import npz

    c = random_cloud(300)
    c = gg.PointCloud(
        c.xyz,
        c.semantic,
        c.instance,
        c.origin,
        c.rgb,
        np.random.default_rng(5).normal(size=(300, 3)).astype(np.float32),
    )
    pcd_path = gg.export(c, tmp_path, format="pcd")
    header, body = pcd_path.read_bytes().split(b"DATA binary\n", 1)
    lines = header.decode().splitlines()
    assert lines[1:] == [
        "VERSION 0.7",
        "FIELDS x y z rgb label instance",
        "SIZE 4 4 4 4 4 4",
        "TYPE F F F U U U",
        "COUNT 1 1 1 1 1 1",
        "WIDTH 300",
        "HEIGHT 1",
        "VIEWPOINT 0 0 0 1 0 0 0",
        "POINTS 300",
    ]
    assert lines[0].endswith(
        "origin " + " ".join(f"{float(v):.17g}" for v in c.origin)
    )  # plain numbers, no reprs
    rgb = np.frombuffer(body, "<u4").reshape(300, 6)[:, 3]
    r, g, b = (c.rgb[:, k].astype(np.int64) for k in range(3))
    np.testing.assert_array_equal(rgb, r * 65536 + g * 256 + b)
    pc = o3d.io.read_point_cloud(str(pcd_path))
    np.testing.assert_allclose(np.asarray(pc.colors) * 255, c.rgb, atol=0.5)
    v = plyfile.PlyData.read(str(gg.export(c, tmp_path, format="ply")))
    np.testing.assert_array_equal(
        np.stack([v["vertex"][k] for k in ("nx", "ny", "nz")], 1), c.normal
    )
    origin = [float(x) for x in v.comments[1].split()[1:]]
    np.testing.assert_array_equal(origin, c.origin)
    back = npz.read(gg.export(c, tmp_path, format="npz"))
    for k in ("xyz", "origin", "semantic", "instance", "rgb", "normal"):
        np.testing.assert_array_equal(getattr(back, k), getattr(c, k))


def test_semantickitti_sequence_files_for_several_scans(tmp_path):
    """poses.txt and times.txt get one line per scan, in scan order, whatever order the scans
    are written in; calib.txt is the identity for every matrix; scans read back as float32."""
    clouds = [
        gg.PointCloud(
            random_cloud(50, seed=k).xyz,
            np.full(50, k, np.uint16),
            np.zeros(50, np.uint32),
            np.array([10.0 * k, -1.0, 0.5]),
        )
        for k in range(3)
    ]
    for k in (1, 0, 2):
        semantickitti.write(clouds[k], tmp_path, sequence=4, frame=k)
    seq = tmp_path / "sequences" / "04"
    poses = [
        np.array(line.split(), float).reshape(3, 4)
        for line in (seq / "poses.txt").read_text().splitlines()
    ]
    assert len(poses) == 3
    for k, P in enumerate(poses):
        np.testing.assert_array_equal(P, np.c_[np.eye(3), clouds[k].origin])
    assert [float(t) for t in (seq / "times.txt").read_text().splitlines()] == [0.0, 1.0, 2.0]
    for line in (seq / "calib.txt").read_text().splitlines():
        name, values = line.split(":")
        np.testing.assert_array_equal(np.array(values.split(), float).reshape(3, 4), np.eye(4)[:3])
    xyz, sem, inst = semantickitti.read(seq / "velodyne" / "000002.bin")
    assert xyz.dtype == np.float32 and xyz.shape == (50, 3)
    np.testing.assert_array_equal(xyz, clouds[2].xyz)
    assert (sem == 2).all()
    raw = np.fromfile(seq / "velodyne" / "000002.bin", "<f4").reshape(-1, 4)
    assert (raw[:, 3] == 0).all()  # remission: none


def test_exports_are_byte_identical_for_the_same_input(tmp_path):
    c = random_cloud()
    for fmt in ("ply", "pcd", "npz"):
        a = gg.export(c, tmp_path / "a", format=fmt).read_bytes()
        b = gg.export(c, tmp_path / "b", format=fmt).read_bytes()
        assert a == b


def test_sampling_and_cleaning():
    c = random_cloud(5000)
    v = voxel_downsample(c, 0.5)
    # the truth, one point at a time: the first point met in each occupied voxel, in order
    first: dict[tuple, int] = {}
    for i, p in enumerate(c.xyz.astype(np.float64)):
        first.setdefault(tuple(int(k) for k in np.floor(p / 0.5)), i)
    keep = np.array(sorted(first.values()))
    assert len(v) == len(first) > 500
    np.testing.assert_array_equal(v.xyz, c.xyz[keep])
    np.testing.assert_array_equal(v.semantic, c.semantic[keep])
    np.testing.assert_array_equal(v.instance, c.instance[keep])
    np.testing.assert_array_equal(v.rgb, c.rgb[keep])
    full = to_cloud([plane_frame(np.eye(4))])
    s = to_cloud([plane_frame(np.eye(4))], max_points=100, rng=np.random.default_rng(0))
    assert len(s) == 100
    # a subset of the full cloud, without repeats, in the cloud's order
    idx = [int(np.flatnonzero((full.xyz == p).all(1))[0]) for p in s.xyz]
    assert len(set(idx)) == 100 and idx == sorted(idx)
    assert random_downsample(full, 10**6, rng=np.random.default_rng(0)) is full
    assert keep_cloud(c, min_points=10)[0]
    assert keep_cloud(c.select(c.semantic == 0), min_points=1) == (False, "background only")
    assert keep_cloud(c, min_points=10**6) == (False, f"5000 points < {10**6}")
    assert keep_cloud(c, min_points=5000)[0]
    labelled = c.select(
        np.r_[np.flatnonzero(c.semantic != 0)[:10], np.flatnonzero(c.semantic == 0)[:190]]
    )
    assert keep_cloud(labelled, min_points=1, min_labelled_share=0.05)[0]  # 10 / 200 = 0.05
    assert keep_cloud(labelled, min_points=1, min_labelled_share=0.051) == (
        False,
        "labelled share 0.050 < 0.051",
    )


def test_voxel_downsample_keeps_the_first_point_of_each_voxel_by_hand():
    """Nine points in 0.5 m voxels, the voxel of each worked out by hand: the first point met
    in each voxel stays, in order. Voxels that differ in one index only (x, y or z, negative
    included) are distinct: a key with a wrong stride (x·ny + y·nz + z) joins (1, 0, 0) with
    (0, 1, 0) and keeps fewer."""
    xyz = np.array(
        [
            [0.1, 0.1, 0.1],  # 0: voxel (0, 0, 0)
            [0.6, 0.1, 0.1],  # 1: (1, 0, 0)
            [0.2, 0.3, 0.4],  # 2: (0, 0, 0) again: dropped
            [0.1, 0.6, 0.1],  # 3: (0, 1, 0)
            [0.1, 0.1, 0.6],  # 4: (0, 0, 1)
            [-0.1, 0.1, 0.1],  # 5: (-1, 0, 0)
            [0.7, 0.4, 0.2],  # 6: (1, 0, 0) again: dropped
            [1.1, 0.6, 0.6],  # 7: (2, 1, 1)
            [0.4, 0.4, 0.4],
        ],
        np.float32,
    )  # 8: (0, 0, 0) again: dropped
    n = len(xyz)
    c = gg.PointCloud(
        xyz, np.arange(n, dtype=np.uint16), np.arange(n, dtype=np.uint32) + 10, np.zeros(3)
    )
    v = voxel_downsample(c, 0.5)
    assert v.semantic.tolist() == [0, 1, 3, 4, 5, 7]
    assert v.instance.tolist() == [10, 11, 13, 14, 15, 17]
    np.testing.assert_array_equal(v.xyz, xyz[[0, 1, 3, 4, 5, 7]])
    # a 3 x 4 x 5 block of voxel centres, one point each, shuffled: every one of the 60 kept
    g = np.stack(np.meshgrid(np.arange(3), np.arange(4), np.arange(5), indexing="ij"), -1).reshape(
        -1, 3
    )
    g = (g[np.random.default_rng(1).permutation(len(g))] * 0.5 + 0.25).astype(np.float32)
    kept = voxel_downsample(
        gg.PointCloud(g, np.zeros(60, np.uint16), np.zeros(60, np.uint32), np.zeros(3)), 0.5
    )
    np.testing.assert_array_equal(kept.xyz, g)


def reference_points(f):
    """World points of a frame's valid pixels from first principles, float64: K⁻¹ (skew
    included) for an ideal lens, OpenCV's undistortPoints for a distorted one; scale by depth,
    apply the pose."""
    import cv2

    s = f.sensor
    v, u = np.nonzero(f.depth)
    if np.any(s.dist):
        xy = cv2.undistortPoints(
            np.stack([u, v], -1).astype(np.float64).reshape(-1, 1, 2),
            s.K,
            s.dist,
            None,
            None,
            None,
            (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12),
        ).reshape(-1, 2)
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
    assert (
        (c.instance == inst[m]).all() and (c.semantic == sem[m]).all() and (c.rgb == rgb[m]).all()
    )
    assert (c.camera == 3).all()
    # merging writes every frame into its slice of one array: same as concatenating
    g = f.replace(depth=np.roll(d, 7), world_from_camera=np.eye(4))
    merged = to_cloud([f, g, f])
    parts = [unproject(x, origin=merged.origin, camera_index=i) for i, x in enumerate([f, g, f])]
    for name in ("xyz", "semantic", "instance", "rgb", "camera"):
        np.testing.assert_array_equal(
            getattr(merged, name), np.concatenate([getattr(p, name) for p in parts])
        )


def test_chunks_down_sample_each_tile_as_random_downsample_does():
    c = random_cloud(20000)
    eager = [
        (k, random_downsample(t, 300, rng=r))
        for r in [np.random.default_rng(5)]
        for k, t in chunks(c, 2.5)
    ]
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


def test_single_frame_unprojection_with_normals_colour_and_an_origin():
    """unproject(frame, origin=, camera_index=): points relative to the origin, normals turned
    into the world by the pose (float64 truth), colours and the camera index per point."""
    rng = np.random.default_rng(8)
    pose = look_at([2.0, -3.0, 1.5], [0.0, 0.5, 0.2])
    s = gg.Sensor(40, 30, np.array([[35.0, 0, 19.5], [0, 37.0, 14.5], [0, 0, 1]]))
    d = rng.uniform(0.3, 4, (30, 40)).astype(np.float32)  # below 1 m too
    d[rng.random(d.shape) < 0.2] = 0
    n_cam = rng.normal(size=(30, 40, 3)).astype(np.float32)
    rgb = rng.integers(0, 256, (30, 40, 3)).astype(np.uint8)
    ids = rng.integers(1, 9, d.shape)
    f = gg.Frame(d, ids.astype(np.uint32), ids.astype(np.uint16), rgb, s, pose, n_cam)
    origin = np.array([1e4, -2.0, 3.0])
    c = unproject(f, origin=origin, camera_index=5)
    valid = d > 0
    assert len(c) == valid.sum()
    np.testing.assert_array_equal(c.origin, origin)
    np.testing.assert_allclose(
        c.world_xyz, reference_points(f), atol=2e-3
    )  # float32 relative to 1e4
    np.testing.assert_allclose(
        c.normal, n_cam[valid].astype(np.float64) @ pose[:3, :3].T, atol=1e-5
    )
    np.testing.assert_array_equal(c.rgb, rgb[valid])
    np.testing.assert_array_equal(c.instance, ids[valid])
    assert (c.camera == 5).all() and c.camera.dtype == np.uint16
    plain = unproject(f.replace(normal=None, rgb=None))
    assert plain.normal is None and plain.rgb is None and not plain.origin.any()
    np.testing.assert_allclose(plain.world_xyz, reference_points(f), atol=1e-5)
