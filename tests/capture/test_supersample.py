"""Edge supersampling: ids are never blended, planes keep their exact depth."""

import numpy as np
import pytest

from genie_gl.frame import Frame
from genie_gl.capture.supersample import majority, reduce, supersample_sensor, supersampled
from genie_gl.sensors.camera import Sensor


@pytest.fixture(scope="module")
def glctx():
    """A context of this module's own: pyrender's EGL platform terminates the display when a
    reference renderer is freed (tests/render/test_reference.py), which ends the session's."""
    from genie_gl.render import create_context

    gl = create_context("egl")
    yield gl
    with gl.ctx:
        assert gl.ctx.error == "GL_NO_ERROR"
    gl.release()


def test_majority_is_the_most_frequent_id_with_ties_to_the_nearer_surface():
    rng = np.random.default_rng(0)
    ids = rng.integers(0, 4, (3000, 16)).astype(np.uint32)
    depth = rng.uniform(0.5, 5, (3000, 16)).astype(np.float32)
    depth[ids == 0] = 0
    pick = majority(ids, depth)
    for i in range(len(ids)):
        vals, counts = np.unique(ids[i], return_counts=True)
        top = vals[counts == counts.max()]
        assert ids[i, pick[i]] in top
        z = np.where(depth[i] > 0, depth[i], np.inf)
        assert z[pick[i]] == min(z[k] for k in range(16) if ids[i, k] in top)
    prefer = rng.integers(0, 4, len(ids)).astype(np.uint32)
    pick = majority(ids, depth, prefer)
    for i in range(len(ids)):
        vals, counts = np.unique(ids[i], return_counts=True)
        top = vals[counts == counts.max()]
        assert ids[i, pick[i]] == prefer[i] if prefer[i] in top else ids[i, pick[i]] in top


def test_the_high_resolution_camera_puts_each_block_symmetrically_about_the_pixel_centre():
    s = Sensor.pinhole(64, 48, 50.0, cx=30.2, cy=20.7)
    hi = supersample_sensor(s, 4)
    # pixel (u, v) of s and the centre of its 4 x 4 block in hi see the same ray
    u, v = 10.0, 7.0
    x, y = (u - s.cx) / s.fx, (v - s.cy) / s.fy
    uh, vh = hi.fx * x + hi.cx, hi.fy * y + hi.cy
    assert (uh, vh) == pytest.approx((4 * u + 1.5, 4 * v + 1.5))


def _random_boxes(seed):
    import trimesh

    from genie_gl.scene.model import Scene

    rng = np.random.default_rng(seed)
    scene = Scene()
    scene.add(trimesh.creation.box((8, 8, 0.02)), [0, 0, 4.0], semantic=9, instance=1000)
    for k in range(30):
        size = rng.uniform(0.01, 0.3, 3)  # some thinner than a pixel
        scene.add(
            trimesh.creation.box(size),
            [*rng.uniform(-1, 1, 2), rng.uniform(1.5, 3.5)],
            semantic=int(rng.integers(1, 8)),
            instance=int(rng.integers(1, 2**31)),
        )
    return scene


