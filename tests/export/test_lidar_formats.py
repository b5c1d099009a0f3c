"""Every scanner format read back by its field's reader with ring, time, intensity and
returns intact: PCD (Open3D), PLY (plyfile), SemanticKITTI (semantic-kitti-api's reader),
LAS 1.4 (laspy), E57 (pye57 and libE57Format), ROS 2 PointCloud2 (rosbags).

The scans here are made analytically (a VLP-16 moving over a floor plane, each point where
its beam meets the floor) so the formats are tested apart from the ray engine."""

from dataclasses import replace

import numpy as np
import pytest

from genie_gl.capture.scan_record import Scan
from genie_gl.cloud.scan_cloud import scan_cloud
from genie_gl.export.lidar_files import write_scans_e57, write_scans_las
from genie_gl.export.lidar_sequences import point_fields, write_kitti_sequence, write_scan_bag
from genie_gl.export.pcd import write as write_pcd
from genie_gl.export.ply import write as write_ply
from genie_gl.sensors.beams import scan_beams
from genie_gl.effects.scanner_profile import load_scanner
from genie_gl.motion.trajectory import Trajectory, planar_poses

HEIGHT = 1.5
SPEED = 2.0  # m/s along x


def floor_scan(scanner, traj, start_s, index, head="top", head_index=0):
    """The scan of ``scanner`` on ``traj`` over the floor z = 0: exact, every 7th beam with a
    second echo 1.5 m behind (as a footprint straddling an edge gives)."""
    b = scan_beams(scanner, lambda t: traj.at(t), start_s, index=index)
    hit = b.directions[:, 2] < -0.05
    idx = np.flatnonzero(hit)
    r = -b.origins[idx, 2] / b.directions[idx, 2]
    two = (idx % 7) == 0
    beam = np.r_[idx, idx[two]]
    rng_m = np.r_[r, r[two] + 1.5]
    order = np.lexsort((rng_m, beam))
    beam, rng_m = beam[order], rng_m[order]
    counts = np.bincount(beam, minlength=len(b))[beam]
    number = np.r_[1, (beam[1:] == beam[:-1]).astype(int) + 1]
    cos = np.abs(b.directions[beam, 2])
    return Scan(
        head,
        head_index,
        scanner,
        index,
        start_s,
        b.origins[beam] + b.directions[beam] * rng_m[:, None],
        b.sensor_origins[beam] + b.sensor_directions[beam] * rng_m[:, None],
        rng_m,
        (0.4 * cos).astype(np.float32),
        b.ring[beam],
        b.channel[beam],
        b.column[beam],
        b.time_s[beam],
        b.azimuth_rad[beam],
        number.astype(np.uint8),
        counts.astype(np.uint8),
        np.full(len(beam), 3, np.uint16),
        (10 + b.ring[beam]).astype(np.uint32),
        b.firing_poses,
        len(b),
    )


@pytest.fixture(scope="module")
def scans():
    s = replace(load_scanner("velodyne_vlp16"), effects=())
    traj = Trajectory(
        np.array([0.0, 1.0]),
        planar_poses(np.array([[0.0, 0.0], [SPEED, 0.0]]), np.zeros(2), HEIGHT),
    )
    return [floor_scan(s, traj, 0.1 * k, k) for k in range(3)]


def test_pcd_has_velodyne_fields_read_by_open3d(scans, tmp_path):
    o3d = pytest.importorskip("open3d")
    c = scan_cloud(scans[0], "raw")
    path = write_pcd(c, tmp_path / "scan.pcd")
    header = path.read_bytes()[:400].decode(errors="replace")
    assert "FIELDS x y z label instance intensity ring time return_number returns" in header
    assert "SIZE 4 4 4 4 4 4 2 4 1 1" in header and "TYPE F F F U U F U F U U" in header
    pc = o3d.t.io.read_point_cloud(str(path))
    np.testing.assert_array_equal(pc.point["positions"].numpy(), c.xyz)
    np.testing.assert_array_equal(pc.point["ring"].numpy().ravel(), c.ring)
    np.testing.assert_array_equal(pc.point["time"].numpy().ravel(), c.time.astype(np.float32))
    np.testing.assert_array_equal(pc.point["intensity"].numpy().ravel(), c.intensity)
    np.testing.assert_array_equal(pc.point["returns"].numpy().ravel(), c.returns)


def test_ply_has_ring_time_and_returns_read_by_plyfile(scans, tmp_path):
    plyfile = pytest.importorskip("plyfile")
    c = scan_cloud(scans[0], "raw")
    v = plyfile.PlyData.read(str(write_ply(c, tmp_path / "scan.ply")))["vertex"]
    np.testing.assert_array_equal(v["ring"], c.ring)
    np.testing.assert_array_equal(v["time"], c.time)
    np.testing.assert_array_equal(v["return_number"], c.return_number)
    np.testing.assert_array_equal(v["returns"], c.returns)
    np.testing.assert_array_equal(v["intensity"], c.intensity)
    assert v["returns"].max() == 2 and v["ring"].max() <= 15


