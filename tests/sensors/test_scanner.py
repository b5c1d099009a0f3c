"""Scanner profiles and the beams of a scan: the published figures (LIDAR.md §9), the timing
formulas of the drivers, and one clear line for every bad scanner file."""

from pathlib import Path

import numpy as np
import pytest
import yaml

from genie_gl.errors import ConfigError
from genie_gl.resources import data_dir
from genie_gl.sensors.beams import firing_times, scan_beams, scan_starts
from genie_gl.effects.scanner_profile import load_scanner
from genie_gl.motion.scanner_rig import load_scanner_rig
from genie_gl.motion.trajectory import Trajectory, planar_poses

VLP16_ELEVATION = [-15, 1, -13, 3, -11, 5, -9, 7, -7, 9, -5, 11, -3, 13, -1, 15]


def test_vlp16_profile_has_the_manuals_figures():
    s = load_scanner("velodyne_vlp16")
    np.testing.assert_array_equal(np.degrees(s.elevation_rad).round(9), VLP16_ELEVATION)
    assert s.firing_period_s == pytest.approx(55.296e-6, abs=1e-15)
    np.testing.assert_allclose(s.channel_time_s, np.arange(16) * 2.304e-6, atol=1e-15)
    # ROS ring = rank by elevation: laser 0 (-15 deg) is ring 0, laser 1 (+1 deg) ring 8, laser 15
    # ring 15
    assert s.ring[0] == 0 and s.ring[1] == 8 and s.ring[15] == 15
    assert sorted(s.ring.tolist()) == list(range(16))
    # azimuth step 360 deg x f x 55.296 us: 0.0995 / 0.199 / 0.398 deg at 5 / 10 / 20 Hz (LIDAR.md
    # §9.1)
    for hz, step in ((5, 0.0995), (10, 0.199), (20, 0.398)):
        assert np.degrees(
            load_scanner("velodyne_vlp16", rate_hz=hz).azimuth_step_rad
        ) == pytest.approx(step, abs=5e-4)
    # single return: 289,344 points/s in the manual (384 per 1.327 ms packet); 16 / 55.296 us here
    assert s.points_per_second == pytest.approx(289_344, rel=1e-4)
    assert (
        s.max_range_m == 100
        and s.range_accuracy_m == 0.03
        and s.sources["beam_divergence_mrad"].startswith("[U]")
    )
    with pytest.raises(ConfigError, match=r"rate_hz 7.5: not a rate of this scanner"):
        load_scanner("velodyne_vlp16", rate_hz=7.5)


@pytest.mark.parametrize(
    "name, rows, top, bottom, origin_mm",
    [
        ("ouster_os1_64", 64, 16.729, -16.679, 12.163),
        ("ouster_os1_128", 128, 20.47, -21.95, 16.721),
    ],
)
def test_ouster_profiles_have_the_published_beam_tables(name, rows, top, bottom, origin_mm):
    s = load_scanner(name)
    e = np.degrees(s.elevation_rad)
    assert s.channels == rows and e[0] == pytest.approx(top) and e[-1] == pytest.approx(bottom)
    assert np.all(np.diff(e) < 0)  # row 0 is the top beam
    np.testing.assert_array_equal(s.ring, np.arange(rows))  # ouster-ros ring = row
    assert s.beam_origin_m == pytest.approx(origin_mm * 1e-3)
    # 1024 columns at 10 Hz: a column every 97.66 us, all rows of a column at one time
    assert s.firing_period_s == pytest.approx(1 / 10240) and not s.channel_time_s.any()
    # the 4-column azimuth pattern repeats down the rows
    az = np.degrees(s.azimuth_offset_rad).reshape(-1, 4)
    assert np.all(np.argsort(-az, axis=1) == [0, 1, 2, 3])


