"""The planner: per effect, a frame where it is skipped (the same bytes and RNG stream as a
run) and one where it runs and changes pixels; culling; ToF multipath on convex and concave
scenes."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.sensors.pose import look_at
from genie_gl.scene.materials import MaterialTable
from genie_gl.sensors.camera import Stereo
from genie_gl.scene.model import Material
from genie_gl.effects.simulate import simulate
from genie_gl.effects.edges import EdgeDropout, FlyingPixels
from genie_gl.effects.registry import EFFECTS, DepthNoise, RangeLimits
from genie_gl.effects.miscalibration import CalibrationError
from genie_gl.effects.shadow import StereoShadow
from genie_gl.effects.specular import SpecularLoss
from genie_gl.effects.surface import IncidenceDropout, LateralNoise, Multipath
from genie_gl.effects.tof import Ambiguity, LowAlbedo, MixedPixels, TofMultipath, _ranges

W, H = 96, 72
MATTE = Material((0.5, 0.5, 0.5), 0.0, 0.9)
METAL = Material((0.6, 0.6, 0.6), 1.0, 0.2)


def frame(depth, normal=(0.0, 0.0, -1.0), instance=None):
    s = gg.Sensor.pinhole(depth.shape[1], depth.shape[0], 80.0)
    d = depth.astype(np.float32)
    inst = (
        np.where(d > 0, 1, 0).astype(np.uint32) if instance is None else instance.astype(np.uint32)
    )
    n = np.broadcast_to(np.asarray(normal, np.float32), d.shape + (3,)).copy()
    n[d == 0] = 0
    return gg.Frame(d, inst, (inst > 0).astype(np.uint16), None, s, np.eye(4), n)


def plane(z=2.0, **kw):
    return frame(np.full((H, W), z), **kw)


def step(near=1.0, far=2.0):
    d = np.full((H, W), far)
    d[:, : W // 2] = near
    return frame(d, instance=np.where(np.arange(W) < W // 2, 1, 2)[None].repeat(H, 0))


def table(*materials):
    """A material table whose instance k + 1 has materials[k]."""
    scene = gg.Scene()
    for m in materials:
        scene.add(trimesh.creation.box((1, 1, 1)), material=m)
    return MaterialTable.from_scene(scene)


def simulated(eff, f, materials=None, seed=0):
    """(simulate's frame and record, the forced run's frame, both generators after)."""
    sensor = gg.Sensor(
        f.sensor.width, f.sensor.height, f.sensor.K, effects=(eff,), stereo=Stereo(0.05)
    )
    rng_a, rng_b = np.random.default_rng(seed), np.random.default_rng(seed)
    out = simulate(
        sensor,
        np.eye(4),
        render=lambda s, p, **kw: f.replace(sensor=s),
        rng=rng_a,
        materials=materials,
    )
    needs = {"materials": materials} if eff.needs_materials else {}
    forced = eff.apply(f.replace(sensor=sensor), rng=rng_b, **needs)
    return out, out.meta["effects"][0], forced, rng_a, rng_b


def same(a, b):
    return a.depth.tobytes() == b.depth.tobytes() and a.instance.tobytes() == b.instance.tobytes()


# effect, frame where the frame check skips it, frame where it runs, materials
CASES = {
    "range": (RangeLimits(min_m=0.5, max_m=3.0), plane(2.0), step(1.0, 4.0), None),
    "depth_noise": (DepthNoise(model="tof_linear"), plane(0.0), plane(2.0), None),
    "flying_pixels": (FlyingPixels(), plane(2.0), step(1.0, 2.0), None),
    "edge_dropout": (EdgeDropout(span_m=0.8), step(1.0, 1.5), step(1.0, 2.0), None),
    "incidence_dropout": (
        IncidenceDropout(max_angle_deg=75.0),
        plane(2.0, normal=(np.sin(0.7), 0, -np.cos(0.7))),
        plane(2.0, normal=(np.sin(1.4), 0, -np.cos(1.4))),
        None,
    ),
    "mixed_pixels": (MixedPixels(), plane(2.0), step(1.0, 2.0), table(MATTE, MATTE)),
    "ambiguity": (Ambiguity(ambiguity_m=3.0), plane(2.0), plane(4.0), None),
    "specular_loss": (SpecularLoss(), plane(2.0), plane(2.0), None),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_frame_check_skip_is_the_run_byte_for_byte_and_a_run_changes_pixels(name):
    eff, quiet, busy, materials = CASES[name]
    quiet_mat = busy_mat = materials
    if name == "specular_loss":
        quiet_mat, busy_mat = table(MATTE), table(METAL)  # matte: skipped; mirror-angle metal: runs
    out, rec, forced, rng_a, rng_b = simulated(eff, quiet, quiet_mat)
    assert rec["run"] is False and rec["reason"] and rec["changed"] == 0
    assert same(out, forced)
    assert rng_a.bit_generator.state == rng_b.bit_generator.state  # the same RNG stream
    out, rec, forced, rng_a, rng_b = simulated(eff, busy, busy_mat)
    assert rec["run"] is True and rec["changed"] > 0 and same(out, forced)
    # what the effect counted itself (or simulate compared) is the pixels that differ
    assert rec["changed"] == int(
        ((busy.depth != out.depth) | (busy.instance != out.instance)).sum()
    )
    assert rng_a.bit_generator.state == rng_b.bit_generator.state


def test_every_effect_can_be_planned():
    """Every registered effect answers plan() on an empty view with a skip and a reason."""
    from genie_gl.effects.base import View

    empty = View(gg.Sensor.pinhole(8, 8, 10.0), np.eye(4), np.zeros(0, np.uint32), 0.0, 0.0)
    for name, cls in EFFECTS.items():
        eff = cls() if name != "stereo_shadow" else cls(baseline_m=0.05)
        d = eff.plan(empty)
        assert d is not None and d.run is False and d.reason, name


# -- with the renderer ---------------------------------------------------------------------------


def tof(*effects):
    return gg.Sensor.pinhole(W, H, 70.0, effects=effects, name="tof-test")


def sphere_scene(material=MATTE, far_one=False):
    s = gg.Scene()
    s.add(
        trimesh.creation.icosphere(subdivisions=3, radius=0.5),
        np.eye(4),
        semantic=1,
        material=material,
    )
    if far_one:  # wholly beyond the range: culled
        s.add(
            trimesh.creation.icosphere(subdivisions=2, radius=0.5),
            [0.0, 0.0, -30.0],
            semantic=2,
            material=material,
        )
    return s


def corner_scene(material=METAL):
    """Two 2 m plates at 90° meeting along the z axis, the inside facing +x +y."""
    s = gg.Scene()
    s.add(trimesh.creation.box((2.0, 0.02, 2.0)), [1.0, 0.0, 0.0], semantic=1, material=material)
    s.add(trimesh.creation.box((0.02, 2.0, 2.0)), [0.0, 1.0, 0.0], semantic=1, material=material)
    return s


SPHERE_POSE = look_at([0.0, 0.0, 2.0], [0.0, 0.0, 0.0], up=(0, 1, 0))
CORNER_POSE = look_at([2.0, 2.0, 0.3], [0.0, 0.0, 0.0])


def captured(scene, sensor, pose, seed=3):
    planned = gg.capture(scene, sensor, [pose], seed=seed)[0]
    unplanned = gg.capture(scene, sensor, [pose], seed=seed, plan=None)[0]
    return planned, unplanned


@pytest.mark.gl
def test_multipath_skipped_on_a_matte_convex_object_and_the_frame_is_identical():
    sensor = tof(
        RangeLimits(min_m=0.5, max_m=4.0), TofMultipath(samples=64), DepthNoise(model="tof_linear")
    )
    scene = sphere_scene()
    p = gg.plan(scene, sensor, [SPHERE_POSE])
    decided = {e.name: e for e in p.frames[0].effects}
    assert decided["tof_multipath"].run is False and "convex" in decided["tof_multipath"].reason
    assert decided["range"].run is False  # the sphere lies at 1.5-2.5 m, inside [0.5, 4]
    planned, unplanned = captured(scene, sensor, SPHERE_POSE)
    assert (planned.depth > 0).sum() > 500
    assert same(planned, unplanned)  # skipping == running, noise after it included
    ran = {e["name"]: e for e in unplanned.meta["effects"]}
    assert ran["tof_multipath"]["run"] is True and ran["tof_multipath"]["changed"] == 0
    assert {e["name"]: e["run"] for e in planned.meta["effects"]}["tof_multipath"] is False


@pytest.mark.gl
def test_multipath_in_a_metallic_inner_corner_pushes_depth_away_never_closer():
    eff = TofMultipath(samples=64)
    scene = corner_scene()
    p = gg.plan(scene, tof(eff), [CORNER_POSE])
    assert p.frames[0].effects[0].run is True and "reflective" in p.frames[0].effects[0].reason
    ideal = gg.render(scene, tof(), CORNER_POSE)
    out = gg.capture(scene, tof(eff), [CORNER_POSE], seed=0)[0]
    valid = ideal.depth > 0
    assert np.array_equal(out.depth > 0, valid)
    delta = out.depth.astype(np.float64) - ideal.depth
    assert (delta[valid] >= 0).all()  # never closer
    assert (delta > 1e-4).sum() > 0.05 * valid.sum()  # a visible share moves away
    rec = out.meta["effects"][0]
    assert rec["run"] and rec["changed"] == int((delta != 0).sum())
    # the bias is largest where the plates meet (the shortest second bounce), nothing far off
    u_mid = W // 2
    assert delta[:, u_mid - 3 : u_mid + 4].max() > delta[:, :5].max()


@pytest.mark.gl
def test_plan_level_skips_keep_output_and_rng_stream():
    """calibration_error with zero sigmas and a constant lateral noise of 0 px are skipped by
    the plan; they still draw what they would, so the noise after them is the same."""
    sensor = tof(
        CalibrationError(sigma_f_px=0.0, sigma_c_px=0.0),
        LateralNoise(model="constant", sigma_px=0.0),
        LowAlbedo(),
        SpecularLoss(),
        Multipath(),
        DepthNoise(model="tof_linear"),
    )
    scene = sphere_scene()
    p = gg.plan(scene, sensor, [SPHERE_POSE]).frames[0]
    assert [e.run for e in p.effects] == [False, False, False, False, False, None]
    planned, unplanned = captured(scene, sensor, SPHERE_POSE)
    assert same(planned, unplanned)
    assert [e["run"] for e in unplanned.meta["effects"]] == [True, True, True, False, True, True]
    assert all(e["changed"] == 0 for e in unplanned.meta["effects"][:-1])


@pytest.mark.gl
def test_low_albedo_and_specular_loss_run_where_the_scene_calls_for_them():
    dark = Material((0.02, 0.02, 0.02), 0.0, 0.9)
    eff = LowAlbedo(ref_albedo=0.15, ref_range_m=4.65)
    cut = 4.65 * np.sqrt(dark.albedo / 0.15)  # 1.70 m: the sphere spans 1.5-2.0 m of range
    sensor = tof(eff)
    p = gg.plan(sphere_scene(dark), sensor, [SPHERE_POSE]).frames[0]
    assert p.effects[0].run is None
    out = gg.capture(sphere_scene(dark), sensor, [SPHERE_POSE], seed=0)[0]
    # albedo 0.02 returns only while r <= cut: the sphere's cap
    ideal = gg.render(sphere_scene(dark), tof(), SPHERE_POSE)
    r = _ranges(ideal)
    kept = out.depth > 0
    assert kept.sum() > 50 and np.array_equal(kept, (ideal.depth > 0) & (r <= cut))
    assert ((r > cut) & (ideal.depth > 0)).sum() > 50
    shiny = tof(SpecularLoss())
    out = gg.capture(sphere_scene(METAL), shiny, [SPHERE_POSE], seed=0)[0]
    assert out.meta["effects"][0]["run"] and out.meta["effects"][0]["changed"] > 0


@pytest.mark.gl
def test_range_culling_and_empty_frames():
    sensor = tof(RangeLimits(min_m=0.5, max_m=4.0))
    scene = sphere_scene(far_one=True)
    pose = look_at([0.0, 0.0, 2.0], [0.0, 0.0, -30.0], up=(0, 1, 0))  # both spheres in line
    p = gg.plan(scene, sensor, [pose, look_at([0.0, 0.0, 2.0], [0.0, 0.0, 10.0], up=(0, 1, 0))])
    far_id = scene.instances[1].instance
    assert p.frames[0].culled_range.tolist() == [far_id]
    assert far_id not in p.frames[0].drawn
    assert 4.0 < p.frames[0].far_m < 4.5
    assert p.frames[1].empty and "nothing" in p.frames[1].reason and p.empty_frames == [1]
    d = p.to_dict()
    assert d["frames"][0]["effects"][0]["name"] == "range" and d["predicted_s"] > 0
    planned, unplanned = captured(scene, sensor, pose)
    assert same(planned, unplanned)


@pytest.mark.gl
def test_stereo_shadow_renders_the_second_view_only_for_an_edge():
    flat = gg.Scene()
    flat.add(trimesh.creation.box((6.0, 6.0, 0.02)), [0.0, 0.0, 0.0], material=MATTE)
    boxed = gg.Scene()
    boxed.add(trimesh.creation.box((6.0, 6.0, 0.02)), [0.0, 0.0, 0.0], material=MATTE)
    boxed.add(trimesh.creation.box((0.3, 0.3, 0.6)), [0.0, 0.0, 0.3], material=MATTE)
    pose = look_at([0.0, 0.0, 2.0], [0.0, 0.0, 0.0], up=(0, 1, 0))

    class Always(StereoShadow):
        def casts_shadow(self, frame):
            return True

    for scene, rendered in (
        (flat, False),
        (boxed, True),
    ):  # the render method (scanline renders nothing)
        out = gg.capture(
            scene, tof(StereoShadow(baseline_m=0.05, method="render")), [pose], seed=0
        )[0]
        forced = gg.capture(scene, tof(Always(baseline_m=0.05, method="render")), [pose], seed=0)[0]
        assert out.meta["stereo_shadow"]["second_view"] is rendered
        assert same(out, forced)
        assert out.meta["effects"][0]["changed"] > 0  # the border band, and the strip


def test_edge_pixels_are_those_of_the_full_frame_step():
    """The compiled edge search finds the pixels and neighbours largest_step() does."""
    from genie_gl.effects import kernels
    from genie_gl.effects.edges import largest_step

    d = np.random.default_rng(0).choice([0.0, 1.0, 1.02, 2.0, 3.5], (60, 80)).astype(np.float32)
    step, other = largest_step(d)
    edge = np.flatnonzero(np.abs(step) > 0.05)
    got, nb = kernels.edge_pixels(d, 0.05)
    assert len(edge) > 100 and np.array_equal(got, edge)
    assert np.array_equal(d.ravel()[nb].astype(np.float64), other.ravel()[edge])


def test_nguyen_incidence_term_computed_only_where_it_applies_gives_the_same_sigma():
    """Angles are computed only where cos θ < 1/2 (θ > 60°); σ is the full computation's."""
    from genie_gl.effects.geometry import incidence_angle

    rng = np.random.default_rng(0)
    d = rng.uniform(0.5, 4, (H, W)).astype(np.float32)
    d[::5] = 0
    n = rng.normal(size=(H, W, 3))
    n[..., 2] = -np.abs(n[..., 2])
    n = (n / np.linalg.norm(n, axis=-1, keepdims=True)).astype(np.float32)
    n[d == 0] = 0
    f = gg.Frame(
        d,
        (d > 0).astype(np.uint32),
        (d > 0).astype(np.uint16),
        None,
        gg.Sensor.pinhole(W, H, 60.0),
        np.eye(4),
        n,
    )
    eff, valid = DepthNoise(model="kinect_nguyen2012"), d > 0
    full = incidence_angle(f)[valid]
    assert (full > np.pi / 3).sum() > 100
    np.testing.assert_array_equal(
        eff.sigma(d[valid].astype(float), 60.0, DepthNoise.steep_angles(f, valid)),
        eff.sigma(d[valid].astype(float), 60.0, full),
    )


