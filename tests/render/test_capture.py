"""capture() over many poses and processes; backends and their errors."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.render import create_context
from genie_gl.sensors.pose import look_at

from .conftest import cast_boxes, interior

pytestmark = pytest.mark.gl


BOXES = [((10, 10, 0.1), [0, 0, -0.05])] + [
    ((0.8, 0.8, 1.5), [i - 2.5, (i % 2) - 0.5, 0.75]) for i in range(6)
]


def small_scene():
    scene = gg.Scene()
    for i, (size, centre) in enumerate(BOXES):
        scene.add(trimesh.creation.box(size), centre, semantic=i)
    return scene


def truth(scene, sensor, pose):
    """Depth and ids of small_scene by exact ray casting (no rasteriser)."""
    boxes = []
    for (size, centre), inst in zip(BOXES, scene.instances):
        T = np.eye(4)
        T[:3, 3] = centre
        boxes.append((T, np.array(size) / 2, inst.instance))
    return cast_boxes(sensor, pose, boxes)


def assert_matches_truth(frame, scene, pose, min_hit=0.3):
    depth, ids = truth(scene, frame.sensor, pose)
    core = interior(ids, 1)
    assert core.mean() > 0.6
    np.testing.assert_array_equal(frame.instance[core], ids[core])
    hit = core & (ids > 0)
    assert hit.mean() > min_hit
    np.testing.assert_allclose(frame.depth[hit], depth[hit], rtol=5e-5)  # creases of a box: one id
    assert not frame.depth[core & (ids == 0)].any()


def test_capture_is_independent_of_worker_count():
    scene = small_scene()
    sensor = gg.Sensor.pinhole(96, 72, 80.0)
    poses = [look_at([6 * np.cos(a), 6 * np.sin(a), 3], [0, 0, 0.5]) for a in np.linspace(0, 6, 5)]
    one = gg.capture(scene, sensor, poses, seed=3, workers=1)
    two = gg.capture(scene, sensor, poses, seed=3, workers=2)
    assert len(one) == len(two) == 5
    for a, b in zip(one, two):
        assert a.depth.tobytes() == b.depth.tobytes()
        assert a.instance.tobytes() == b.instance.tobytes()
        assert a.rgb.tobytes() == b.rgb.tobytes()
        np.testing.assert_array_equal(a.pose, b.pose)
    # an ideal sensor: capture equals render, bit for bit
    single = gg.render(scene, sensor, poses[2])
    assert single.depth.tobytes() == one[2].depth.tobytes()
    assert (one[0].instance > 0).mean() > 0.3
    for f, pose in zip(one, poses):  # and both equal the truth, not only each other
        assert_matches_truth(f, scene, pose)


def test_each_frame_is_handed_over_in_order_as_the_capture_makes_it(monkeypatch):
    """``on_frame`` gets every frame, in pose order, the very objects the capture returns;
    in this process each one as soon as the next pose is drawn (before the poses after it),
    with workers once they are all back. In this process, frame k+1 is planned (culled, its
    draws written) before frame k is read back: while frame k rasterises (the GL raster)."""
    from genie_gl.render import GLRenderer

    scene = small_scene()
    sensor = gg.Sensor.pinhole(64, 48, 50.0)
    poses = [look_at([6 * np.cos(a), 6 * np.sin(a), 3], [0, 0, 0.5]) for a in np.linspace(0, 6, 4)]
    events = []
    for name in ("_plan", "_issue", "_fetch"):

        def step(self, *a, _real=getattr(GLRenderer, name), _name=name, **k):
            events.append(_name[1:])
            return _real(self, *a, **k)

        monkeypatch.setattr(GLRenderer, name, step)
    for workers in (1, 2):
        handed, drawn_then = [], []
        events.clear()
        frames = gg.capture(
            scene,
            sensor,
            poses,
            seed=3,
            workers=workers,
            raster="gl",  # GL's pipelining
            on_frame=lambda f: (
                handed.append(f),
                drawn_then.append(events.count("issue")),
                events.append("hand"),
            ),
        )
        assert len(frames) == 4 and all(a is b for a, b in zip(handed, frames))
        # in this process: frame k is handed over once frame k + 1 is drawn, not later
        assert drawn_then == ([2, 3, 4, 4] if workers == 1 else [0, 0, 0, 0])
        if workers == 1:
            assert events == [
                "plan",
                "issue",
                "plan",
                "fetch",
                "issue",
                "hand",
                "plan",
                "fetch",
                "issue",
                "hand",
                "plan",
                "fetch",
                "issue",
                "hand",
                "fetch",
                "hand",
            ]


def test_unknown_backend_is_a_clear_error():
    with pytest.raises(gg.ConfigError, match="unknown; expected one of egl, osmesa"):
        create_context("vulkan")


def test_osmesa_fallback_renders_the_same_depth(tmp_path):
    """OSMesa must be chosen before PyOpenGL is imported: run it in a fresh process. Its whole
    frame of a scene of boxes equals the exact ray caster's, and EGL's frame of it."""
    pose = look_at([5.0, -4.0, 3.0], [0, 0, 0.5])
    np.save(tmp_path / "pose.npy", pose)
    code = (
        "import sys, numpy as np, genie_gl as gg\n"
        "from genie_gl.render import Renderer\n"
        "from tests.render.test_capture import small_scene\n"
        "out = sys.argv[1]\n"
        "with Renderer(small_scene(), backend='osmesa') as r:\n"
        "    f = r.render(gg.Sensor.pinhole(96, 72, 80.0), np.load(out + '/pose.npy'))\n"
        "    np.savez(out + '/f.npz', depth=f.depth, instance=f.instance)\n"
        "    print(r.gl.backend)\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "PYOPENGL_PLATFORM"}
    root = Path(__file__).parents[2]
    env["PYTHONPATH"] = os.pathsep.join([str(root)] + [p for p in [env.get("PYTHONPATH")] if p])
    out = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path)],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        cwd=root,
    )
    assert out.returncode == 0, out.stderr  # libosmesa6 is installed by `make setup`: no skip
    assert out.stdout.split() == ["osmesa"]
    f = np.load(tmp_path / "f.npz")
    scene, sensor = small_scene(), gg.Sensor.pinhole(96, 72, 80.0)
    osmesa = gg.Frame(
        f["depth"], f["instance"], np.zeros(f["depth"].shape, np.uint16), None, sensor, pose
    )
    assert_matches_truth(osmesa, scene, pose)
    egl = gg.render(scene, sensor, pose, backend="egl")
    assert (egl.instance != osmesa.instance).mean() < 0.005  # silhouette pixels at most
    same = egl.instance == osmesa.instance
    np.testing.assert_allclose(osmesa.depth[same], egl.depth[same], rtol=1e-5)


def test_a_process_forked_after_egl_renders_through_osmesa(tmp_path):
    """EGL's driver threads stay in the process that started it: a child forked after a render
    that read back through EGL would wait for them forever. In the child, create_context()
    goes to OSMesa, "egl" is refused with a clear error, shared_context() is the child's own,
    and its frame equals the exact ray caster's, as the parent's does."""
    import signal

    from genie_gl.render import Renderer, shared_context
    from genie_gl.render.gl.platforms import egl

    scene, sensor = small_scene(), gg.Sensor.pinhole(96, 72, 80.0)
    pose = look_at([5.0, -4.0, 3.0], [0, 0, 0.5])
    parent_shared = shared_context("egl")
    with Renderer(scene, context=parent_shared) as r:
        parent = r.render(sensor, pose)
    pid = os.fork()
    if pid == 0:  # the child: no assertion here (pytest is the parent's), only an exit code
        signal.alarm(60)
        code = 9
        try:
            try:
                create_context("egl")
                code = 3
            except gg.BackendUnavailableError as exc:
                code = 4 if "forked" not in str(exc) else 5
            if code == 5:
                gl = create_context()
                own = (
                    shared_context("osmesa") is not parent_shared
                    and shared_context() is not parent_shared
                )
                with Renderer(scene, context=gl) as r:
                    f = r.render(sensor, pose)
                np.savez(tmp_path / "child.npz", depth=f.depth, instance=f.instance)
                code = 0 if gl.backend == "osmesa" and own else 6
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0, os.waitstatus_to_exitcode(status)
    assert (
        egl.started_in == os.getpid() and shared_context("egl") is parent_shared
    )  # the parent's untouched
    c = np.load(tmp_path / "child.npz")
    child = gg.Frame(
        c["depth"], c["instance"], np.zeros(c["depth"].shape, np.uint16), None, sensor, pose
    )
    assert_matches_truth(child, scene, pose)
    assert_matches_truth(parent, scene, pose)


def test_frame_buffers_are_recycled_only_when_no_view_remains():
    import gc

    from genie_gl.render.memory import _POOL, frame_buffers

    # what earlier tests left: their garbage collected now (a block it frees would otherwise
    # come back during this test, ahead of ours) and the free blocks dropped (a full pool
    # would keep none)
    gc.collect()
    _POOL.free.clear()
    _POOL.bytes = 0
    a = frame_buffers(48, 64, True, True)
    keep = a["semantic"]  # one view keeps the whole block lent out
    addr = a["depth"].ctypes.data
    del a
    gc.collect()
    b = frame_buffers(48, 64, True, True)
    assert b["depth"].ctypes.data != addr  # still in use: not lent again
    views = [v for v in b.values()]
    for i, x in enumerate(views):  # views never overlap
        for y in views[i + 1 :]:
            assert not np.shares_memory(x, y)
    del keep
    gc.collect()
    c = frame_buffers(48, 64, True, True)
    assert c["depth"].ctypes.data == addr  # the first block came back and is reused
    assert (
        c["rgba"].shape == (48, 64, 4)
        and c["normal"].dtype == np.float32
        and c["depth"].flags.writeable
    )
    assert _POOL.bytes <= _POOL.max_bytes


def test_an_on_frame_that_is_no_function_is_one_clear_error_before_anything_renders():
    scene = small_scene()
    sensor = gg.Sensor.pinhole(64, 48, 50.0)
    with pytest.raises(
        gg.ConfigError,
        match=r"capture: on_frame: expected a function taking a Frame \(or None\), "
        r"got int 3",
    ):
        gg.capture(scene, sensor, [look_at([6, 0, 3], [0, 0, 0.5])], seed=0, on_frame=3)
