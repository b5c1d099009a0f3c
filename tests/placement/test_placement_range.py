"""Placement knows the sensor's range: every shipped profile on every shipped strategy gives
frames with points; a profile that cannot fit the hall gets a one-line error."""

from pathlib import Path

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.errors import ConfigError
from genie_gl.placement.genetic import mount_for

ROOT = Path(__file__).resolve().parents[2]
STRATEGIES = sorted(p.stem for p in (ROOT / "layouts").glob("*.json"))
PROFILES = sorted(p.stem for p in (ROOT / "sensors").glob("*.yaml"))


@pytest.fixture(scope="module", params=STRATEGIES)
def hall(request):
    layout = gg.generate_layout(ROOT / "layouts" / f"{request.param}.json", seed=0)
    return layout, gg.build_scene(layout, seed=0)


def test_the_shipped_files_are_all_here():
    assert len(STRATEGIES) >= 3 and {"realsense_d435", "azure_kinect_nfov", "zivid2_m70"} <= set(
        PROFILES
    )


@pytest.mark.gl
@pytest.mark.parametrize("profile", PROFILES)
def test_every_profile_on_every_strategy_gives_frames_with_points(hall, profile):
    layout, scene = hall
    sensor = gg.load_sensor(profile)
    try:
        poses = gg.place_sensors(layout, sensor, n=1, seed=0, method="greedy")
    except ConfigError as exc:  # a close-range sensor: refused in one line, then mounted low
        assert "\n" not in str(exc) and "mount" in str(exc) and profile == "zivid2_m70"
        poses = gg.place_sensors(layout, sensor, n=1, seed=0, method="greedy", mount_height_m=0.9)
    (frame,) = gg.capture(scene, sensor, poses, seed=0)
    valid = frame.depth > 0
    assert valid.mean() > 0.3, f"{profile}: {valid.mean():.0%} of the pixels return"
    rng = [e for e in sensor.effects if e.name == "range"]
    if rng:
        assert frame.depth[valid].max() <= rng[0].max_m * 1.01


def test_mount_keeps_the_top_edge_of_the_image_on_the_floor_within_range():
    sensor = gg.load_sensor("azure_kinect_nfov")
    m = mount_for(sensor)
    half_v = np.arctan2(sensor.height / 2, sensor.fy)
    top = m.pitch_rad - half_v  # the top edge's angle below the horizon
    assert m.height_m / np.sin(top) == pytest.approx(0.95 * 3.86, rel=1e-6)
    assert 2.0 <= m.height_m <= 3.5


def test_a_sensor_that_cannot_fit_is_refused_unless_the_mount_is_given():
    zivid = gg.load_sensor("zivid2_m70")
    with pytest.raises(ConfigError, match=r"zivid2_m70.*0\.3-1\.1 m.*between 2 and 4 m"):
        mount_for(zivid, ceiling_m=4.0)
    m = mount_for(zivid, ceiling_m=4.0, mount_height_m=0.8)
    assert m.height_m == 0.8 and 0 < m.pitch_rad <= np.pi / 2


def test_look_at_is_an_opencv_camera_with_the_cross_products_of_numpy():
    """A placed camera's pose: z from the eye to the target, x = z × up, y = z × x (right,
    down, forward), orthonormal; the cross products are numpy's, bit for bit (the poses, and
    so every dataset, stay the same)."""
    from genie_gl.sensors.pose import look_at

    rng = np.random.default_rng(3)
    for _ in range(200):
        eye, target = rng.uniform(-30, 30, 3), rng.uniform(-30, 30, 3)
        T = look_at(eye, target)
        z = (target - eye) / np.linalg.norm(target - eye)
        x = np.cross(z, [0.0, 0.0, 1.0])
        x /= np.linalg.norm(x)
        assert np.array_equal(T[:3, 2], z) and np.array_equal(T[:3, 0], x)
        assert np.array_equal(T[:3, 1], np.cross(z, x)) and np.array_equal(T[:3, 3], eye)
        np.testing.assert_allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-12)
        assert T[2, 1] <= 1e-12  # image y points down (or level): the camera is upright
    down = look_at([1.0, 2.0, 5.0], [1.0, 2.0, 0.0])  # straight down: any perpendicular x
    np.testing.assert_array_equal(down[:3, 2], [0.0, 0.0, -1.0])
    np.testing.assert_array_equal(down[:3, 0], np.cross([0.0, 0.0, -1.0], [1.0, 0.0, 0.0]))
