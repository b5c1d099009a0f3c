"""The packed read-back (depth bits and instance id in one RG32UI target, semantic ids looked
up per instance, the sensor's range applied while unpacking) gives the frames of the three
separate targets bit for bit, on a generated scene, through render() and frames(), with and
without colour and normals, with pixel buffer objects, and in every depth precision."""

import dataclasses

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.errors import ConfigError
from genie_gl.render import Renderer
from genie_gl.render.gl.readback import semantic_table, unpack
from genie_gl.resources import resolve

from .test_fast_path import assert_same_frames

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def generated():
    layout = gg.generate_layout(resolve("assembly_line", "layouts", (".json",)), seed=3)
    scene = gg.build_scene(layout, seed=3)
    sensor = gg.Sensor.pinhole(160, 120, 130.0)
    return scene, sensor, gg.place_sensors(layout, sensor, n=4, seed=3)


def same(a, b):
    assert_same_frames(a, b)
    assert (a.normal is None) == (b.normal is None)
    if a.normal is not None:
        assert a.normal.tobytes() == b.normal.tobytes()


@pytest.mark.parametrize("kw", [{"depth_only": True}, {}, {"normals": True}])
def test_packed_equals_separate_targets_on_a_generated_scene(glctx, generated, kw):
    scene, sensor, poses = generated
    # a range that cuts: near surfaces and far ones give no return (emptied while unpacking)
    ranged = dataclasses.replace(sensor, near_m=3.5, far_m=6.0)
    with (
        Renderer(scene, context=glctx, targets="separate") as old,
        Renderer(scene, context=glctx) as new,
        Renderer(scene, context=glctx, readback="pbo") as pbo,
    ):
        assert new._packed and not old._packed
        for s in (sensor, ranged):
            ref = [old.render(s, p, **kw) for p in poses]
            for got in (
                [new.render(s, p, **kw) for p in poses],
                list(new.frames(s, poses, **kw)),
                list(pbo.frames(s, poses, **kw)),
            ):
                for a, b in zip(ref, got):
                    same(a, b)
            if s is ranged:
                full = [old.render(sensor, p, **kw) for p in poses]
                cut = sum(
                    int(((f.depth > 0) & ((f.depth < 3.5) | (f.depth > 6.0))).sum()) for f in full
                )
                assert cut > 1000  # the range did empty pixels
                for f, g in zip(full, ref):
                    keep = (f.depth >= 3.5) & (f.depth <= 6.0)
                    assert np.array_equal(g.instance, np.where(keep, f.instance, 0))
        assert all((f.semantic > 0).any() and (f.instance > 0).mean() > 0.3 for f in ref)


@pytest.mark.parametrize("precision", ["depth24", "reversed_z"])
def test_packed_equals_separate_targets_in_other_depth_precisions(glctx, generated, precision):
    scene, sensor, poses = generated
    with (
        Renderer(scene, context=glctx, targets="separate", depth_precision=precision) as old,
        Renderer(scene, context=glctx, depth_precision=precision) as new,
    ):
        for a, b in zip([old.render(sensor, p) for p in poses], new.frames(sensor, poses)):
            same(a, b)


@pytest.mark.parametrize("big", [2**32 - 1, 40])  # a sorted search, a direct table
def test_unpack_looks_semantic_ids_up_by_instance(big):
    ids, sem = np.array([7, 3, big], np.uint32), np.array([5, 9, 65535], np.uint16)
    table = semantic_table(ids, sem)
    assert len(table) == (2 if big > 2**20 else 1)
    z = np.array([[1.5, 0.0, 4.0, 0.5, 12.0, 3.0, 10.0, 1.0]], np.float32)
    inst = np.array([[3, 0, 7, 7, 3, big, 7, 3]], np.uint32)
    packed = np.stack([z.view(np.uint32), inst], axis=-1)
    depth, instance, semantic = np.empty_like(z), np.empty_like(inst), np.empty(z.shape, np.uint16)
    assert (
        unpack(packed, table, depth, instance, semantic, near_m=1.0, far_m=10.0) == 2
    )  # 0.5 m, 12 m
    assert depth.tolist() == [
        [1.5, 0.0, 4.0, 0.0, 0.0, 3.0, 10.0, 1.0]
    ]  # 10 m and 1 m are in range
    assert instance.tolist() == [[3, 0, 7, 0, 0, big, 7, 3]]
    assert semantic.tolist() == [[9, 0, 5, 0, 0, 65535, 5, 9]]
    depth[:] = -1
    assert unpack(packed, table, None, instance, semantic, near_m=1.0, far_m=10.0) == 0  # ids alone
    assert instance.tolist() == inst.tolist() and (depth == -1).all()
    assert semantic_table(np.array([4, 4], np.uint32), np.array([1, 2], np.uint16)) is None


