"""``genie bench render`` times the frames users get: the benchmark's frames equal
``gg.capture``'s and the renderer's own, byte for byte."""

import numpy as np
import pytest

from genie_gl.bench.render import bench_frames
from genie_gl.capture import capture
from genie_gl.render import Renderer
from tests.scenes import scene_of, sensor_640

pytestmark = pytest.mark.gl


def assert_same_frames(a, b):
    assert a.depth.tobytes() == b.depth.tobytes()
    assert np.array_equal(a.instance, b.instance) and np.array_equal(a.semantic, b.semantic)


def test_api_path_and_benchmark_path_give_the_same_frames():
    scene, poses = scene_of("100k")
    sensor = sensor_640()
    timed = bench_frames(scene, sensor, poses[:2])  # what genie bench render times
    api = capture(scene, sensor, poses[:2], seed=0, depth_only=True)  # what users call
    with Renderer(scene, raster=None) as r:  # the machine's default raster, as the two above
        direct = [r.render(sensor, p, depth_only=True) for p in poses[:2]]
    for a, b, c in zip(timed, api, direct):
        assert_same_frames(a, b)
        assert_same_frames(a, c)


def test_each_tool_loads_its_library_before_the_clock_and_the_cold_figures_add_it():
    from genie_gl.bench.render import _measure, available

    tools = ["genie-gl"] + (["Open3D"] if available("Open3D") else [])
    for tool in tools:
        row = _measure((tool, "100k"))
        assert row["library_s"] > 0.0 and row["build_s"] > 0.0
        for n in (24, 40):
            assert row[f"cameras_{n}_cold_s"] == pytest.approx(
                row["library_s"] + row[f"cameras_{n}_s"], rel=1e-12
            )
            assert row[f"cameras_{n}_s"] > row["build_s"]
