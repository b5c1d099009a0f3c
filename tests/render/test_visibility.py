"""Which instances a frame draws (``render/visibility.py`` and ``Renderer(...).render(only=)``):
the compiled composition has the bits of numpy's, and drawing only some instances gives the
frame of a scene holding only them, through the GL raster and the exact one."""

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.render import Renderer
from genie_gl.render.visibility import compose
from tests.scenes import scene_of, sensor_640


def test_compose_has_the_bits_of_numpy_einsum():
    rng = np.random.default_rng(5)
    for _ in range(50):
        n = int(rng.integers(1, 2000))
        cw = rng.normal(size=(3, 4)) * 10 ** rng.uniform(-3, 6)
        wfm = rng.normal(size=(n, 4, 4)) * 10 ** rng.uniform(-3, 6)
        out = np.empty((n, 3, 4))
        compose(cw, wfm, out)
        assert out.tobytes() == np.einsum("ij,njk->nik", cw, wfm).tobytes()


@pytest.mark.parametrize("raster", ["gl", "cpu"])
def test_drawing_only_some_instances_is_the_frame_of_a_scene_of_them(glctx, raster):
    scene, poses = scene_of("100k")
    rng = np.random.default_rng(2)
    ids = [inst.instance for inst in scene.instances]
    keep = set(rng.choice(ids, size=len(ids) // 3, replace=False).tolist())
    sub = gg.Scene()
    for inst in scene.instances:
        if inst.instance in keep:
            sub.add(
                scene.meshes[inst.mesh],
                inst.world_from_model,
                semantic=inst.semantic,
                instance=inst.instance,
                color=inst.color,
            )
    sensor = sensor_640()
    kw = {"context": glctx} if raster == "gl" else {}
    with Renderer(scene, raster=raster, **kw) as r, Renderer(sub, raster=raster, **kw) as s:
        for p in poses[:2]:
            a = r.render(sensor, p, depth_only=True, only=np.array(sorted(keep), np.int64))
            b = s.render(sensor, p, depth_only=True)
            c = r.render(
                sensor, p, depth_only=True, only=sorted(keep) + [2**31]
            )  # a list, an unknown id
            assert set(np.unique(a.instance).tolist()) - {0} <= keep
            assert (a.instance > 0).mean() > 0.05
            for f in (a, c):
                assert np.array_equal(f.instance, b.instance) and np.array_equal(
                    f.semantic, b.semantic
                )
                assert f.depth.tobytes() == b.depth.tobytes()


@pytest.mark.parametrize("bad", [["a"], [1.5, 2.0], [[1, 2]], 7, [True]])
def test_only_that_is_not_a_collection_of_ids_is_refused_by_name(bad):
    scene, poses = scene_of("100k")
    with Renderer(scene, raster="cpu") as r:
        with pytest.raises(
            gg.errors.ConfigError, match="only: expected a collection of instance ids"
        ):
            r.render(sensor_640(), poses[0], depth_only=True, only=bad)
        assert r.render(sensor_640(), poses[0], depth_only=True, only=[]).instance.max() == 0
