"""Trajectories: interpolation, and the makers on the free floor: never through an asset
(a property over strategies, seeds, paths and motions), turning and speed a person or robot
can take, the same seed the same trajectory, one-line errors for bad waypoints."""

import functools
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import genie_gl as gg
from genie_gl.errors import ConfigError
from genie_gl.motion.floor import FLOOR_TOP_M, free_floor
from genie_gl.motion.follow import MOTIONS
from genie_gl.motion.paths import make_trajectory
from genie_gl.motion.trajectory import Trajectory, planar_poses

ROOT = Path(__file__).resolve().parents[2]
STRATEGIES = sorted(p.stem for p in (ROOT / "layouts").glob("*.json"))


def test_at_gives_the_samples_exactly_and_slerps_between():
    poses = planar_poses(np.array([[0.0, 0.0], [2.0, 4.0]]), np.array([0.0, np.pi / 2]), 1.5)
    tr = Trajectory(np.array([0.0, 2.0]), poses)
    np.testing.assert_array_equal(tr.at([0.0, 2.0]), poses)
    mid = tr.at([0.5])[0]
    np.testing.assert_allclose(mid[:3, 3], [0.5, 1.0, 1.5])
    np.testing.assert_allclose(np.arctan2(mid[1, 0], mid[0, 0]), np.pi / 8, atol=1e-12)
    assert tr.length_m == pytest.approx(np.sqrt(20)) and tr.distance_at([1.0])[0] == pytest.approx(
        np.sqrt(20) / 2
    )
    with pytest.raises(ConfigError, match="outside its span"):
        tr.at([2.5])
    cut = tr.crop(1.0)
    assert cut.end_s == 1.0 and cut.positions[-1] == pytest.approx([1.0, 2.0, 1.5])


def test_slerp_between_tumbling_samples_equals_scipys():
    # 40 samples of a body turning about every axis (up to ~170 degrees between samples, and
    # steps under the small-angle series' 1e-3 rad), read at 2,000 times and at the samples
    from scipy.spatial.transform import Rotation, Slerp

    rng = np.random.default_rng(3)
    times = np.cumsum(rng.uniform(0.05, 0.5, 40))
    steps = rng.normal(size=(40, 3)) * rng.choice([1e-4, 0.5, 3.0], (40, 1))
    rots = Rotation.from_rotvec(steps[0]) * Rotation.identity()
    mats = [rots.as_matrix()]
    for v in steps[1:]:
        rots = rots * Rotation.from_rotvec(v)
        mats.append(rots.as_matrix())
    poses = np.tile(np.eye(4), (40, 1, 1))
    poses[:, :3, :3] = mats
    poses[:, :3, 3] = np.cumsum(rng.normal(size=(40, 3)), axis=0)
    tr = Trajectory(times, poses)
    t = np.r_[np.sort(rng.uniform(times[0], times[-1], 2000)), times]
    ref = Slerp(times, Rotation.from_matrix(poses[:, :3, :3]))(t).as_matrix()
    got = tr.at(t)[:, :3, :3]
    np.testing.assert_allclose(got, ref, atol=1e-12, rtol=0)
    np.testing.assert_array_equal(tr.at(times), poses)
    # a sensor's pose on the body: the body's pose times body_from_sensor
    then = np.eye(4)
    then[:3, :3] = Rotation.from_rotvec([0.3, -1.2, 2.0]).as_matrix()
    then[:3, 3] = [0.1, -0.4, 1.7]
    np.testing.assert_allclose(tr.at(t, then=then), tr.at(t) @ then, atol=1e-14, rtol=0)
    bad = then.copy()
    bad[3, 0] = 0.5  # not rigid: refused, not half applied
    with pytest.raises(ConfigError, match="rigid transform"):
        tr.at(t, then=bad)


def test_bad_samples_are_refused():
    p = planar_poses(np.zeros((2, 2)), np.zeros(2), 1.0)
    with pytest.raises(ConfigError, match="strictly increasing"):
        Trajectory(np.array([1.0, 1.0]), p)
    p[1, 0, 0] = 2.0
    with pytest.raises(ConfigError, match="rigid"):
        Trajectory(np.array([0.0, 1.0]), p)


@functools.lru_cache(maxsize=None)
def hall(strategy: str, seed: int):
    layout = gg.generate_layout(ROOT / "layouts" / f"{strategy}.json", seed=seed)
    return layout, gg.build_scene(layout, seed=seed)