@pytest.mark.gl
@pytest.mark.parametrize("s", [2, 4])
def test_supersampling_never_produces_an_id_not_in_the_scene(glctx, s):
    from genie_gl.render import Renderer

    scene = _random_boxes(s)
    ids = {i.instance for i in scene.instances} | {0}
    sem_of = {i.instance: i.semantic for i in scene.instances} | {0: 0}
    sensor = Sensor.pinhole(96, 72, 80.0)
    with Renderer(scene, context=glctx) as r:
        f = supersampled(r.render, s)(sensor, np.eye(4))
        hi = r.render(supersample_sensor(sensor, s), np.eye(4))
    assert set(np.unique(f.instance).tolist()) <= ids
    # each pixel's id is one of its own block's samples', its semantic id that instance's
    blocks = hi.instance.reshape(72, s, 96, s).swapaxes(1, 2).reshape(72, 96, s * s)
    assert (blocks == f.instance[..., None]).any(-1).all()
    assert all(sem_of[int(i)] == int(c) for i, c in zip(f.instance.ravel(), f.semantic.ravel()))
    assert ((f.depth > 0) == (f.instance > 0)).all()
    # its depth is the centre ray's where that ray saw the instance kept, else it lies within
    # its instance's own samples (never between two surfaces)
    with Renderer(scene, context=glctx) as r:
        centre = r.render(sensor, np.eye(4))
    on_centre = (centre.instance == f.instance) & (f.instance > 0)
    assert on_centre.mean() > 0.9 and np.array_equal(f.depth[on_centre], centre.depth[on_centre])
    zb = hi.depth.reshape(72, s, 96, s).swapaxes(1, 2).reshape(72, 96, s * s)
    own = blocks == f.instance[..., None]
    lo = np.where(own, zb, np.inf).min(-1)
    top = np.where(own, zb, -np.inf).max(-1)
    rest = (f.instance > 0) & ~on_centre
    assert rest.any()
    assert (f.depth[rest] >= lo[rest] * (1 - 1e-6)).all() and (
        f.depth[rest] <= top[rest] * (1 + 1e-6)
    ).all()
    assert (
        f.instance != hi.instance[s // 2 :: s, s // 2 :: s]
    ).any() or s == 1  # the reduction did something


@pytest.mark.gl
def test_a_tilted_plane_keeps_its_exact_depth_at_every_supersampling(glctx):
    from genie_gl.render import Renderer
    from genie_gl.scene.model import Mesh, Scene

    n = np.array([np.sin(0.6), 0.2, -np.cos(0.6)])
    n /= np.linalg.norm(n)
    p0 = np.array([0.0, 0.0, 2.5])
    a = np.cross(n, [0, 1.0, 0])
    a /= np.linalg.norm(a)
    b = np.cross(n, a)
    corners = [p0 + 5 * (sa * a + sb * b) for sa, sb in [(-1, -1), (1, -1), (1, 1), (-1, 1)]]
    scene = Scene()
    scene.add(Mesh(np.array(corners), np.array([[0, 1, 2], [0, 2, 3]])), semantic=1)
    sensor = Sensor.pinhole(80, 60, 70.0)
    u, v = np.meshgrid(np.arange(80.0), np.arange(60.0))
    d = np.stack([(u - sensor.cx) / sensor.fx, (v - sensor.cy) / sensor.fy, np.ones_like(u)], -1)
    truth = (n @ p0) / (d @ n)
    with Renderer(scene, context=glctx) as r:
        for s in (1, 2, 4):
            f = supersampled(r.render, s)(sensor, np.eye(4), normals=True)
            np.testing.assert_allclose(f.depth, truth, rtol=2e-6)
            np.testing.assert_allclose(np.abs(f.normal.reshape(-1, 3) @ n), 1.0, atol=1e-5)


def test_reduce_of_a_uniform_frame_is_the_frame_itself():
    s = Sensor.pinhole(8, 6, 10.0)
    hi = supersample_sensor(s, 2)
    z = np.full((12, 16), 2.0, np.float32)
    inst = np.full((12, 16), 7, np.uint32)
    f = reduce(Frame(z, inst, np.full((12, 16), 3, np.uint16), None, hi, np.eye(4)), s, 2)
    assert (f.depth == 2.0).all() and (f.instance == 7).all() and (f.semantic == 3).all()


@pytest.mark.gl
def test_one_object_hiding_part_of_itself_gets_no_depth_between_its_parts(glctx):
    """A bar 1 m before a plate, both one instance: each pixel's depth is the bar's or the
    plate's, never a mean of the two (the bar's edges cross pixels at random offsets)."""
    from genie_gl.render import Renderer
    from genie_gl.scene.model import Mesh, Scene

    def quad(x0, x1, y0, y1, z):
        return [[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]]

    v = np.array(quad(-0.123, 0.077, -2, 2, 2.0) + quad(-3, 3, -3, 3, 3.0))
    f = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    scene = Scene()
    scene.add(Mesh(v, f), semantic=1, instance=5)
    sensor = Sensor.pinhole(64, 48, 60.0)
    with Renderer(scene, context=glctx) as r:
        for s in (2, 4):
            out = supersampled(r.render, s)(sensor, np.eye(4))
            z = out.depth[out.depth > 0]
            assert z.size == 64 * 48
            on_part = np.isclose(z, 2.0, rtol=1e-5) | np.isclose(z, 3.0, rtol=1e-5)
            assert on_part.all(), np.unique(z[~on_part])
            assert np.isclose(z, 2.0).sum() > 0 and set(np.unique(out.instance)) == {5}


@pytest.mark.gl
def test_capture_applies_the_settings_given_or_the_profiles(glctx):
    """capture(accuracy=...) renders through the supersampler and sets the effects' knobs; a
    profile's accuracy: block applies when none is given."""
    import dataclasses

    from genie_gl.capture import capture
    from genie_gl.render import Renderer
    from genie_gl.sensors.accuracy import AccuracySettings
    from genie_gl.effects.shadow import StereoShadow

    scene = _random_boxes(7)
    sensor = Sensor.pinhole(48, 36, 40.0, effects=(StereoShadow(baseline_m=0.1, scale=0.5),))
    acc = AccuracySettings(supersample=2, shadow_scale=0.25)
    (f,) = capture(scene, sensor, [np.eye(4)], seed=0, accuracy=acc, raster="gl")
    assert f.meta["supersample"] == 2
    (g,) = capture(
        scene, dataclasses.replace(sensor, accuracy=acc), [np.eye(4)], seed=0, raster="gl"
    )
    assert np.array_equal(f.depth, g.depth) and np.array_equal(f.instance, g.instance)
    # the same frame by hand: a 2x render reduced, a second view at a quarter of the scale
    by_hand = dataclasses.replace(sensor, effects=(StereoShadow(baseline_m=0.1, scale=0.25),))
    from genie_gl.effects.simulate import simulate

    with Renderer(scene, context=glctx) as r:
        h = simulate(
            by_hand, np.eye(4), render=supersampled(r.render, 2), rng=np.random.default_rng(0)
        )
    assert np.array_equal(f.depth, h.depth) and np.array_equal(f.instance, h.instance)
    (plain,) = capture(scene, sensor, [np.eye(4)], seed=0)
    assert "supersample" not in plain.meta and not np.array_equal(plain.instance, f.instance)