def test_instance_spheres_follow_each_transform():
    """A box's bounding sphere moved, turned and scaled by each instance's transform: centre
    T @ (box centre), radius the half diagonal times the largest column scale."""
    from genie_gl.capture.planner import _spheres

    scene = gg.Scene()
    key = scene.add_mesh(
        trimesh.creation.box(extents=(2.0, 1.0, 0.5)).apply_translation((1.0, 0.0, 0.25))
    )
    rng = np.random.default_rng(3)
    want = []
    for k in range(25):
        yaw, s = rng.uniform(-np.pi, np.pi), rng.uniform(0.5, 2.0, 3)
        T = np.eye(4)
        T[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
        T[:3, :3] = T[:3, :3] * s
        T[:3, 3] = rng.uniform(-20, 20, 3)
        scene.add(key, T, instance=100 + 2 * k)
        want.append(
            (
                100 + 2 * k,
                T[:3, :3] @ [1.0, 0.0, 0.25] + T[:3, 3],
                np.sqrt(2.0**2 + 1 + 0.25) / 2 * s.max(),
            )
        )
    ids, centres, radii = _spheres(scene)
    assert ids.tolist() == [w[0] for w in want]
    assert np.allclose(centres, [w[1] for w in want], atol=1e-9) and np.allclose(
        radii, [w[2] for w in want], atol=1e-9
    )
    empty = _spheres(gg.Scene())
    assert [a.shape for a in empty] == [(0,), (0, 3), (0,)]