def test_semantickitti_sequence_read_by_the_api_puts_scans_back_in_the_world(scans, tmp_path):
    pytest.importorskip("auxiliary.laserscan")
    from auxiliary.laserscan import SemLaserScan

    seq = tmp_path / "sequences" / "00"
    paths = write_kitti_sequence(scans, seq)
    poses = np.loadtxt(seq / "poses.txt").reshape(-1, 3, 4)
    world0 = np.loadtxt(seq / "world_pose.txt").reshape(3, 4)
    calib = dict(line.split(":", 1) for line in (seq / "calib.txt").read_text().splitlines())
    assert np.allclose(np.array(calib["Tr"].split(), float), np.eye(4)[:3].ravel())
    for k, (s, p) in enumerate(zip(scans, paths)):
        api = SemLaserScan({i: [0, 0, 0] for i in range(20)}, project=False)
        api.open_scan(str(p))
        api.open_label(str(seq / "labels" / f"{k:06d}.label"))
        np.testing.assert_allclose(
            api.remissions, s.intensity, rtol=0, atol=0
        )  # remission 0-1, KITTI's range
        assert np.all(api.sem_label == 3) and np.array_equal(api.inst_label, 10 + s.ring)
        # deskewed scan, moved by its pose (from the first) and the first pose, lies where it was
        # fired
        pose = np.vstack([poses[k], [0, 0, 0, 1]])
        first = np.vstack([world0, [0, 0, 0, 1]])
        world = (api.points.astype(np.float64) @ (first @ pose)[:3, :3].T) + (first @ pose)[:3, 3]
        np.testing.assert_allclose(world, s.world_xyz, atol=2e-5)
        assert np.abs(world[:, 2][s.return_number == 1]).max() < 2e-5  # first echoes on the floor
    # the raw scan is skewed: the same points 2 m/s x up to 0.1 s = up to 0.2 m off
    raw = write_kitti_sequence(scans[:1], tmp_path / "raw", deskew=False)[0]
    pts = np.fromfile(raw, "<f4").reshape(-1, 4)[:, :3]
    skew = np.linalg.norm(pts - scans[0].deskewed_xyz(), axis=1)
    assert 0.19 < skew.max() < 0.21


def test_las_1_4_format_6_read_by_laspy(scans, tmp_path):
    laspy = pytest.importorskip("laspy")
    path = write_scans_las(scans, tmp_path / "map.las")
    las = laspy.read(str(path))
    assert las.header.version.minor == 4 and las.header.point_format.id == 6
    n = sum(len(s) for s in scans)
    assert len(las.points) == n
    rn = np.concatenate([s.return_number for s in scans])
    np.testing.assert_array_equal(np.asarray(las.return_number), rn)
    np.testing.assert_array_equal(
        np.asarray(las.number_of_returns), np.concatenate([s.returns for s in scans])
    )
    np.testing.assert_array_equal(np.asarray(las.ring), np.concatenate([s.ring for s in scans]))
    gps = np.concatenate([s.start_s + s.time_s for s in scans])
    np.testing.assert_array_equal(np.asarray(las.gps_time), gps)
    # every echo of a pulse carries the pulse's emission time
    two = np.flatnonzero(rn == 2)
    np.testing.assert_array_equal(np.asarray(las.gps_time)[two], np.asarray(las.gps_time)[two - 1])
    az = np.degrees(np.concatenate([s.azimuth_rad for s in scans]))
    np.testing.assert_allclose(np.asarray(las.scan_angle) * 0.006, az, atol=0.003)
    np.testing.assert_array_equal(np.asarray(las.scanner_channel), 0)
    inten = np.concatenate([s.intensity for s in scans]).astype(np.float64)
    np.testing.assert_allclose(np.asarray(las.intensity) / 65535, inten, atol=1 / 65535)
    world = np.concatenate([s.world_xyz for s in scans])
    np.testing.assert_allclose(np.stack([las.x, las.y, las.z], 1), world, atol=6e-5)


