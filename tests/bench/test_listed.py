"""``genie bench``'s options are listed in genie_gl/commands/bench.py (so ``--help`` imports no
benchmark); the names they accept are the benchmarks' own."""

from genie_gl.bench import odometry, render, scenes
from genie_gl.commands import bench


def test_the_render_options_name_the_benchmarks_scenes_and_tools():
    assert bench.RENDER_SCENES == tuple(scenes.SIZES)
    assert bench.RENDER_TOOLS == tuple(render.TOOLS)


def test_the_odometry_defaults_are_the_benchmarks_own():
    assert bench.ODOMETRY == {
        "rate_hz": odometry.RATE_HZ,
        "scan_points": odometry.SCAN_POINTS,
        "max_range": odometry.MAX_RANGE_M,
        "voxel_m": odometry.VOXEL_M,
    }


def test_every_benchmark_listed_has_its_module():
    import importlib.util

    missing = [
        n for n in bench.BENCHMARKS if importlib.util.find_spec(f"genie_gl.bench.{n}") is None
    ]
    assert missing == []
