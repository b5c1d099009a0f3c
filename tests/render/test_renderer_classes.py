"""``Renderer(scene, raster=)`` makes the renderer of the raster named, one class per raster,
and both hand the same winners to one shading: a box's front face at its analytic depth."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.render import CPURenderer, GLRenderer, Renderer
from genie_gl.render.rasters import default_raster
from genie_gl.sensors.pose import look_at

pytestmark = pytest.mark.gl


def box_scene() -> gg.Scene:
    scene = gg.Scene()
    scene.add(trimesh.creation.box((2.0, 2.0, 2.0)), [0.0, 0.0, 0.0])
    return scene


def test_each_raster_has_its_own_class_behind_one_entry():
    scene = box_scene()
    for raster, cls in (("cpu", CPURenderer), ("gl", GLRenderer)):
        with Renderer(scene, raster=raster) as r:
            assert type(r) is cls and isinstance(r, Renderer) and r.raster == raster
    with Renderer(scene, raster=None) as r:
        assert r.raster == default_raster()
    with CPURenderer(scene) as r:  # a raster's own class makes its own
        assert type(r) is CPURenderer and not hasattr(r, "gl")  # no GL context at all
    with pytest.raises(gg.ConfigError, match="Renderer: raster 'vulkan' is unknown"):
        Renderer(scene, raster="vulkan")


def test_both_rasters_put_the_box_face_at_its_analytic_depth_with_its_ids():
    """Camera 5 m from the box's centre on +x, looking at it: the face x = 1 at z = 4 m, its
    edges 40 px * 1 m / 4 m = 10 px from the centre pixel. In both rasters' frames every pixel
    centre inside that square shows the box at 4 m and every one outside it shows nothing
    (the centres on its outline are left to each raster's own edge rule)."""
    scene = box_scene()
    sensor = gg.Sensor.pinhole(33, 33, 40.0)
    pose = look_at([5.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    frames = {}
    for raster in ("cpu", "gl"):
        with Renderer(scene, raster=raster) as r:
            frames[raster] = r.render(sensor, pose, normals=True, triangles=True)
    d = np.maximum(*np.abs(np.mgrid[-16:17, -16:17]))  # pixels from the centre, either axis
    inside, outside = d < 10, d > 10
    for f in frames.values():
        assert np.allclose(f.depth[inside], 4.0, rtol=1e-6, atol=0)
        assert (f.instance[inside] == scene.instances[0].instance).all()
        assert (f.depth[outside] == 0).all() and (f.instance[outside] == 0).all()
        assert np.allclose(f.normal[inside], [0.0, 0.0, -1.0], atol=1e-6)  # towards the eye
        assert f.triangles.vertices_of(16, 16) is not None
    assert frames["cpu"].depth[16, 16] == np.float32(4.0)  # exact along the ray