def clearance_to_assets(scene, xy: np.ndarray, top_m: float = 2.2) -> float:
    """The least horizontal distance from any of ``xy`` to any instance standing on the floor,
    measured in each instance's own frame against its mesh's box (instances turn about z)."""
    best = np.inf
    for inst in scene.instances:
        b = scene.meshes[inst.mesh].bounds
        T = inst.world_from_model
        corners = (
            np.array([[x, y, z, 1.0] for x in b[:, 0] for y in b[:, 1] for z in b[:, 2]]) @ T.T
        )
        if corners[:, 2].max() <= FLOOR_TOP_M or corners[:, 2].min() >= top_m:
            continue
        assert np.allclose(T[:3, 2], [0, 0, 1]), f"{inst.name} is not turned about z alone"
        local = (xy - T[:2, 3]) @ T[:2, :2]  # rotation about z: the inverse is the transpose
        dx = np.maximum(np.maximum(b[0, 0] - local[:, 0], local[:, 0] - b[1, 0]), 0)
        dy = np.maximum(np.maximum(b[0, 1] - local[:, 1], local[:, 1] - b[1, 1]), 0)
        best = min(best, float(np.hypot(dx, dy).min()))
    return best


@settings(max_examples=8, deadline=None, suppress_health_check=list(HealthCheck))
@given(
    strategy=st.sampled_from(STRATEGIES),
    seed=st.integers(0, 3),
    path=st.sampled_from(["aisles", "random"]),
    motion=st.sampled_from(sorted(MOTIONS)),
    route_seed=st.integers(0, 2**31 - 1),
)
def test_trajectories_never_pass_through_an_asset(strategy, seed, path, motion, route_seed):
    layout, scene = hall(strategy, seed)
    m = MOTIONS[motion]
    tr = make_trajectory(layout, scene, path, seed=route_seed, motion=motion, length_m=80.0)
    assert tr.length_m > 10.0
    dense = tr.at(np.linspace(tr.start_s, tr.end_s, int(tr.length_m / 0.01) + 2))[:, :2, 3]
    assert clearance_to_assets(scene, dense) >= m.body_radius_m
    x0, y0, w, h = layout.bounds
    assert (dense[:, 0] > x0 + m.body_radius_m).all() and (
        dense[:, 0] < x0 + w - m.body_radius_m
    ).all()
    assert (dense[:, 1] > y0 + m.body_radius_m).all() and (
        dense[:, 1] < y0 + h - m.body_radius_m
    ).all()
    # what a person or robot can take: cruising speed, turning rate, level, at its height
    assert tr.speeds().max() <= m.speed_mps * (1 + 1e-9)
    assert np.abs(tr.yaw_rates()).max() <= m.max_yaw_rate_rad_s * (1 + 1e-9)
    np.testing.assert_array_equal(tr.positions[:, 2], m.height_m)
    np.testing.assert_allclose(
        tr.world_from_body[:, 2, :3], np.tile([0, 0, 1.0], (len(tr), 1)), atol=1e-15
    )


def test_the_speed_changes_no_faster_than_the_acceleration_allows():
    layout, scene = hall("storage_area", 0)
    m = MOTIONS["person"]
    tr = make_trajectory(layout, scene, "random", seed=3, length_m=40.0)
    v = tr.speeds()  # mean speed of each step
    t = 0.5 * (tr.times_s[1:] + tr.times_s[:-1])
    moving = np.diff(tr.times_s) > 0
    accel = np.abs(np.diff(v[moving])) / np.diff(t[moving])
    assert accel.max() <= m.max_accel_mps2 * 1.05  # between step midpoints: a mean of the true one
    assert tr.speeds()[0] < 0.2 and tr.speeds()[-1] < 0.2  # from rest, to rest


def _yaw(tr):
    return np.unwrap(np.arctan2(tr.world_from_body[:, 1, 0], tr.world_from_body[:, 0, 0]))


def _worst_angular_acceleration(tr):
    w, t = tr.yaw_rates(), 0.5 * (tr.times_s[1:] + tr.times_s[:-1])
    return float(np.max(np.abs(np.diff(w)) / np.diff(t)))


def test_eased_turns_build_up_their_rate_and_leave_the_path_where_it_was():
    """With ``turn_ease_s`` the body keeps its positions and times, never turns faster than
    its fastest turn, and its angular acceleration stays under 2 max_yaw_rate / turn_ease_s,
    where turns that start at once jump to full rate within a sample; without it, the
    trajectory is the one it always was."""
    layout, scene = hall("storage_area", 0)
    m = MOTIONS["person"]
    at_once = make_trajectory(layout, scene, "random", seed=3, length_m=40.0)
    ease = 0.4
    eased = make_trajectory(
        layout, scene, "random", seed=3, length_m=40.0, motion=replace(m, turn_ease_s=ease)
    )
    np.testing.assert_array_equal(eased.times_s, at_once.times_s)
    np.testing.assert_array_equal(eased.positions, at_once.positions)
    assert np.abs(eased.yaw_rates()).max() <= m.max_yaw_rate_rad_s * (1 + 1e-9)

    bound = 2 * m.max_yaw_rate_rad_s / ease
    assert _worst_angular_acceleration(eased) <= bound * 1.05  # step means, as for the speed
    assert _worst_angular_acceleration(at_once) > 5 * bound
    # the yaw eased is the mean of the yaw over the window: a whole turn is still turned
    assert abs(_yaw(eased)[-1] - _yaw(at_once)[-1]) < 1e-9
    assert eased.meta["turn_ease_s"] == ease and "turn_ease_s" not in at_once.meta


