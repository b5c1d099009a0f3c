"""Agreement with an independent rasteriser (pyrender, SEG mode) on a random ~200-object scene."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.render import Renderer
from genie_gl.sensors.pose import look_at
from genie_gl.render.reference import ReferenceRenderer

from .conftest import interior

pytestmark = pytest.mark.gl


def random_scene(rng, n=200, size=20.0):
    scene = gg.Scene()
    scene.add(trimesh.creation.box((size, size, 0.02)), [0, 0, -0.01], semantic=0)
    shapes = [
        trimesh.creation.box((1, 1, 1)),
        trimesh.creation.icosphere(2),
        trimesh.creation.cylinder(0.5, 1.0, sections=24),
    ]
    for i in range(n):
        T = trimesh.transformations.random_rotation_matrix(rng.random(3))
        T[:3, :3] *= rng.uniform(0.3, 1.2)
        T[:3, 3] = [*rng.uniform(-size / 2, size / 2, 2), rng.uniform(0.2, 2.0)]
        scene.add(shapes[i % 3], T, semantic=1 + i % 9)
    return scene


def test_agrees_with_pyrender_seg_mode(draw):
    rng = np.random.default_rng(11)
    scene = random_scene(rng)
    # pyrender linearises a 24-bit depth buffer: give it a tight near/far so that the
    # comparison measures geometry, not its depth quantisation
    sensor = gg.Sensor(
        320,
        240,
        np.array([[262.5, 0, 159.5], [0, 262.5, 119.5], [0, 0, 1]]),
        near_m=0.5,
        far_m=40.0,
    )
    poses = [look_at([-9.0, -9.0, 5.0], [0, 0, 0]), look_at([8.0, -3.0, 3.0], [-2, 2, 0.5])]
    ref = ReferenceRenderer(scene)
    with draw(scene) as r:
        for pose in poses:
            ours = r.render(sensor, pose, depth_only=True)
            theirs = ref.render(sensor, pose)
            both = (ours.depth > 0) & (theirs.depth > 0)
            assert both.mean() > 0.5
            assert np.median(np.abs(ours.depth[both] - theirs.depth[both])) < 1e-4
            differ = ours.instance != theirs.instance
            assert differ.mean() < 0.005
            # ids differ only on silhouettes: next to an id boundary in our image
            assert not (differ & interior(ours.instance, 1)).any()
            assert (ours.semantic == theirs.semantic)[~differ].all()
    ref.release()


def test_releasing_the_reference_leaves_our_contexts_working(glctx):
    """pyrender's own delete terminates the process's EGL display; ours must survive it."""
    scene = gg.Scene()
    scene.add(trimesh.creation.box((4, 4, 0.02)), [0, 0, -0.01], semantic=1)
    sensor = gg.Sensor(64, 48, np.array([[50.0, 0, 31.5], [0, 50.0, 23.5], [0, 0, 1]]))
    pose = look_at([0.0, 0.0, 3.0], [0, 0, 0], up=[0, 1, 0])
    ref = ReferenceRenderer(scene)
    ref.render(sensor, pose)
    ref.render(gg.Sensor(32, 24, sensor.K / [2, 2, 1]), pose)  # a new size releases the old one
    ref.release()
    with Renderer(scene, context=glctx) as r:
        depth = r.render(sensor, pose, depth_only=True).depth
    # the floor's top face at z = 0 seen from 3 m straight down: depth 3 at every pixel
    np.testing.assert_allclose(depth, 3.0, rtol=1e-6)
