"""A rig recorded along a trajectory over a generated scene: every frame's cloud, moved by the
poses the SemanticKITTI sequence stores, lands on the scene's surfaces (ideal sensors: within
1e-4 m, measured by Open3D's distance query) and on the fused map (within a voxel); the
registration error moves a map as its model predicts; the same seed gives the same frames."""

import dataclasses
import sys

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.capture.mobile_map import registration_rng, with_registration
from genie_gl.capture.trajectory import record
from genie_gl.cloud.fusion import fuse
from genie_gl.cloud.unproject import unproject
from genie_gl.motion.paths import make_trajectory
from genie_gl.motion.registration import RegistrationError
from genie_gl.motion.rig import Rig, load_rig

pytestmark = pytest.mark.gl


def ideal(rig: Rig, rate_hz: float) -> Rig:
    """The rig's extrinsics with ideal sensors ('before noise': no effects), seeing as far as
    the D435's 6 m range."""
    return Rig(
        rig.name,
        tuple(
            dataclasses.replace(
                s, sensor=gg.Sensor.from_camera(s.sensor, name=s.name, far_m=6.0), rate_hz=rate_hz
            )
            for s in rig.sensors
        ),
    )


@pytest.fixture(scope="module")
def recorded():
    layout = gg.generate_layout("storage_area", seed=0)
    scene = gg.build_scene(layout, seed=0)
    tr = make_trajectory(layout, scene, "aisles", seed=0, duration_s=2.0)
    rig = ideal(load_rig("d435_quad"), 2.5)
    return scene, rig, tr, list(record(scene, rig, tr, seed=0))


def raycaster(scene):
    import open3d as o3d

    rc = o3d.t.geometry.RaycastingScene()
    ids = {}
    for inst in scene.instances:
        m = scene.meshes[inst.mesh]
        v = (
            np.asarray(m.vertices, np.float64) @ inst.world_from_model[:3, :3].T
            + inst.world_from_model[:3, 3]
        )
        ids[
            rc.add_triangles(
                o3d.core.Tensor(v.astype(np.float32)),
                o3d.core.Tensor(np.asarray(m.faces, np.uint32)),
            )
        ] = inst.instance
    return rc, ids


def surface_distance(caster, points: np.ndarray) -> np.ndarray:
    """Open3D's distance from each point to the nearest triangle of the scene."""
    import open3d as o3d

    return caster[0].compute_distance(o3d.core.Tensor(points.astype(np.float32))).numpy()