@pytest.mark.parametrize("ease", [-0.1, float("nan"), float("inf")])
def test_a_turn_ease_that_is_not_a_time_is_refused(ease):
    with pytest.raises(ConfigError, match="turn_ease_s must be a number >= 0"):
        replace(MOTIONS["person"], turn_ease_s=ease)


def test_the_same_seed_gives_the_same_trajectory_and_another_seed_another():
    layout, scene = hall("assembly_line", 0)
    a = make_trajectory(layout, scene, "aisles", seed=5, length_m=40)
    b = make_trajectory(layout, scene, "aisles", seed=5, length_m=40)
    c = make_trajectory(layout, scene, "aisles", seed=6, length_m=40)
    assert (
        a.times_s.tobytes() == b.times_s.tobytes()
        and a.world_from_body.tobytes() == b.world_from_body.tobytes()
    )
    assert a.world_from_body.shape != c.world_from_body.shape or not np.array_equal(
        a.world_from_body, c.world_from_body
    )


def test_the_aisle_tour_passes_near_every_aisle_target():
    layout, scene = hall("storage_area", 1)
    floor = free_floor(layout, scene)
    tr = make_trajectory(layout, scene, "aisles", seed=0, floor=floor)
    # every free cell within sight of a furnished region lies within reach of the path
    rows, cols = np.nonzero(floor.free & (floor.near_m <= 3.0))
    cells = floor.centres(rows, cols)
    pos = tr.positions[::4, :2]
    d = np.min([np.linalg.norm(cells - p, axis=1) for p in pos], axis=0)
    assert np.quantile(d, 0.95) < 3.0 and d.max() < 6.0


def test_waypoints_from_a_file_are_passed_through(tmp_path):
    layout, scene = hall("assembly_line", 0)
    floor = free_floor(layout, scene)
    rows, cols = np.nonzero(floor.free)
    pick = floor.centres(rows, cols)[[0, len(rows) // 2, len(rows) - 1]]
    f = tmp_path / "w.txt"
    f.write_text("# x y\n" + "".join(f"{x:.4f}, {y:.4f}\n" for x, y in pick))
    tr = make_trajectory(layout, scene, "waypoints", waypoints=f, floor=floor)
    np.testing.assert_allclose(tr.positions[0, :2], np.round(pick[0], 4))
    np.testing.assert_allclose(tr.positions[-1, :2], np.round(pick[-1], 4))
    assert min(np.linalg.norm(tr.positions[:, :2] - pick[1], axis=1)) < 0.2
    (tmp_path / "w.json").write_text(json.dumps(pick.round(4).tolist()))
    tr2 = make_trajectory(layout, scene, "waypoints", waypoints=tmp_path / "w.json", floor=floor)
    np.testing.assert_array_equal(tr.world_from_body, tr2.world_from_body)


def test_a_waypoint_on_an_asset_or_a_bad_line_is_one_line_naming_the_file(tmp_path):
    layout, scene = hall("assembly_line", 0)
    floor = free_floor(layout, scene)
    car = next(i for i in scene.instances if i.semantic == 3)
    rows, cols = np.nonzero(floor.free)
    ok = floor.centres(rows, cols)[0]
    f = tmp_path / "w.txt"
    f.write_text(f"{ok[0]} {ok[1]}\n{car.world_from_model[0, 3]} {car.world_from_model[1, 3]}\n")
    with pytest.raises(
        ConfigError, match=rf"{f}: waypoint 2 .* is not free floor .* nearest free point"
    ) as e:
        make_trajectory(layout, scene, "waypoints", waypoints=f, floor=floor)
    assert "\n" not in str(e.value)
    f.write_text("1 2\n3 four\n")
    with pytest.raises(ConfigError, match=rf"{f}:2: expected two numbers"):
        make_trajectory(layout, scene, "waypoints", waypoints=f, floor=floor)
    with pytest.raises(ConfigError, match="did you mean 'random'"):
        make_trajectory(layout, scene, "randm", floor=floor)
    with pytest.raises(ConfigError, match="unknown; did you mean 'robot'"):
        make_trajectory(layout, scene, "random", motion="robo", floor=floor)


def test_without_a_scene_the_layouts_furnished_regions_are_avoided():
    from genie_gl.motion.floor import furnished_rects, outside_rects

    layout, _ = hall("storage_area", 0)
    tr = make_trajectory(layout, None, "random", seed=1, length_m=40)
    assert outside_rects(
        tr.positions[:, :2], furnished_rects(layout), MOTIONS["person"].body_radius_m
    ).all()
