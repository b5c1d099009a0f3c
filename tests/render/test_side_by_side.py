"""Frames of depth and ids alone drawn side by side by the CPU raster (``Renderer.frames``,
one frame per thread, each with a rasteriser of its own): the same bytes as the frames drawn
one by one, with an extra render of the caller's in between, and after a caller stops
early."""

import numba
import trimesh
import numpy as np

import genie_gl as gg
from genie_gl.render import Renderer, shading
from genie_gl.render.cpu import raster
from genie_gl.render.cpu import renderer as cpu_renderer
from tests.render.test_lens_rays import FISHEYE, TUTORIAL
from tests.scenes import scene_of, sensor_640


def same(a, b):
    return (
        a.depth.tobytes() == b.depth.tobytes()
        and np.array_equal(a.instance, b.instance)
        and np.array_equal(a.semantic, b.semantic)
    )


def test_frames_drawn_side_by_side_equal_frames_drawn_one_by_one():
    scene, poses = scene_of("100k")
    sensor = sensor_640()
    threads = numba.get_num_threads()
    assert threads >= 2, "numba has one thread here: no frames are drawn side by side"
    poses = [poses[k % len(poses)] for k in range(6)]
    only = [None, None, None, [2, 3, 4], None, None]
    with Renderer(scene, raster="cpu") as r:
        alone = [r.render(sensor, p, depth_only=True, only=o) for p, o in zip(poses, only)]
        full = r.render(sensor, poses[3], normals=True)
        frames = r.frames(sensor, poses, depth_only=True, only=only)
        side = [next(frames)]
        # a render of the caller's while the next frames draw (an effect's extra view)
        extra = r.render(sensor, poses[3], normals=True)
        side += list(frames)
        assert len(r._side) == cpu_renderer.AHEAD * threads  # the twins, given back when done
        assert r.stats["instances_drawn"] > 0
        # a caller that stops after one frame: the twins come back, the renderer goes on
        frames = r.frames(sensor, poses, depth_only=True)
        first = next(frames)
        frames.close()
        assert len(r._side) == cpu_renderer.AHEAD * threads
        again = r.render(sensor, poses[0], depth_only=True)
    assert len(side) == len(alone)
    assert all(same(a, b) for a, b in zip(alone, side))
    assert same(first, alone[0]) and same(again, alone[0])
    assert same(extra, full) and extra.rgb.tobytes() == full.rgb.tobytes()
    assert extra.normal.tobytes() == full.normal.tobytes()
    assert (alone[0].instance > 0).mean() > 0.3
    assert set(np.unique(alone[3].instance)) <= {0, 2, 3, 4}  # the floor (1) left out


def test_frames_too_large_for_the_side_by_side_budget_are_drawn_one_by_one(monkeypatch):
    scene, poses = scene_of("100k")
    sensor = sensor_640()
    # room for one frame's raster buffers only: no frames side by side
    monkeypatch.setattr(cpu_renderer, "SIDE_BY_SIDE_BYTES", 640 * 480 * 16 * 2 - 1)
    with Renderer(scene, raster="cpu") as r:
        frames = list(r.frames(sensor, poses[:3], depth_only=True))
        assert r._side == []
        alone = [r.render(sensor, p, depth_only=True) for p in poses[:3]]
    assert all(same(a, b) for a, b in zip(alone, frames))


def test_a_scene_of_one_instance_and_one_of_many_use_the_same_compiled_kernels(monkeypatch):
    """The kernels are compiled (or loaded from numba's cache) once per process: the arrays a
    frame hands them have the same types and layouts whatever the scene (a strided column of
    the instance rows made a second version of the raster's and the shading's kernels, loaded
    in the first frames of every scene of more than one instance)."""
    sensor = sensor_640()
    pose = np.eye(4)
    seen: dict = {}

    def recording(module, name):
        kernel = getattr(module, name)

        def call(*args):
            seen.setdefault(name, set()).add(tuple(numba.typeof(a) for a in args))
            return kernel(*args)

        monkeypatch.setattr(module, name, call)

    for module, name in ((raster, "_raster"), (raster, "_raster_serial"), (shading, "_shade")):
        recording(module, name)

    def types(scene):
        seen.clear()
        with Renderer(scene, raster="cpu") as r:
            r.render(sensor, pose, depth_only=True)
            r.render(sensor, pose, normals=True)
            list(r.frames(sensor, [pose] * 3, depth_only=True))
        return dict(seen)

    one = gg.Scene()
    at = np.eye(4)
    at[2, 3] = 3.0
    one.add(trimesh.creation.box((1.0, 1.0, 1.0)), at, semantic=1)
    many = gg.Scene()
    for k in range(3):
        at = np.eye(4)
        at[:3, 3] = (k - 1.0, 0.0, 3.0 + k)
        many.add(trimesh.creation.box((0.5, 0.5, 0.5)), at, semantic=2 + k)
    first = types(one)
    assert sorted(first) == ["_raster", "_raster_serial", "_shade"]
    assert all(len(v) == 1 for v in first.values())
    assert types(many) == first


def test_frames_through_a_lens_drawn_side_by_side_equal_frames_drawn_one_by_one():
    """A lens's frames (each pixel's own ray, through one view or a fisheye's cube faces)
    drawn side by side, one per thread, give the bytes of the frames drawn one by one."""
    scene, poses = scene_of("100k")
    poses = [poses[k % len(poses)] for k in range(4)]
    for sensor in (TUTORIAL, FISHEYE):
        with Renderer(scene, raster="cpu") as r:
            alone = [r.render(sensor, p, depth_only=True) for p in poses]
            side = list(r.frames(sensor, poses, depth_only=True))
            assert len(r._side) == cpu_renderer.AHEAD * numba.get_num_threads()
        assert all(same(a, b) for a, b in zip(alone, side))
        assert all(f.meta["resample"] == "exact" for f in side)
        assert (alone[0].instance > 0).mean() > 0.2
