"""Each measuring script of ``benchmarks/`` run on a small case: it still reaches what it
measures, and its figures say what they should (a setting that is off costs nothing, culling
draws no more than it was given, each stage takes some time)."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import benchmarks
from benchmarks import (
    frame_cpu,
    lens_frame,
    lens_ids,
    lod_saving,
    occlusion_cost,
    random_rays,
    skip_cost,
    stage_cpu,
    stage_parts,
)

ROOT = Path(__file__).resolve().parents[2]


def test_the_runner_lists_every_benchmark_module_and_refuses_an_unknown_one():
    modules = {p.stem for p in (ROOT / "benchmarks").glob("*.py")} - {
        "__init__",
        "__main__",
        "common",
    }
    assert set(benchmarks.NAMES) == modules
    run = subprocess.run(
        [sys.executable, "-m", "benchmarks", "--list"], cwd=ROOT, capture_output=True, text=True
    )
    assert run.returncode == 0 and all(name in run.stdout for name in modules)
    bad = subprocess.run(
        [sys.executable, "-m", "benchmarks", "lod_savings"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert bad.returncode == 2 and "unknown benchmark 'lod_savings'" in bad.stderr


@pytest.mark.gl
def test_frame_cpu_counts_the_culling_inside_the_frame():
    r = frame_cpu.run("100k", frames=3)
    assert r["ms_cpu"] > 0 and 0 < r["cull_ms_cpu"] <= r["ms_cpu"] and 0 < r["cull_share"] <= 1
    assert 0 < r["drawn"] <= r["triangles"]


@pytest.mark.gl
def test_lod_saving_off_is_the_reference_and_a_setting_draws_simplified_copies():
    rows = lod_saving.run("100k", "gl", rounds=1, poses=2)
    assert [r["below_px"] for r in rows] == list(lod_saving.SETTINGS)
    off = rows[0]
    assert off["x_off"] == 1.0 and off["simplified"] == 0
    assert off["dz_p99_mm"] == 0 and off["id_differs_pct"] == 0
    assert all(r["ms"] > 0 for r in rows)
    # more pixels across before an instance counts as small: at least as many simplified
    assert np.all(np.diff([r["simplified"] for r in rows[1:]]) >= 0)


@pytest.mark.gl
def test_occlusion_cost_draws_no_more_with_occlusion():
    r = occlusion_cost.run("100k", frames=2, quad_frames=1)
    assert r["off_ms"] > 0 and r["on_ms"] > 0 and r["quad_ms"] > 0
    assert 0 < r["drawn_on"] <= r["drawn_off"]
    assert r["clusters"] > 0 and 0 <= r["clusters_dropped"] <= r["clusters"]


@pytest.mark.gl
def test_skip_cost_times_both_captures():
    r = skip_cost.run(fresh=True, calls=1)
    assert r["with_ms_cpu"] > 0 and r["without_ms_cpu"] > 0
    assert r["ratio"] == pytest.approx(r["with_ms_cpu"] / r["without_ms_cpu"])


def test_random_rays_time_both_casters_and_agree():
    r = random_rays.run("100k", rays=2_000, rounds=1)
    assert r["genie_gl_s"] > 0 and r["open3d_s"] > 0 and r["rays"] == 2_000
    # Open3D keeps float32 world triangles: short rays differ most in relative distance
    assert r["ids_agree"] >= 0.99 and r["range_rel_p99"] <= 1e-4


def test_lens_frame_times_both_sensors_through_capture_and_as_frames():
    r = lens_frame.run("100k", frames=2, rounds=1)
    assert r["pinhole_ms"] > 0 and r["lens_ms"] > 0
    assert r["ratio"] == pytest.approx(r["lens_ms"] / r["pinhole_ms"])
    assert r["pinhole_frames_ms"] > 0 and r["lens_frames_ms"] > 0
    assert r["frames_ratio"] == pytest.approx(r["lens_frames_ms"] / r["pinhole_frames_ms"])


@pytest.mark.gl
@pytest.mark.parametrize("raster", ["gl", "cpu"])
def test_lens_ids_agree_with_open3d_and_time_every_mode(raster):
    name = "plumb-bob (k1 -0.42)"
    r = lens_ids.run("both", "100k", poses=1, lenses=[name], rounds=1, raster=raster)[name]
    assert set(r["agreement"]) == set(r["ms"]) == set(lens_ids.MODES)
    # the exact mode casts each pixel's own ray: it agrees with Open3D at least as well as nearest
    assert (
        r["agreement"]["exact"][0] > 0.999
        and r["agreement"]["exact"][1] <= r["agreement"]["nearest"][1]
    )
    assert all(v > 0 for v in r["ms"].values())


@pytest.mark.gl
def test_stage_cpu_times_every_stage_of_a_steady_scene():
    r = stage_cpu.run(steady=1, cameras=2)
    assert {"capture", "total"} <= set(r) and all(v >= 0 for v in r.values())
    assert r["total"] >= max(v for k, v in r.items() if k != "total") > 0


@pytest.mark.gl
def test_stage_parts_times_its_three_parts():
    r = stage_parts.run(scenes=1, cameras=2, repeats=1)
    assert set(r) == {"build_scene", "plan", "cloud"} and all(v > 0 for v in r.values())