def test_e57_read_by_pye57_and_libe57(scans, tmp_path):
    pye57 = pytest.importorskip("pye57")
    path = write_scans_e57(scans[:2], tmp_path / "scans.e57")
    e = pye57.E57(str(path))
    assert e.scan_count == 2
    for k, s in enumerate(scans[:2]):
        raw = e.read_scan_raw(
            k, ignore_unsupported_fields=True
        )  # pye57 reads no time stamps nor returns
        np.testing.assert_array_equal(raw["rowIndex"], s.ring)
        np.testing.assert_array_equal(raw["columnIndex"], s.column)
        np.testing.assert_array_equal(raw["intensity"], s.intensity)
        h = e.get_header(k)
        local = np.stack([raw["cartesianX"], raw["cartesianY"], raw["cartesianZ"]], 1)
        np.testing.assert_allclose(
            local @ h.rotation_matrix.T + h.translation, s.world_xyz, atol=1e-9
        )
        # time stamps and returns, through libE57Format itself
        lib = pye57.libe57
        points = h.points
        n = points.childCount()
        arrays = {
            "timeStamp": np.empty(n, np.float64),
            "returnIndex": np.empty(n, np.int16),
            "returnCount": np.empty(n, np.int16),
        }
        bufs = lib.VectorSourceDestBuffer()
        for name, a in arrays.items():
            bufs.append(lib.SourceDestBuffer(e.image_file, name, a, n, True, True))
        reader = points.reader(bufs)
        assert reader.read() == n
        reader.close()
        np.testing.assert_array_equal(arrays["timeStamp"], s.time_s)
        np.testing.assert_array_equal(arrays["returnIndex"], s.return_number - 1)
        np.testing.assert_array_equal(arrays["returnCount"], s.returns)
    e.close()
    # the same scans give the same bytes
    again = write_scans_e57(scans[:2], tmp_path / "again.e57")
    assert again.read_bytes() == path.read_bytes()


@pytest.mark.parametrize(
    "style, time_field, scale", [("velodyne", "time", 1.0), ("ouster", "t", 1e-9)]
)
def test_pointcloud2_in_a_ros2_bag_read_by_rosbags(scans, tmp_path, style, time_field, scale):
    pytest.importorskip("rosbags")
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    bag = write_scan_bag(scans, tmp_path / "bag", style=style)
    got = []
    with Reader(bag) as r:
        for conn, t, raw in r.messages():
            if conn.topic == "/top/points":
                got.append(ts.deserialize_cdr(raw, conn.msgtype))
    assert len(got) == len(scans)
    width = {
        "INT8": 1,
        "UINT8": 1,
        "INT16": 2,
        "UINT16": 2,
        "INT32": 4,
        "UINT32": 4,
        "FLOAT32": 4,
        "FLOAT64": 8,
    }
    np_type = {2: "u1", 4: "<u2", 6: "<u4", 7: "<f4", 8: "<f8"}
    for msg, s in zip(got, scans):
        f = {fl.name: fl for fl in msg.fields}
        assert f["ring"].datatype == 4 and f[time_field].datatype in (6, 7)
        dt = np.dtype(
            {
                "names": list(f),
                "formats": [np_type[x.datatype] for x in f.values()],
                "offsets": [x.offset for x in f.values()],
                "itemsize": msg.point_step,
            }
        )
        rec = np.frombuffer(msg.data.tobytes(), dt)
        np.testing.assert_array_equal(rec["ring"], s.ring)
        np.testing.assert_allclose(rec[time_field] * scale, s.time_s, atol=1e-8)
        assert msg.header.stamp.sec * 1e9 + msg.header.stamp.nanosec == pytest.approx(
            (s.start_s - scans[0].start_s) * 1e9 + 1, abs=1
        )
        np.testing.assert_array_equal(
            np.stack([rec["x"], rec["y"], rec["z"]], 1), s.sensor_xyz.astype(np.float32)
        )
        assert width["UINT16"] == 2 and rec[time_field].min() >= 0
    rec, fields = point_fields(scans[0], style)
    assert [n for n, _, _ in fields][:3] == ["x", "y", "z"]


def test_the_map_is_cut_into_chunks_of_the_papers_25000_points():
    from genie_gl.cloud.scan_map import class_shares, scan_map

    s = replace(load_scanner("velodyne_vlp16"), effects=())
    traj = Trajectory(
        np.array([0.0, 1.0]),
        planar_poses(np.array([[0.0, 0.0], [SPEED, 0.0]]), np.zeros(2), HEIGHT),
    )
    scans = [floor_scan(s, traj, 0.1 * k, k) for k in range(8)]
    # four quadrant tiles around the walk (x, y = 0 are tile edges), each with more than 25,000
    # points
    tiles = scan_map(scans, voxel_m=None, chunk_m=200.0, rng=np.random.default_rng(0))
    assert len(tiles) == 4 and all(len(t) == 25_000 for _, t in tiles)
    c = tiles[0][1]
    assert (
        c.ring is not None and c.time is not None and c.returns is not None
    )  # the scanner's fields kept
    np.testing.assert_array_equal(class_shares([c]), np.eye(10)[3])
    assert (
        scan_map(scans, voxel_m=None, chunk_m=1.0, rng=np.random.default_rng(0)) == []
    )  # none that full
