"""A rig's recording along a trajectory, written in every sequence format and read back by
the field's own readers (semantic-kitti-api, evo, rosbags, mcap with mcap-ros2-support,
pye57, laspy): every point back where the frames put it, every pose as the trajectory had it."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.capture.trajectory import record, schedule
from genie_gl.cloud.unproject import unproject
from genie_gl.motion.rig import Rig, RigSensor, body_from_sensor
from genie_gl.motion.trajectory import Trajectory, planar_poses

pytestmark = pytest.mark.gl


def room() -> gg.Scene:
    scene = gg.Scene()
    floor = trimesh.creation.box((12.0, 12.0, 0.1))
    scene.add(floor, np.diag([1.0, 1, 1, 1]) @ _t(0, 0, -0.05), semantic=0)
    for k, (x, y, c) in enumerate([(3.0, 1.0, 1), (3.0, -1.5, 2), (-2.5, 2.5, 5), (0.5, 3.0, 9)]):
        scene.add(trimesh.creation.box((1.0, 1.2, 1.5)), _t(x, y, 0.75), semantic=c)
    return scene


def _t(x, y, z):
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def small_rig(rate_b: float = 5.0) -> Rig:
    s = gg.Sensor.pinhole(64, 48, 40.0)
    return Rig(
        "pair",
        (
            RigSensor("front", s, body_from_sensor([0.1, 0, 0], pitch_rad=0.2), 5.0),
            RigSensor(
                "left", s, body_from_sensor([0, 0.1, 0], yaw_rad=np.pi / 2, pitch_rad=0.1), rate_b
            ),
        ),
    )


def walk() -> Trajectory:
    t = np.linspace(0.0, 2.0, 21)
    xy = np.stack([-1.0 + 0.8 * t, 0.3 * np.sin(t)], 1)
    return Trajectory(t, planar_poses(xy, 0.4 * t, 1.2))


@pytest.fixture(scope="module")
def recorded():
    scene, rig, tr = room(), small_rig(), walk()
    pairs = list(record(scene, rig, tr, seed=0))
    return scene, rig, tr, pairs


def world_points(frame) -> np.ndarray:
    return unproject(frame).world_xyz


def test_the_schedule_fires_each_sensor_at_its_rate_in_time_order():
    rig, tr = small_rig(rate_b=2.0), walk()
    shots = schedule(rig, tr)
    assert [s.sensor for s in shots if s.time_s == 0.0] == [0, 1]
    assert sum(s.sensor == 0 for s in shots) == 11 and sum(s.sensor == 1 for s in shots) == 5
    assert all(a.time_s <= b.time_s for a, b in zip(shots, shots[1:]))
    for s in shots:
        np.testing.assert_allclose(
            s.world_from_camera, tr.at([s.time_s])[0] @ rig.sensors[s.sensor].body_from_sensor
        )


def test_semantickitti_sequence_poses_and_calib_move_each_scan_onto_the_frames_points(
    recorded, tmp_path
):
    from auxiliary.laserscan import SemLaserScan  # semantic-kitti-api

    from genie_gl.export.semantickitti_sequence import write_recording

    scene, rig, tr, pairs = recorded
    (seq,) = write_recording(rig, tr, pairs, tmp_path)
    # the tools' own parsing (generate_sequential.parse_calibration / parse_poses)
    calib = {}
    for line in (seq / "calib.txt").read_text().splitlines():
        key, content = line.strip().split(":")
        calib[key] = np.r_[
            np.array([float(v) for v in content.strip().split()]).reshape(3, 4), [[0, 0, 0, 1]]
        ]
    Tr = calib["Tr"]
    poses = [
        np.r_[np.array([float(v) for v in line.split()]).reshape(3, 4), [[0, 0, 0, 1]]]
        for line in (seq / "poses.txt").read_text().splitlines()
    ]
    world_pose = np.r_[np.loadtxt(seq / "world_pose.txt").reshape(3, 4), [[0, 0, 0, 1]]]
    times = [float(x) for x in (seq / "times.txt").read_text().split()]
    assert len(poses) == 11 and times == pytest.approx(np.arange(11) * 0.2)
    np.testing.assert_allclose(poses[0], np.eye(4), atol=1e-12)
    np.testing.assert_allclose(calib["P0"][:3, :3], rig.sensors[0].sensor.K, atol=1e-12)
    by_time = {}
    for shot, frame in pairs:
        by_time.setdefault(shot.time_s, []).append(frame)
    scan = SemLaserScan({i: [0, 0, 0] for i in range(20)}, project=False)
    for j, t in enumerate(sorted(by_time)):
        scan.open_scan(str(seq / "velodyne" / f"{j:06d}.bin"))
        scan.open_label(str(seq / "labels" / f"{j:06d}.label"))
        p = np.c_[scan.points.astype(np.float64), np.ones(len(scan.points))]
        world = (world_pose @ np.linalg.inv(Tr) @ poses[j] @ Tr @ p.T).T[:, :3]
        want = np.concatenate([world_points(f) for f in by_time[t]])
        sem = np.concatenate([unproject(f).semantic for f in by_time[t]])
        np.testing.assert_allclose(world, want, atol=2e-6)
        np.testing.assert_array_equal(scan.sem_label, sem)


def test_tum_sequences_read_back_by_evo_and_opencv(recorded, tmp_path):
    import cv2
    from evo.tools import file_interface

    from genie_gl.export.tum import write_recording

    scene, rig, tr, pairs = recorded
    dirs = write_recording(rig, tr, pairs, tmp_path)
    assert [d.name for d in dirs] == ["front", "left"]
    gt = file_interface.read_tum_trajectory_file(str(dirs[0] / "groundtruth.txt"))
    mine = [(s, f) for s, f in pairs if s.sensor == 0]
    assert gt.num_poses == len(mine)
    np.testing.assert_allclose(gt.timestamps, [s.time_s for s, _ in mine], atol=1e-6)
    np.testing.assert_allclose(
        gt.poses_se3, np.array([s.world_from_camera for s, _ in mine]), atol=1e-8
    )
    lines = [line.split() for line in (dirs[0] / "associations.txt").read_text().splitlines()]
    for (shot, frame), (t_rgb, rgb, t_d, depth) in zip(mine, lines):
        d = cv2.imread(str(dirs[0] / depth), cv2.IMREAD_UNCHANGED)
        assert d.dtype == np.uint16
        np.testing.assert_allclose(d / 5000.0, frame.depth, atol=1e-4 + 1e-7)
        assert ((d == 0) == (frame.depth == 0)).all()
        np.testing.assert_array_equal(cv2.imread(str(dirs[0] / rgb))[..., ::-1], frame.rgb)
        np.testing.assert_array_equal(
            cv2.imread(str(dirs[0] / "semantic" / f"{t_rgb}.png"), cv2.IMREAD_UNCHANGED),
            frame.semantic,
        )


def test_mcap_bag_read_back_by_rosbags_and_by_mcap(recorded, tmp_path):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.highlevel import AnyReader

    from genie_gl.export.rosbag import write_recording

    scene, rig, tr, pairs = recorded
    bag = write_recording(rig, tr, pairs, tmp_path / "bag")
    with AnyReader([bag]) as reader:
        topics = {c.topic: c for c in reader.connections}
        assert {
            "/tf",
            "/tf_static",
            "/front/depth/image_raw",
            "/front/depth/camera_info",
            "/front/points",
            "/left/points",
            "/front/color/image_raw",
        } <= set(topics)
        static = [
            reader.deserialize(raw, c.msgtype)
            for c, _, raw in reader.messages([topics["/tf_static"]])
        ]
        assert len(static) == 1
        for t, s in zip(static[0].transforms, rig.sensors):
            assert (t.header.frame_id, t.child_frame_id) == ("base_link", f"{s.name}_optical_frame")
            _check_transform(t.transform, s.body_from_sensor)
        clouds = [
            (ts, reader.deserialize(raw, c.msgtype))
            for c, ts, raw in reader.messages([topics["/left/points"]])
        ]
        mine = [(s, f) for s, f in pairs if s.sensor == 1]
        assert len(clouds) == len(mine)
        for (ts, msg), (shot, frame) in zip(clouds, mine):
            rec = np.frombuffer(
                msg.data,
                dtype=[
                    ("x", "<f4"),
                    ("y", "<f4"),
                    ("z", "<f4"),
                    ("label", "<u2"),
                    ("pad", "<u2"),
                    ("instance", "<u4"),
                ],
            )
            assert [f.name for f in msg.fields] == ["x", "y", "z", "label", "instance"]
            c = unproject(frame.replace(world_from_camera=np.eye(4)))
            np.testing.assert_array_equal(np.stack([rec["x"], rec["y"], rec["z"]], 1), c.xyz)
            np.testing.assert_array_equal(rec["label"], c.semantic)
            assert msg.header.frame_id == "left_optical_frame"
            assert ts == int(round(shot.time_s * 1e9)) + 1
        tfs = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages([topics["/tf"]])]
        times = sorted({s.time_s for s, _ in pairs})
        assert len(tfs) == len(times)
        for msg, t in zip(tfs, times):
            _check_transform(msg.transforms[0].transform, tr.at([t])[0])
    # an independent reader: mcap with the ROS 2 decoder
    (mcap_file,) = bag.glob("*.mcap")
    with open(mcap_file, "rb") as fh:
        depth = [
            (m.log_time, d)
            for _, _, m, d in make_reader(
                fh, decoder_factories=[DecoderFactory()]
            ).iter_decoded_messages(topics=["/front/depth/image_raw"])
        ]
    front = [f for s, f in pairs if s.sensor == 0]
    assert len(depth) == len(front)
    for (_, img), frame in zip(depth, front):
        assert img.encoding == "32FC1" and (img.height, img.width) == frame.depth.shape
        np.testing.assert_array_equal(
            np.frombuffer(bytes(img.data), "<f4").reshape(frame.depth.shape), frame.depth
        )
    with open(mcap_file, "rb") as fh:
        (info,) = [
            d
            for _, _, _, d in make_reader(
                fh, decoder_factories=[DecoderFactory()]
            ).iter_decoded_messages(topics=["/front/depth/camera_info"])
        ][:1]
    np.testing.assert_allclose(np.reshape(info.k, (3, 3)), rig.sensors[0].sensor.K)
    assert info.distortion_model == "plumb_bob"


def _check_transform(t, pose):
    from scipy.spatial.transform import Rotation

    np.testing.assert_allclose(
        [t.translation.x, t.translation.y, t.translation.z], pose[:3, 3], atol=1e-12
    )
    R = Rotation.from_quat([t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w]).as_matrix()
    np.testing.assert_allclose(R, pose[:3, :3], atol=1e-12)


def test_e57_read_back_by_pye57_places_every_scan_with_its_pose(recorded, tmp_path):
    import pye57

    from genie_gl.export.e57 import write_recording

    scene, rig, tr, pairs = recorded
    path = write_recording(rig, tr, pairs, tmp_path / "rec.e57")
    e = pye57.E57(str(path))
    assert e.scan_count == len(pairs)
    labels = np.load(str(path) + ".labels.npz")
    for k, (shot, frame) in enumerate(pairs[:6]):
        d = e.read_scan(
            k, colors=True, intensity=True, transform=True
        )  # pye57 applies the scan's pose
        world = np.stack([d["cartesianX"], d["cartesianY"], d["cartesianZ"]], 1)
        np.testing.assert_allclose(world, world_points(frame), atol=1e-6)
        c = unproject(frame)
        np.testing.assert_array_equal(d["intensity"], c.semantic.astype(np.float32))
        np.testing.assert_array_equal(labels[f"semantic_{k}"], c.semantic)
        np.testing.assert_array_equal(
            np.stack([d["colorRed"], d["colorGreen"], d["colorBlue"]], 1), c.rgb
        )


def test_e57_and_las_clouds_read_back_by_pye57_and_laspy(tmp_path):
    import laspy
    import pye57

    rng = np.random.default_rng(0)
    n = 5000
    origin = np.array([1.0e6, 2.0e6, 0.0])
    cloud = gg.PointCloud(
        rng.uniform(-6, 6, (n, 3)).astype(np.float32),
        rng.integers(0, 10, n).astype(np.uint16),
        rng.integers(0, 2**32 - 1, n, dtype=np.uint64).astype(np.uint32),
        origin,
        rng.integers(0, 256, (n, 3)).astype(np.uint8),
        camera=rng.integers(0, 40, n).astype(np.uint16),
    )
    gg.export(cloud, tmp_path, format="las", name="c")
    las = laspy.read(str(tmp_path / "c.las"))
    assert las.header.version.minor == 4 and las.header.point_format.id == 7
    np.testing.assert_allclose(
        np.stack([las.x, las.y, las.z], 1), cloud.world_xyz, atol=0.5e-4 + 1e-9
    )
    np.testing.assert_array_equal(las.classification, cloud.semantic)
    np.testing.assert_array_equal(las.instance_id, cloud.instance)
    np.testing.assert_array_equal(las.point_source_id, cloud.camera)
    np.testing.assert_array_equal(np.stack([las.red, las.green, las.blue], 1) // 257, cloud.rgb)
    gg.export(cloud, tmp_path, format="e57", name="c")
    d = pye57.E57(str(tmp_path / "c.e57")).read_scan(0, colors=True, intensity=True, transform=True)
    np.testing.assert_allclose(
        np.stack([d["cartesianX"], d["cartesianY"], d["cartesianZ"]], 1),
        cloud.world_xyz,
        rtol=0,
        atol=1e-9 * 2e6,
    )
    big = gg.PointCloud(cloud.xyz, np.full(n, 300, np.uint16), cloud.instance, origin)
    with pytest.raises(gg.GenieError, match="0-255"):
        gg.export(big, tmp_path / "big", format="las")


def test_e57_same_points_same_bytes_other_points_other_guids(tmp_path):
    import pye57

    rng = np.random.default_rng(1)
    n = 2000
    cloud = gg.PointCloud(
        rng.uniform(-6, 6, (n, 3)).astype(np.float32),
        rng.integers(0, 10, n).astype(np.uint16),
        rng.integers(0, 1000, n).astype(np.uint32),
        np.array([3.0, 4.0, 0.0]),
    )
    paths = [
        gg.export(cloud, tmp_path / d, format="e57", name="c") and tmp_path / d / "c.e57"
        for d in "ab"
    ]
    assert paths[0].read_bytes() == paths[1].read_bytes()
    other = gg.PointCloud(cloud.xyz[::-1].copy(), cloud.semantic, cloud.instance, cloud.origin)
    gg.export(other, tmp_path / "c", format="e57", name="c")
    files = [pye57.E57(str(p)) for p in (paths[0], tmp_path / "c" / "c.e57")]
    guids = [f.root["guid"].value() for f in files]
    assert guids[0] != guids[1] and len(set(guids[0])) > 4
