"""Scans cast by the exact ray engine: analytic ranges on a floor, agreement with Open3D's
ray casting of the same beams, the skew of a moving head undone by each point's own time,
seeds, skipped effects, and the footprint's two echoes at an edge."""

from dataclasses import replace

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.bench.lidar import agreement, open3d_cast, open3d_caster, scene_beams
from genie_gl.capture.scan import cast_beams
from genie_gl.scene.model import Material, Scene
from genie_gl.effects.lidar import BeamDivergence, RangeNoise
from genie_gl.effects.scanner_profile import load_scanner
from genie_gl.motion.trajectory import Trajectory, planar_poses

ALBEDO = 0.6


def floor_scene(size=400.0):
    s = Scene()
    s.add(
        trimesh.creation.box((size, size, 1.0)),
        _shift(0, 0, -0.5),
        semantic=0,
        material=Material((ALBEDO, ALBEDO, ALBEDO)),
    )
    return s


def _shift(x, y, z):
    T = np.eye(4)
    T[:3, 3] = x, y, z
    return T


def ideal(name, **kw):
    return replace(load_scanner(name, **kw), effects=())


def test_floor_ranges_are_analytic_and_intensity_is_albedo_times_cosine():
    s = ideal("velodyne_vlp16")
    height = 1.5
    (scan,) = gg.scan(floor_scene(), s, _shift(0, 0, height), seed=0)
    down = np.sin(s.elevation_rad[scan.channel])
    np.testing.assert_allclose(scan.range_m, height / -down, rtol=1e-12)
    np.testing.assert_allclose(scan.world_xyz[:, 2], 0.0, atol=1e-9)
    np.testing.assert_allclose(scan.intensity, np.float32(ALBEDO * -down), rtol=1e-6)
    # every downward beam in range returns, no upward one: 8 lasers below the horizon (-1 deg
    # reaches 86 m)
    assert set(np.unique(scan.channel)) == {c for c in range(16) if s.elevation_rad[c] < 0}
    assert len(scan) == 8 * (scan.column.max() + 1)
    assert np.all(scan.returns == 1) and np.all(scan.return_number == 1)


@pytest.fixture(scope="module")
def generated():
    layout = gg.generate_layout("storage_area", seed=0)
    return gg.build_scene(layout, seed=0)


@pytest.mark.parametrize("profile", ["velodyne_vlp16", "ouster_os1_128"])
def test_hits_ids_and_ranges_equal_open3d_ray_casting(generated, profile):
    beams = scene_beams(generated, ideal(profile))
    ours = cast_beams(generated, beams.origins, beams.directions)
    a = agreement(
        ours,
        open3d_cast(open3d_caster(generated, beams.origins[0]), beams.origins, beams.directions),
    )
    assert ours.hit.mean() > 0.5
    assert a["hit_agree"] >= 0.9999 and a["id_agree"] >= 0.9999, a
    assert a["range_rel_p99"] <= 1e-6, a


def test_each_points_time_gives_the_pose_that_puts_it_on_the_wall():
    """A head runs at 2 m/s towards a wall 12 m ahead: the raw scan is skewed by up to 0.2 m,
    and moving each raw point by the trajectory's pose at its own time puts it back on the wall
    (each laser fires from the pose at its own time)."""
    s = ideal("velodyne_vlp16")
    scene = Scene()
    scene.add(trimesh.creation.box((1.0, 40.0, 40.0)), _shift(12.5, 0, 0), semantic=2)
    traj = Trajectory(
        np.array([0.0, 1.0]), planar_poses(np.array([[0.0, 0.0], [2.0, 0.0]]), np.zeros(2), 0.0)
    )
    scans = gg.scan(scene, s, traj, seed=0, scans=2)
    for sc in scans:
        front = np.abs(sc.azimuth_rad) < np.radians(40)
        poses = traj.at(sc.start_s + sc.time_s[front])
        moved = np.einsum("nij,nj->ni", poses[:, :3, :3], sc.sensor_xyz[front]) + poses[:, :3, 3]
        np.testing.assert_allclose(moved[:, 0], 12.0, atol=1e-9)
        start = sc.start_pose  # the head at the scan's first firing
        unskewed = (
            sc.sensor_xyz[front] + start[:3, 3]
        )  # the raw scan placed at the scan start: skewed
        assert 0.1 < np.ptp(unskewed[:, 0]) < 0.21
        np.testing.assert_allclose(sc.deskewed_xyz()[front][:, 0] + start[0, 3], 12.0, atol=1e-9)