def test_vlp16_point_times_follow_the_driver_formula():
    """t = 55.296 us x seq + 2.304 us x id (LIDAR.md §9.1), from the scan start."""
    s = load_scanner("velodyne_vlp16")
    b = scan_beams(s, np.eye(4), 0.0)
    seq, laser = b.column.astype(np.int64), b.channel.astype(np.int64)
    np.testing.assert_allclose(b.time_s, seq * 55.296e-6 + laser * 2.304e-6, rtol=0, atol=1e-12)
    assert len(b) // 16 in (1808, 1809) and b.time_s[::16].max() < 0.1 < b.time_s.max() + 55.296e-6
    # the scans of a recording tile the firing grid: 18084 firings in 10 s at 10 Hz... per scan 1808
    # or 1809
    counts = [len(firing_times(s, t)) for t in scan_starts(s, 0.0, 1.0)]
    assert set(counts) <= {1808, 1809} and sum(counts) == int(np.ceil(1.0 / 55.296e-6 - 1e-9))
    # clockwise seen from above: the azimuth of one laser falls with time, 0.199 deg per firing
    a = np.unwrap(b.azimuth_rad[b.channel == 0])
    np.testing.assert_allclose(np.diff(a), -s.azimuth_step_rad, rtol=1e-9)
    # directions: unit, at the laser's elevation
    np.testing.assert_allclose(np.linalg.norm(b.directions, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(
        np.degrees(np.arcsin(b.directions[:16, 2])), VLP16_ELEVATION, atol=1e-9
    )


def test_ouster_columns_share_one_time_and_offsets_turn_the_beams():
    s = load_scanner("ouster_os1_64")
    b = scan_beams(s, np.eye(4), 0.0)
    assert len(b) == 64 * 1024
    t = b.time_s.reshape(1024, 64)
    assert np.all(t == t[:, :1]) and t[1, 0] == pytest.approx(1 / 10240)
    # column 0 looks backward (lidar_to_sensor turns the lidar frame by 180 deg), less the beam's
    # offset
    np.testing.assert_allclose(
        np.degrees(b.azimuth_rad[:64]) % 360, (180 - np.degrees(s.azimuth_offset_rad)) % 360
    )
    # beam origins 12.163 mm off the spin axis, along the encoder angle
    np.testing.assert_allclose(np.linalg.norm(b.sensor_origins, axis=1), 0.012163)


def test_a_moving_head_fires_each_firing_from_its_own_pose():
    s = load_scanner("velodyne_vlp16")
    times = np.array([0.0, 1.0])
    traj = Trajectory(times, planar_poses(np.array([[0.0, 0.0], [2.0, 0.0]]), np.zeros(2), 1.0))
    b = scan_beams(s, lambda t: traj.at(t), 0.3)
    t_fire = firing_times(s, 0.3)
    assert len(t_fire) == len(b) // 16
    np.testing.assert_allclose(b.origins[::16, 0], 2.0 * t_fire, atol=1e-12)  # 2 m/s along x
    # each laser from the pose at its own time: laser 5 fires 11.52 us after its firing
    np.testing.assert_allclose(b.origins[5::16, 0], 2.0 * (t_fire + 5 * 2.304e-6), atol=1e-12)
    np.testing.assert_allclose(b.origins[:, 2], 1.0)
    # raw (scanner-frame) directions are those of a standing head
    still = scan_beams(s, np.eye(4), 0.3)
    np.testing.assert_array_equal(b.sensor_directions, still.sensor_directions)


def test_a_posed_heads_beams_are_its_raw_beams_turned_and_moved():
    # an OS1-64 (its beams start 12 mm off the axis) turned about all three axes and moved, held
    # still and carried on a turning path: world = R raw + T, beam by beam at the beam's time
    from scipy.spatial.transform import Rotation

    s = load_scanner("ouster_os1_64")
    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_rotvec([0.3, -0.2, 1.1]).as_matrix()
    pose[:3, 3] = [1.5, -2.5, 0.7]
    b = scan_beams(s, pose, 0.0)
    np.testing.assert_allclose(
        b.origins, b.sensor_origins @ pose[:3, :3].T + pose[:3, 3], atol=1e-12
    )
    np.testing.assert_allclose(b.directions, b.sensor_directions @ pose[:3, :3].T, atol=1e-12)
    traj = Trajectory(
        np.array([0.0, 1.0]),
        planar_poses(np.array([[0.0, 1.0], [2.0, -3.0]]), np.array([0.2, 1.4]), 1.2),
    )
    moving = scan_beams(s, lambda t: traj.at(t, then=pose), 0.3)
    P = traj.at(0.3 + moving.time_s, then=pose)  # Ouster: a column's beams share one time
    np.testing.assert_allclose(
        moving.origins,
        np.einsum("bij,bj->bi", P[:, :3, :3], moving.sensor_origins) + P[:, :3, 3],
        atol=1e-12,
    )
    np.testing.assert_allclose(
        moving.directions,
        np.einsum("bij,bj->bi", P[:, :3, :3], moving.sensor_directions),
        atol=1e-12,
    )


def _write(tmp_path, **change):
    data = yaml.safe_load((data_dir("sensors") / "velodyne_vlp16.lidar.yml").read_text())
    data.update(change)
    for k in [k for k, v in change.items() if v is None]:
        del data[k]
    p = tmp_path / "mine.lidar.yml"
    p.write_text(yaml.safe_dump(data))
    return p


@pytest.mark.parametrize(
    "change, field",
    [
        ({"elevation_deg": [float("nan")] * 16}, "elevation_deg[0]"),
        ({"elevation_deg": [], "channel_time_us": 0}, "elevation_deg"),
        ({"rate_hz": 0}, "rate_hz"),
        ({"fov_deg": 361}, "fov_deg"),
        ({"channel_time_us": [0, 2.304, 1.0] + [5.0] * 13}, "channel_time_us[2]"),
        ({"elevations_deg": [0.0]}, "elevations_deg"),
        ({"firing_period_us": 0}, "firing_period_us"),
        ({"effects": [{"type": "range_nois"}]}, "effects[0].type"),
    ],
)
def test_a_bad_scanner_file_is_one_line_naming_the_file_and_field(tmp_path, change, field):
    path = _write(tmp_path, **change)
    with pytest.raises(ConfigError) as exc:
        load_scanner(path)
    msg = str(exc.value)
    assert "\n" not in msg and str(path) in msg and field in msg, msg


def test_unknown_keys_get_a_did_you_mean(tmp_path):
    with pytest.raises(
        ConfigError,
        match=r"elevations_deg: not a field of a scanner profile; did you mean 'elevation_deg'",
    ):
        load_scanner(_write(tmp_path, elevations_deg=[1.0]))
    with pytest.raises(
        ConfigError, match=r"sigma: not a parameter of range_noise; did you mean 'sigma_m'"
    ):
        load_scanner(_write(tmp_path, effects=[{"type": "range_noise", "sigma": 0.1}]))


def test_a_users_own_scanner_from_a_file(tmp_path):
    p = tmp_path / "own.lidar.yml"
    p.write_text(
        yaml.safe_dump(
            {
                "name": "own",
                "elevation_deg": [-10.0, 0.0, 10.0],
                "azimuth_offset_deg": [1.0, 0.0, -1.0],
                "channel_time_us": [0.0, 1.0, 2.0],
                "firing_period_us": 10.0,
                "rate_hz": 5,
                "range_m": [0.5, 50],
            }
        )
    )
    s = load_scanner(p)
    assert s.channels == 3 and s.firings_per_scan == pytest.approx(20000) and s.max_range_m == 50
    b = scan_beams(s, np.eye(4), 0.0)
    assert len(b) == 3 * 20000
    # channel 2 fires 2 us into its firing, 1 deg left of the head (offset subtracted)
    np.testing.assert_allclose(b.time_s[2], 2e-6)
    head = -2 * np.pi * 5 * 2e-6
    assert b.azimuth_rad[2] == pytest.approx(head + np.radians(1.0))


def test_shipped_scanner_rigs_load():
    rig = load_scanner_rig("navvis_wearable")
    assert len(rig.heads) == 2
    level, tilted = (h.body_from_scanner[:3, 2] for h in rig.heads)
    assert (
        level == pytest.approx([0, 0, 1]) and abs(tilted[2]) < 0.9
    )  # the second head's spin axis leans over
    robot = load_scanner_rig("forklift_vlp16")
    assert robot.heads[0].scanner.name == "velodyne_vlp16"


def test_a_bad_rig_file_is_one_line(tmp_path):
    p = tmp_path / "r.lidar.yml"
    p.write_text("heads:\n  - {name: a, profile: velodyne_vlp16, rate_hz: 7.5}\n")
    with pytest.raises(ConfigError, match=r"heads.0.profile: .*rate_hz 7.5"):
        load_scanner_rig(p)
    p.write_text("heads:\n  - {name: a, profile: velodyne_vlp16, pich_deg: 3}\n")
    with pytest.raises(ConfigError, match=r"did you mean 'pitch_deg'"):
        load_scanner_rig(p)
    assert Path(p).read_text().startswith("heads")
