"""Faults of the renderers: what a raster cannot draw right or cannot hold is refused in one
line, never drawn wrong or ended in numpy's MemoryError."""

import subprocess
import sys
import textwrap

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.errors import LimitError
from genie_gl.render import Renderer

from .common import ROOT, _env, fault

SENSOR = gg.Sensor.pinhole(640, 480, 500.0)


def looking_down_the_ground():
    """A camera 1.5 m above z = 0 looking level along +y, tilted 0.3 rad down."""
    tilt = np.array([[1, 0, 0], [0, np.cos(0.3), -np.sin(0.3)], [0, np.sin(0.3), np.cos(0.3)]])
    pose = np.eye(4)
    pose[:3, :3] = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]]) @ tilt
    pose[2, 3] = 1.5
    return pose


def ground(half_m):
    scene = gg.Scene()
    scene.add(
        gg.Mesh(
            np.array([[-half_m, -half_m, 0], [half_m, -half_m, 0], [0, half_m, 0]], float),
            np.array([[0, 1, 2]]),
        ),
        np.eye(4),
        semantic=1,
    )
    return scene


@pytest.mark.gl
@fault("huge input", "wrong")
@pytest.mark.parametrize("half_m", [1e6, 1e8])
def test_a_ground_triangle_too_large_for_float32_is_refused_by_gl_and_drawn_exactly_by_cpu(
    glctx, half_m
):
    """A triangle reaching 1e6 m or 1e8 m from the camera: the GL raster (float32 vertices)
    refuses it in one line naming the instance and the way out; the CPU raster draws it,
    every pixel below the horizon at its analytic depth (ray meets z = 0)."""
    scene, pose = ground(half_m), looking_down_the_ground()
    with Renderer(scene, context=glctx) as r, pytest.raises(LimitError) as exc:
        r.render(SENSOR, pose, depth_only=True)
    msg = str(exc.value)
    assert "\n" not in msg and "instance 1 reaches" in msg and "raster='cpu'" in msg
    with Renderer(scene, raster="cpu") as r:
        f = r.render(SENSOR, pose, depth_only=True)
    d = SENSOR.directions().reshape(-1, 3) @ pose[:3, :3].T  # unit world rays
    cam_z = SENSOR.directions().reshape(-1, 3)[:, 2]
    down = d[:, 2] < 0
    t = np.where(down, 1.5 / np.where(down, -d[:, 2], 1), 0)
    z = (t * cam_z).reshape(f.depth.shape)
    seen = down.reshape(f.depth.shape) & (z <= SENSOR.far_m)
    assert seen.sum() > 100_000
    assert ((f.depth > 0) == seen).all()
    np.testing.assert_allclose(f.depth[seen], z[seen], rtol=1e-6)


@pytest.mark.gl
@fault("huge input", "wrong")
def test_a_ground_of_a_few_kilometres_is_still_drawn_by_gl():
    """The refusal is for coordinates float32 cannot hold, not for large halls: +-1e4 m is
    drawn by GL with the CPU raster's pixels."""
    scene, pose = ground(1e4), looking_down_the_ground()
    with Renderer(scene, raster="gl") as g, Renderer(scene, raster="cpu") as c:
        a, b = g.render(SENSOR, pose, depth_only=True), c.render(SENSOR, pose, depth_only=True)
    assert ((a.depth > 0) == (b.depth > 0)).all() and (a.depth > 0).sum() > 100_000


@fault("huge input", "traceback")
def test_the_cpu_raster_refuses_a_frame_side_past_the_limit_in_one_line():
    scene = ground(10.0)
    with Renderer(scene, raster="cpu") as r, pytest.raises(LimitError) as exc:
        r.render(gg.Sensor.pinhole(16385, 16, 1000.0), looking_down_the_ground(), depth_only=True)
    msg = str(exc.value)
    assert "\n" not in msg and "16385x16 px" in msg and "at most 16384 px" in msg


@fault("huge input", "traceback")
def test_the_cpu_raster_refuses_a_frame_it_has_no_memory_for_in_one_line():
    """A 12000 x 12000 frame (8 GB of buffers) in a process left 1 GB of address space:
    refused before any buffer is made (it needed numpy's MemoryError to stop before)."""
    code = textwrap.dedent("""
        import resource, numpy as np, genie_gl as gg
        from genie_gl.render import Renderer
        from genie_gl.errors import LimitError
        s = gg.Scene()
        v = np.array([[-9, -9, 0], [9, -9, 0], [0, 9, 0]], float)
        s.add(gg.Mesh(v, np.array([[0, 1, 2]])), np.eye(4))
        pose = np.eye(4); pose[2, 3] = 5.0; pose[:3, :3] = np.diag([1.0, -1.0, -1.0])
        with Renderer(s, raster="cpu") as r:
            # the kernels loaded
            assert (r.render(gg.Sensor.pinhole(64, 48, 50.0), pose).depth > 0).any()
            used = next(int(l.split()[1]) * 1024 for l in open("/proc/self/status")
                        if l.startswith("VmSize:"))
            resource.setrlimit(resource.RLIMIT_AS, (used + (1 << 30), used + (1 << 30)))
            try:
                r.render(gg.Sensor.pinhole(12000, 12000, 6000.0), pose, depth_only=True)
            except LimitError as exc:
                print("REFUSED", exc)
    """)
    run = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=300,
        env=_env(),
        cwd=ROOT,
    )
    assert "MemoryError" not in run.stderr and "Traceback" not in run.stderr, run.stderr[-2000:]
    line = run.stdout.strip()
    assert (
        line.startswith("REFUSED estimated memory")
        and "12000x12000 px" in line
        and "\n" not in line
    ), line