def test_same_seed_same_bytes_and_a_skipped_effect_changes_nothing():
    base = ideal("velodyne_vlp16")
    scene, pose = floor_scene(60.0), _shift(0, 0, 1.2)
    (plain,) = gg.scan(scene, base, pose, seed=3)
    skip = replace(base, effects=(RangeNoise(),))  # no sigma, no step: planned out
    (skipped,) = gg.scan(scene, skip, pose, seed=3)
    assert skipped.plan["range_noise"][0] is False
    for f in ("world_xyz", "sensor_xyz", "range_m", "intensity", "time_s", "ring"):
        assert getattr(plain, f).tobytes() == getattr(skipped, f).tobytes()
    noisy = replace(base, effects=(RangeNoise(sigma_m=0.01),))
    (a,) = gg.scan(scene, noisy, pose, seed=3)
    (b,) = gg.scan(scene, noisy, pose, seed=3)
    (c,) = gg.scan(scene, noisy, pose, seed=4)
    assert a.range_m.tobytes() == b.range_m.tobytes() != c.range_m.tobytes()
    assert np.std(a.range_m - plain.range_m) == pytest.approx(0.01, rel=0.05)


@pytest.mark.parametrize("mode, max_returns", [("strongest", 1), ("last", 1), ("dual", 2)])
def test_a_footprint_over_an_edge_gives_two_echoes_in_dual_mode(mode, max_returns):
    """A pillar 5 m ahead of a wall 10 m ahead: beams whose footprint (3 mrad) straddles the
    pillar's edges see both, more than 1 m apart."""
    s = replace(load_scanner("velodyne_vlp16", returns=mode), effects=(BeamDivergence(),))
    scene = Scene()
    scene.add(trimesh.creation.box((0.3, 0.3, 10.0)), _shift(5.0, 0, 0), semantic=1)
    scene.add(trimesh.creation.box((0.5, 40.0, 40.0)), _shift(10.25, 0, 0), semantic=2)
    (scan,) = gg.scan(scene, s, np.eye(4), seed=0)
    assert scan.returns.max() == max_returns
    if mode == "dual":
        two = scan.returns == 2
        assert two.sum() >= 16 and set(scan.semantic[two]) == {1, 2}
        # both echoes of a beam come from one firing, nearest first
        k = np.flatnonzero(two & (scan.return_number == 1))
        assert np.all(scan.range_m[k] < scan.range_m[k + 1] - 1.0) and np.all(
            scan.time_s[k] == scan.time_s[k + 1]
        )


@pytest.mark.parametrize("mode", ["strongest", "last", "dual"])
def test_a_scans_footprint_returns_are_its_sub_rays_echoes_combined(generated, mode):
    """A scan builds only the echoes its returns keep; they equal the sub-rays' every echo
    combined (:meth:`BeamDivergence.combine`) on a real revolution."""
    from genie_gl.capture.scan import _echoes
    from genie_gl.effects.lidar_base import Echoes
    from genie_gl.scene.materials import MaterialTable

    scanner = replace(load_scanner("velodyne_vlp16"), returns=mode)
    fx = next(e for e in scanner.effects if e.casts_subrays)
    beams = scene_beams(generated, scanner)
    dirs = fx.subrays(beams.directions, scanner)
    k = len(dirs) // len(beams)
    hits = cast_beams(generated, np.repeat(beams.origins, k, axis=0), dirs)
    parent = np.repeat(np.arange(len(beams)), k)
    table = MaterialTable.from_scene(generated)
    kept = _echoes(hits, dirs, parent, table, scanner, fx)
    every = _echoes(hits, dirs, parent, table, scanner)
    hit = np.flatnonzero(hits.hit & (hits.distance <= scanner.max_range_m))
    combined = fx.combine(every, fx.pattern(scanner)[1][hit % k], scanner)
    assert len(kept) > 0.5 * len(beams)
    for f in Echoes.__dataclass_fields__:
        np.testing.assert_array_equal(getattr(kept, f), getattr(combined, f))
    assert (kept.returns > 1).any() == (mode == "dual")