def range_error(caster, origins: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """|range of the point - range of the first surface Open3D's ray caster hits| along each
    ray from the camera's centre through the point, and the instance it hits."""
    import open3d as o3d

    d = points - origins
    r = np.linalg.norm(d, axis=1)
    rc, ids = caster
    hit = rc.cast_rays(o3d.core.Tensor(np.c_[origins, d / r[:, None]].astype(np.float32)))
    inst = np.array([ids.get(int(g), 0) for g in hit["geometry_ids"].numpy()])
    return np.abs(hit["t_hit"].numpy() - r), inst


def test_every_scan_moved_by_its_kitti_pose_lands_on_the_scene_and_on_the_map(recorded, tmp_path):
    from scipy.spatial import cKDTree

    from genie_gl.export.semantickitti import read
    from genie_gl.export.semantickitti_sequence import write_recording

    scene, rig, tr, pairs = recorded
    assert len(pairs) == 4 * 6
    (seq,) = write_recording(rig, tr, pairs, tmp_path)
    Tr = np.r_[np.loadtxt(seq / "calib.txt", usecols=range(1, 13))[4].reshape(3, 4), [[0, 0, 0, 1]]]
    poses = [np.r_[p.reshape(3, 4), [[0, 0, 0, 1]]] for p in np.loadtxt(seq / "poses.txt")]
    world_pose = np.r_[np.loadtxt(seq / "world_pose.txt").reshape(3, 4), [[0, 0, 0, 1]]]
    scans = []
    for j, pose in enumerate(poses):
        xyz, sem, inst = read(seq / "velodyne" / f"{j:06d}.bin")
        p = np.c_[xyz.astype(np.float64), np.ones(len(xyz))]
        scans.append(((world_pose @ np.linalg.inv(Tr) @ pose @ Tr @ p.T).T[:, :3], sem))
    world = np.concatenate([w for w, _ in scans])
    labels = np.concatenate([unproject(f).instance for _, f in pairs])
    centres = np.concatenate(
        [np.tile(s.world_from_camera[:3, 3], (int((f.depth > 0).sum()), 1)) for s, f in pairs]
    )
    pick = np.random.default_rng(0).choice(len(world), 50000, replace=False)
    sub = world[pick]
    rc = raycaster(scene)
    # on the surface along its own ray: an independent ray caster's first hit, on the object
    # the point is labelled with, at the same range within 1e-4 m (all but rays along
    # silhouette edges, where a rasteriser and a ray caster break the tie differently)
    err, hit = range_error(rc, centres[pick], sub)
    agree = (hit == labels[pick]) & (err <= 1e-4)
    assert agree.mean() >= 0.995, agree.mean()
    assert np.median(err) < 2e-6
    # and the distance to the nearest surface: a ray grazing a face edge-on may hit it just
    # past its edge (ours and the ray caster's alike), so the bound holds for all but those
    d = surface_distance(rc, sub)
    assert np.quantile(d, 0.99) <= 1e-4, np.quantile(d, 0.99)
    # the same points as the frames themselves hold, labels included
    want = np.concatenate([unproject(f).world_xyz for _, f in pairs])
    np.testing.assert_allclose(world, want, atol=5e-6)
    # and on the fused map: every point within one voxel's diagonal of a map point
    b = scene.bounds()
    b[0] -= 0.5
    b[1] += 0.5
    voxel = 0.05
    m = fuse((f for _, f in pairs), bounds=b, voxel_m=voxel)
    dist, _ = cKDTree(m.world_xyz).query(sub)
    assert dist.max() <= np.sqrt(3) * voxel
    assert len(m) < len(world) / 3  # voxel-reduced


def test_the_registration_error_moves_each_frame_by_its_drawn_error_and_grows_with_the_path(
    recorded,
):
    scene, rig, tr, pairs = recorded
    model = RegistrationError(drift_m_per_sqrt_m=0.01, pass_length_m=1.0)
    moved = list(with_registration(iter(pairs), tr, model, rng=registration_rng(0)))
    path = model.sample(tr.length_m, rng=registration_rng(0))
    for (shot, f), (_, g) in zip(pairs, moved):
        np.testing.assert_array_equal(g.meta["true_world_from_camera"], f.world_from_camera)
        np.testing.assert_allclose(
            g.world_from_camera,
            path.apply(f.world_from_camera, shot.world_from_body, shot.distance_m),
        )
        assert g.meta["registration_sigma_m"] == pytest.approx(
            float(model.sigma_m(shot.distance_m, 3.0))
        )
    # the prediction: sigma grows as the square root of the distance walked
    s = model.sigma_m(np.array([0.0, 100.0]), 0.0)
    assert s[1] ** 2 - s[0] ** 2 == pytest.approx(3 * 0.01**2 * 100)
    spread = np.array(
        [model.sample(100.0, rng=np.random.default_rng(k)).error(100.0)[:3] for k in range(400)]
    )
    np.testing.assert_allclose(spread.std(0), np.sqrt(0.01**2 * 100 + 0.003**2), rtol=0.15)


def test_the_same_seed_records_the_same_bytes(recorded):
    scene, rig, tr, pairs = recorded
    again = list(record(scene, load_rig("d435_quad"), tr.crop(0.4), seed=3))
    twice = list(record(scene, load_rig("d435_quad"), tr.crop(0.4), seed=3))
    assert len(again) == 4 * 7
    for (_, a), (_, b) in zip(again, twice):
        assert (
            a.depth.tobytes() == b.depth.tobytes() and a.semantic.tobytes() == b.semantic.tobytes()
        )


def test_the_plan_of_a_recording_is_each_sensors_plan_of_its_shots_and_the_registration_predicted(
    recorded,
):
    from genie_gl.capture.trajectory import plan_recording

    scene, rig, tr, pairs = recorded
    p = plan_recording(scene, rig, tr, registration=RegistrationError())
    assert list(p.plans) == ["front", "left", "back", "right"]
    assert all(len(sp.frames) == 6 for sp in p.plans.values())
    assert np.all(np.diff(p.registration_sigma_m) >= 0) and p.registration_sigma_m[0] > 0
    assert "registration error (predicted, at 3 m range)" in p.summary()
    assert p.to_dict()["shots"] == 24


def test_a_recording_is_gg_capture_of_each_window_with_one_renderer_and_one_plan(
    recorded, monkeypatch
):
    """Recorded with windows of 3 shots per sensor (so the 6 shots of each sensor span two
    windows), every frame equals ``gg.capture`` of its window's poses with the window's seed:
    one renderer and one plan for the whole recording change no byte."""
    from genie_gl.capture.trajectory import schedule, window_seed

    scene, rig, tr, _ = recorded
    rig = Rig(
        rig.name,
        tuple(
            dataclasses.replace(s, sensor=gg.load_sensor("realsense_d435")) for s in rig.sensors[:2]
        ),
    )
    monkeypatch.setattr(sys.modules[record.__module__], "WINDOW", 3)
    pairs = list(record(scene, rig, tr, seed=5))
    shots = schedule(rig, tr)
    assert [s.index for s, _ in pairs] == [s.index for s in shots] and len(shots) == 12
    for k, s in enumerate(rig.sensors):
        mine = [sh for sh in shots if sh.sensor == k]
        for window, part in enumerate((mine[:3], mine[3:])):
            want = gg.capture(
                scene,
                s.sensor,
                [sh.world_from_camera for sh in part],
                seed=window_seed(5, k, window),
            )
            for sh, w in zip(part, want):
                got = pairs[sh.index][1]
                assert (
                    got.depth.tobytes() == w.depth.tobytes()
                    and got.rgb.tobytes() == w.rgb.tobytes()
                )
                assert got.semantic.tobytes() == w.semantic.tobytes()
                assert [(e["name"], e["run"], e["changed"]) for e in got.meta["effects"]] == [
                    (e["name"], e["run"], e["changed"]) for e in w.meta["effects"]
                ]