def _unpack_one_pass(packed, lut, with_depth, near_m, far_m):
    """The unpacking as the kernel's docstring states it, pixel by pixel in plain numpy."""
    z, i = packed[..., 0].view(np.float32), packed[..., 1]
    half = np.float32(0.5 * near_m)
    bad = (
        ((z > np.float32(far_m)) | (np.abs(z - half) < half))
        if with_depth
        else np.zeros(z.shape, bool)
    )
    return (
        np.where(bad, np.float32(0), z),
        np.where(bad, np.uint32(0), i),
        np.where(bad, np.uint16(0), lut[i]).astype(np.uint16),
        int(bad.sum()),
    )


@pytest.mark.parametrize("with_zero_id", [False, True])  # a scene's table; one holding an id 0
@pytest.mark.parametrize("with_depth", [True, False])
def test_unpack_equals_the_one_pass_reading_on_a_full_frame(with_zero_id, with_depth):
    rng = np.random.default_rng(11)
    ids = np.arange(0 if with_zero_id else 1, 900, dtype=np.uint32)
    table = semantic_table(ids, rng.integers(1, 60, len(ids)).astype(np.uint16))
    z = rng.uniform(0.0, 20.0, (480, 640)).astype(np.float32)
    z[:40] = 0.0
    z[40:60] = 0.01  # nearer than the range
    z[60:70] = -0.0
    inst = rng.integers(0, 900, z.shape).astype(np.uint32)
    inst[:20] = 0
    packed = np.stack([z.view(np.uint32), inst], axis=-1)
    depth, instance, semantic = (
        np.full_like(z, -1),
        np.empty_like(inst),
        np.empty(z.shape, np.uint16),
    )
    emptied = unpack(
        packed, table, depth if with_depth else None, instance, semantic, near_m=0.1, far_m=15.0
    )
    want_depth, want_instance, want_semantic, want_emptied = _unpack_one_pass(
        packed, table[0], with_depth, 0.1, 15.0
    )
    assert emptied == want_emptied and (want_emptied > 0) == with_depth
    assert (
        instance.tobytes() == want_instance.tobytes()
        and semantic.tobytes() == want_semantic.tobytes()
    )
    if with_depth:
        assert depth.tobytes() == want_depth.tobytes()


def test_unknown_targets_or_readback_is_a_config_error():
    for kw in ({"targets": "rg"}, {"readback": "async"}):
        with pytest.raises(ConfigError, match=next(iter(kw))):
            Renderer(gg.Scene(), **kw)


def test_prefault_puts_mapped_blocks_in_the_pool_and_never_more_than_it_keeps(monkeypatch):
    from genie_gl.render import memory

    pool = memory._Pool(
        max_bytes=10 * 64 * 48 * 10
    )  # room for 10 frames of 64 x 48 (10 bytes a pixel)
    monkeypatch.setattr(memory, "_POOL", pool)
    assert memory.prefault(48, 64, False, False, 4) == 4
    size = sum(memory._parts(48, 64, False, False)[1])
    assert size == 64 * 48 * 10 and len(pool.free[size]) == 4
    frame = memory.frame_buffers(48, 64, False, False)
    assert len(pool.free[size]) == 3 and (frame["depth"] == 0).all()  # lent from the pool, written
    assert memory.prefault(48, 64, False, False, 40) == 10  # capped by the pool's size


def test_a_shared_context_serves_scene_after_scene_with_the_same_frames(generated):
    from genie_gl.capture import capture
    from genie_gl.render import release_shared_contexts, shared_context

    scene, sensor, poses = generated
    gl = shared_context()
    assert shared_context() is gl
    try:
        alone = capture(scene, sensor, poses, seed=1, depth_only=True)
        for _ in range(2):  # the context (and its shaders) outlive each capture's renderer
            shared = capture(scene, sensor, poses, seed=1, depth_only=True, context=gl)
            for a, b in zip(alone, shared):
                same(a, b)
        with gl.ctx:
            assert gl.ctx.error == "GL_NO_ERROR"
    finally:
        release_shared_contexts()
    assert shared_context() is not gl
    release_shared_contexts()
