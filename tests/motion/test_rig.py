"""Rigs: extrinsics in the REP 103 body frame, shipped rigs, frame times, one-line errors."""

import numpy as np
import pytest

from genie_gl.errors import ConfigError
from genie_gl.motion.rig import Rig, RigSensor, body_from_sensor, load_rig


def test_a_level_forward_sensor_looks_along_body_x_with_its_x_to_the_right():
    T = body_from_sensor()
    np.testing.assert_array_equal(T[:3, 2], [1, 0, 0])  # optical z: forward
    np.testing.assert_array_equal(T[:3, 0], [0, -1, 0])  # optical x: right = -y (y is left)
    np.testing.assert_array_equal(T[:3, 1], [0, 0, -1])  # optical y: down


def test_pitch_tilts_the_axis_down_and_yaw_turns_it_left():
    T = body_from_sensor([0.1, 0.2, 0.3], yaw_rad=np.pi / 2, pitch_rad=np.radians(15))
    np.testing.assert_allclose(
        T[:3, 2], [0, np.cos(np.radians(15)), -np.sin(np.radians(15))], atol=1e-15
    )
    np.testing.assert_allclose(T[:3, 0], [1, 0, 0], atol=1e-15)  # looking left, its right is +x
    np.testing.assert_array_equal(T[:3, 3], [0.1, 0.2, 0.3])
    # roll turns the image about the optical axis: +90 deg puts optical x on the world's up
    R = body_from_sensor(roll_rad=np.pi / 2)
    np.testing.assert_allclose(R[:3, 2], [1, 0, 0], atol=1e-15)
    np.testing.assert_allclose(R[:3, 0], [0, 0, -1], atol=1e-15)


def test_the_quad_rig_has_four_d435_ninety_degrees_apart():
    rig = load_rig("d435_quad")
    assert [s.name for s in rig.sensors] == ["front", "left", "back", "right"]
    assert all(s.sensor.name == "realsense_d435" and s.rate_hz == 15 for s in rig.sensors)
    axes = np.array([s.body_from_sensor[:3, 2] for s in rig.sensors])
    heading = np.degrees(np.arctan2(axes[:, 1], axes[:, 0]))
    np.testing.assert_allclose(heading, [0, 90, 180, -90], atol=1e-9)
    np.testing.assert_allclose(np.degrees(np.arcsin(-axes[:, 2])), 15.0, atol=1e-9)  # tilted down
    np.testing.assert_allclose(
        np.linalg.norm([s.body_from_sensor[:2, 3] for s in rig.sensors], axis=1), 0.08
    )


def test_the_cube_rig_sees_every_direction_exactly_once_but_on_its_seams():
    rig = load_rig("panorama_cube")
    assert len(rig) == 6 and {s.sensor.size for s in rig.sensors} == {(512, 512)}
    d = np.random.default_rng(0).normal(size=(20000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    seen = np.zeros(len(d), int)
    for s in rig.sensors:
        R = s.body_from_sensor[:3, :3]
        c = d @ R  # directions in the face's optical frame
        front = c[:, 2] > 0
        u = s.sensor.fx * c[:, 0] / np.where(front, c[:, 2], 1) + s.sensor.cx
        v = s.sensor.fy * c[:, 1] / np.where(front, c[:, 2], 1) + s.sensor.cy
        inside = front & (u >= -0.5) & (u < 511.5) & (v >= -0.5) & (v < 511.5)  # pixel edges
        seen += inside
    assert (seen == 1).all()


def test_frame_times_follow_the_rate_and_offset():
    s = RigSensor("a", load_rig("d435_quad").sensors[0].sensor, np.eye(4), 15.0, offset_s=0.02)
    t = s.times(0.0, 1.0)
    assert len(t) == 15 and t[0] == 0.02
    np.testing.assert_allclose(np.diff(t), 1 / 15)
    assert len(RigSensor("b", s.sensor, np.eye(4), 10.0).times(0.0, 1.0)) == 11  # both ends


@pytest.mark.parametrize(
    "body, match",
    [
        (
            "sensors:\n  - {name: a, profile: ideal_pinhole, rate: 5}\n",
            r"sensors\.0\.rate: unknown field; did you mean 'rate_hz'",
        ),
        (
            "sensors:\n  - {name: a, profile: ideal_pinhole, rate_hz: 0}\n",
            r"sensors\.0\.rate_hz 0.*greater than 0",
        ),
        ("sensors:\n  - {name: A b, profile: ideal_pinhole}\n", r"sensors\.0\.name 'A b'"),
        ("sensors:\n  - {name: a, profile: nope}\n", r"sensors\.0\.profile: nope: no such file"),
        (
            "sensors:\n  - {name: a, profile: ideal_pinhole}\n  - {name: a, profile: "
            "ideal_pinhole}\n",
            "a repeated",
        ),
        ("sensors: []\n", "sensors"),
        ("- 1\n", "a mapping with a 'sensors' list"),
        (
            "sensors:\n  - {name: a, profile: ideal_pinhole, rate_hz: 10, offset_s: 0.2}\n",
            r"offset_s 0\.2: must be below",
        ),
    ],
)
def test_a_bad_rig_file_is_one_line_naming_the_file_and_field(tmp_path, body, match):
    p = tmp_path / "r.yaml"
    p.write_text(body)
    with pytest.raises(ConfigError, match=match) as e:
        load_rig(p)
    assert "\n" not in str(e.value)
    if "repeated" not in match:
        assert str(p) in str(e.value)


def test_a_rig_profile_path_is_read_beside_the_rig_file(tmp_path):
    from genie_gl.resources import data_dir

    (tmp_path / "mine.yaml").write_text(
        (data_dir("sensors") / "ideal_pinhole.yaml")
        .read_text()
        .replace("ideal_pinhole.calib.yml", str(data_dir("sensors") / "ideal_pinhole.calib.yml"))
    )
    (tmp_path / "r.yaml").write_text("sensors:\n  - {name: a, profile: mine.yaml, pitch_deg: 90}\n")
    rig = load_rig(tmp_path / "r.yaml")
    assert rig.name == "r" and rig.sensors[0].sensor.size == (640, 480)
    np.testing.assert_allclose(
        rig.sensors[0].body_from_sensor[:3, 2], [0, 0, -1], atol=1e-15
    )  # straight down


def test_a_single_sensor_rig():
    from genie_gl.effects.profile import load_sensor

    rig = Rig.single(load_sensor("realsense_d435"), rate_hz=30)
    assert rig.name == "realsense_d435" and rig.sensors[0].rate_hz == 30
    with pytest.raises(ConfigError, match="rigid"):
        RigSensor("x", rig.sensors[0].sensor, np.diag([2.0, 1, 1, 1]), 10)
