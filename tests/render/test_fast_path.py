"""The fast path changes no pixel: culled == unculled (depth bytes, ids, colour), on generated
scenes, a scene of sub-pixel triangles, a far-away scene and the tests' object and hall scenes;
the depth-precision options against analytic depth."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.errors import ConfigError
from genie_gl.render import Renderer, create_context
from genie_gl.sensors.pose import look_at
from genie_gl.resources import resolve
from tests.scenes import scene_of, sensor_640

from .conftest import ray_dirs

pytestmark = pytest.mark.gl


def assert_same_frames(a, b):
    assert a.depth.tobytes() == b.depth.tobytes()
    assert np.array_equal(a.instance, b.instance) and np.array_equal(a.semantic, b.semantic)
    if a.rgb is not None or b.rgb is not None:
        assert np.array_equal(a.rgb, b.rgb)


def culled_and_unculled(glctx, scene, sensor, poses, **kw):
    with (
        Renderer(scene, context=glctx, cull=False) as a,
        Renderer(scene, context=glctx, cull=True) as b,
    ):
        b.cull_min_faces = b.occlusion_min_faces = 0  # cull however few faces are in view,
        b._culler.break_even = 0.0  # and occlusion-cull every frame
        out = []
        for p in poses:
            fa, fb = a.render(sensor, p, **kw), b.render(sensor, p, **kw)
            out.append((fa, fb, a.stats["triangles_drawn"], b.stats["triangles_drawn"]))
        return out


def test_culling_changes_no_pixel_on_the_benchmark_scene(glctx):
    scene, poses = scene_of("100k")
    pairs = culled_and_unculled(glctx, scene, sensor_640(), poses)
    for fa, fb, na, nb in pairs:
        assert_same_frames(fa, fb)
        assert (fa.instance > 0).mean() > 0.3
        assert nb < 0.7 * na  # it does cull: sub-pixel, off-screen and back faces


@pytest.mark.parametrize("size", ["1M", "hall"])
def test_culling_changes_no_pixel_on_the_million_and_ten_million_triangle_scenes(glctx, size):
    scene, poses = scene_of(size)
    ((fa, fb, na, nb),) = culled_and_unculled(
        glctx, scene, sensor_640(), poses[:1], depth_only=True
    )
    assert_same_frames(fa, fb)
    assert (fa.instance > 0).mean() > 0.3
    assert nb < (0.4 if size == "1M" else 0.05) * na


def test_culling_changes_no_pixel_on_a_generated_scene(glctx):
    layout = gg.generate_layout(resolve("assembly_line", "layouts", (".json",)), seed=3)
    scene = gg.build_scene(layout, seed=3)
    sensor = gg.Sensor.pinhole(160, 120, 130.0)
    poses = gg.place_sensors(layout, sensor, n=4, seed=3)
    for fa, fb, na, nb in culled_and_unculled(glctx, scene, sensor, poses, normals=True):
        assert_same_frames(fa, fb)
        assert fa.normal.tobytes() == fb.normal.tobytes()
        assert (fa.instance > 0).any() and nb < na


def test_culling_changes_no_pixel_with_sub_pixel_triangles_near_pixel_centres():
    """Thousands of triangles smaller than a pixel, many of them with a corner within a
    hundredth of a pixel of a pixel centre (where a careless box test drops a covered centre),
    seen from random poses at odd scales, plus one far-away copy of the scene."""
    rng = np.random.default_rng(11)
    sensor = gg.Sensor(97, 73, np.array([[90.0, 0.3, 48.2], [0, 93.0, 36.7], [0, 0, 1]]))
    scene = gg.Scene()
    n = 4000
    # triangles around points on a sphere of radius 2 seen from its centre region
    centre = rng.normal(size=(n, 3))
    centre *= 2.0 / np.linalg.norm(centre, axis=1, keepdims=True)
    size = rng.uniform(0.002, 0.05, n)
    tri = centre[:, None, :] + rng.normal(size=(n, 3, 3)) * size[:, None, None]
    mesh = gg.Mesh(tri.reshape(-1, 3), np.arange(3 * n).reshape(-1, 3))
    scene.add(mesh, np.eye(4), semantic=2)
    ball = trimesh.creation.icosphere(4, radius=0.3)
    for k in range(6):
        T = np.eye(4)
        T[:3, 3] = rng.uniform(-1, 1, 3)
        scene.add(ball, T, semantic=3)
    far = gg.Scene()
    shift = np.eye(4)
    shift[:3, 3] = [1e7, -1e7, 3e6]
    for inst in scene.instances:
        far.add(scene.meshes[inst.mesh], shift @ inst.world_from_model, semantic=inst.semantic)
    poses = []
    for k in range(6):
        eye = rng.uniform(-0.5, 0.5, 3)
        poses.append(look_at(eye, eye + rng.normal(size=3)))
    # snap the view so that many triangle corners fall almost on pixel centres
    gl = create_context("egl")
    try:
        pairs = culled_and_unculled(gl, scene, sensor, poses)
        far_pairs = culled_and_unculled(gl, far, sensor, [shift @ p for p in poses])
    finally:
        gl.release()
    for (fa, fb, na, nb), (ga, gb, _, _) in zip(pairs, far_pairs):
        assert_same_frames(fa, fb)
        assert_same_frames(ga, gb)
        assert nb < na
        hit = fa.depth > 0
        assert hit.mean() > 0.05 and np.array_equal(ga.instance > 0, hit)
        np.testing.assert_allclose(ga.depth[hit], fa.depth[hit], rtol=1e-5)


def test_benchmark_scene_moved_1e7_m_away_renders_the_same_depth(glctx):
    scene, poses = scene_of("100k")
    shift = np.eye(4)
    shift[:3, 3] = [1e7, -1e7, 2e6]
    far = gg.Scene()
    for inst in scene.instances:
        far.add(scene.meshes[inst.mesh], shift @ inst.world_from_model, semantic=inst.semantic)
    sensor = sensor_640()
    with Renderer(scene, context=glctx) as a, Renderer(far, context=glctx) as b:
        for p in poses[:2]:
            fa, fb = a.render(sensor, p), b.render(sensor, shift @ p)
            hit = fa.instance > 0
            assert hit.mean() > 0.3
            assert (
                fa.instance == fb.instance
            ).mean() > 0.999  # ids may differ on a few edge pixels
            same = hit & (fa.instance == fb.instance)
            np.testing.assert_allclose(fb.depth[same], fa.depth[same], rtol=1e-6)


def test_unknown_depth_precision_is_a_config_error():
    with pytest.raises(ConfigError, match="depth_precision"):
        Renderer(gg.Scene(), depth_precision="float16")


def tilted_plane(distance, pose=np.eye(4)):
    """A plane 30 degrees off fronto-parallel, through (0, 0, distance) in the camera frame."""
    n = np.array([np.sin(np.radians(30)), 0.0, -np.cos(np.radians(30))])
    p0 = np.array([0.0, 0.0, distance])
    a = np.cross(n, [0, 1, 0])
    a /= np.linalg.norm(a)
    b = np.cross(n, a)
    s = 2.0 * distance
    corners = [p0 + s * (sa * a + sb * b) for sa, sb in [(-1, -1), (1, -1), (1, 1), (-1, 1)]]
    return gg.Mesh(np.array(corners), np.array([[0, 1, 2], [0, 2, 3]])), n, p0


@pytest.mark.parametrize("precision", ["float32", "depth24", "reversed_z"])
def test_depth_precision_against_analytic_plane_depth(glctx, precision):
    near, far = 0.1, 100.0
    sensor = gg.Sensor.pinhole(96, 72, 80.0, near_m=near, far_m=far)
    rays = ray_dirs(sensor)
    worst = []
    for distance in (0.5, 2.0, 8.0, 32.0):
        mesh, n, p0 = tilted_plane(distance)
        scene = gg.Scene()
        scene.add(mesh, semantic=4, instance=9)
        with (
            Renderer(scene, context=glctx, depth_precision=precision) as r,
            Renderer(scene, context=glctx) as ref,
        ):
            f, g = r.render(sensor, np.eye(4)), ref.render(sensor, np.eye(4))
        expected = (n @ p0) / (rays @ n)
        hit = f.instance > 0
        assert (
            hit.all()
            and np.array_equal(f.instance, g.instance)
            and np.array_equal(f.semantic, g.semantic)
        )
        err = np.abs(f.depth[hit] - expected[hit])
        if precision == "depth24":
            # window depth d = A + B / z, stored in 24 bits: dz = z^2 (f - n) / (f n) * 2^-24 per
            # step; the float32 rounding of d (d ~ 1) before storing is of the same size
            step = expected[hit] ** 2 * (far - near) / (far * near) / (2**24 - 1)
            assert (err <= 3 * step + 1e-6 * expected[hit]).all()
            worst.append(err.max() / distance**2)
            if distance > 4:
                assert err.max() > 0.1 * step.max()  # not secretly the float32 target
        else:
            assert (err <= (1e-5 if precision == "float32" else 1e-6) * expected[hit]).all()
    if precision == "depth24":
        # error / z^2 stays of one order from 0.5 m to 32 m: it grows as z^2
        assert max(worst) < 20 * min(worst)


def test_overlapped_frames_equal_frame_by_frame_renders(glctx):
    layout = gg.generate_layout(resolve("assembly_line", "layouts", (".json",)), seed=1)
    scene = gg.build_scene(layout, seed=1)
    sensor = gg.Sensor.pinhole(120, 90, 100.0)
    poses = gg.place_sensors(layout, sensor, n=5, seed=1)
    with Renderer(scene, context=glctx) as r:
        one_by_one = [r.render(sensor, p, normals=True) for p in poses]
        overlapped = list(r.frames(sensor, poses, normals=True))
    assert len(overlapped) == len(poses)
    for a, b in zip(one_by_one, overlapped):
        assert_same_frames(a, b)
        assert a.normal.tobytes() == b.normal.tobytes()
        assert np.array_equal(a.world_from_camera, b.world_from_camera)


def test_renders_between_overlapped_frames_change_neither(glctx):
    """A frame of ``frames`` is handed over while the next one rasterises: a render the
    caller makes then (an effect's extra view) and the frames after it are all as drawn one
    by one."""
    layout = gg.generate_layout(resolve("assembly_line", "layouts", (".json",)), seed=2)
    scene = gg.build_scene(layout, seed=2)
    sensor = gg.Sensor.pinhole(120, 90, 100.0)
    poses = gg.place_sensors(layout, sensor, n=4, seed=2)
    extra = [poses[(k + 2) % 4] for k in range(4)]
    with Renderer(scene, context=glctx) as r:
        one_by_one = [r.render(sensor, p) for p in poses]
        extra_alone = [r.render(sensor, p, depth_only=True) for p in extra]
        overlapped, between = [], []
        for k, f in enumerate(r.frames(sensor, poses)):
            between.append(r.render(sensor, extra[k], depth_only=True))
            overlapped.append(f)
    assert (one_by_one[0].instance > 0).mean() > 0.2
    for a, b in zip(one_by_one + extra_alone, overlapped + between):
        assert_same_frames(a, b)
        assert (a.rgb is None) == (b.rgb is None) and (
            a.rgb is None or a.rgb.tobytes() == b.rgb.tobytes()
        )


def test_culling_keeps_triangles_that_miss_a_pixel_centre_by_less_than_the_snapping():
    """Triangles one of whose edges passes within 1/500 pixel of a pixel centre, on either
    side: the GPU snaps vertices to 1/256 pixel, so some that miss the centre exactly cover it
    once drawn. The culled frame must still equal the unculled one (an error bound of
    1/1024 pixel, or none, fails here)."""
    rng = np.random.default_rng(5)
    W, H, f = 96, 72, 100.0
    sensor = gg.Sensor(W, H, np.array([[f, 0.0, 47.3], [0, f, 35.6], [0, 0, 1]]))
    K = sensor.K
    tris = []
    for cu in range(2, W - 2, 3):
        for cv in range(2, H - 2, 3):
            # an edge through the centre (cu, cv) at a random angle, moved off it by delta px
            a = rng.uniform(0, 2 * np.pi)
            d, n = np.array([np.cos(a), np.sin(a)]), np.array([-np.sin(a), np.cos(a)])
            delta = rng.uniform(-0.002, 0.002)
            p0 = np.array([cu, cv]) + delta * n - rng.uniform(0.2, 0.9) * d
            p1 = p0 + rng.uniform(0.4, 1.1) * d
            p2 = (p0 + p1) / 2 - rng.uniform(0.1, 0.6) * n  # third corner away from the centre
            tris.append([p0, p1, p2])
    uv = np.array(tris).reshape(-1, 2)
    z = 2.0
    xyz = np.stack(
        [(uv[:, 0] - K[0, 2]) * z / f, (uv[:, 1] - K[1, 2]) * z / f, np.full(len(uv), z)], axis=1
    )
    faces = np.arange(len(xyz)).reshape(-1, 3)
    scene = gg.Scene()
    scene.add(gg.Mesh(xyz, np.concatenate([faces, faces[:, ::-1]])), np.eye(4), semantic=1)
    gl = create_context("egl")
    try:
        ((fa, fb, na, nb),) = culled_and_unculled(gl, scene, sensor, [np.eye(4)], depth_only=True)
    finally:
        gl.release()
    assert_same_frames(fa, fb)
    assert nb < 0.8 * na and (fa.instance > 0).sum() > 100
