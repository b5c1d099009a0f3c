"""Huge inputs: refused up front by the limits (genie_gl/limits.py) with the estimate and the
option that raises them, in seconds and within a few GB, never by running out of memory or
time. Each runs in a child with 3 GB of address space and a deadline."""

import json

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.errors import LimitError
from genie_gl.layout.estimate import layout_estimate
from genie_gl.resources import data_dir

from .common import cli, cli_proc, fault, refused, write_calibration

HUGE = fault("huge input", "hang")
MEMORY_GB = 3.0


def big(levels, n: int = 1) -> dict:
    s = json.loads((data_dir("layouts") / "assembly_line.json").read_text())
    s["levels"] = levels * n
    s["root"]["width"], s["root"]["height"] = 1000, 1000
    s["region_types"] = {"hall": {}, "cell": {}, "empty": {}, "room": {"final": True}}
    s["root"]["type"] = "hall"
    return s


def grid(cell, types=("hall", "cell")):
    return {
        t: {
            "generator": "grid",
            "args": {"cell": cell},
            "children": {"cell": "cell", "empty": "empty"},
        }
        for t in types
    }


STRATEGIES = {
    "six levels of 1 m grids": big([grid([1.0, 1.0])], 6),
    "1 cm grid cells": big([grid([0.01, 0.01], ("hall",))]),
    "random_rooms count 1e5": big(
        [
            {
                "hall": {
                    "generator": "random_rooms",
                    "args": {"count": [100000, 100000]},
                    "children": {"room": "room"},
                }
            }
        ]
    ),
    "drunkard_walk 1e9 steps": big(
        [
            {
                "hall": {
                    "generator": "drunkard_walk",
                    "args": {"steps": 10**9},
                    "children": {"room": "room"},
                }
            }
        ]
    ),
}


@HUGE
@pytest.mark.parametrize("name", list(STRATEGIES))
@pytest.mark.parametrize("command", ["layout", "dataset"])
def test_a_strategy_too_large_is_refused_before_any_work(name, command, tmp_path):
    p = tmp_path / "s.json"
    p.write_text(json.dumps(STRATEGIES[name]))
    if (
        command == "layout"
    ):  # in a child with 3 GB: were the limit gone, it would run out there, not here
        run = cli_proc(
            command,
            p,
            "--resolution",
            "1",
            "--out",
            tmp_path / "o",
            timeout=180,
            memory_gb=MEMORY_GB,
        )
    else:  # the same estimate, here (the child's start costs seconds)
        run = cli(command, p, "--out", tmp_path / "o", timeout=60)
    refused(run, "s.json: a layout of this strategy can make up to", "--max-nodes")
    assert not (tmp_path / "o").exists()


@HUGE
def test_the_api_refuses_the_same_strategy(tmp_path):
    with pytest.raises(
        gg.LimitError if hasattr(gg, "LimitError") else gg.ConfigError, match="max_regions="
    ):
        gg.generate_layout(STRATEGIES["drunkard_walk 1e9 steps"], seed=0)


@fault("huge input", "wrong")
@pytest.mark.parametrize("seed", range(6))
def test_the_layout_estimate_bounds_what_random_strategies_make(seed):
    """The estimate is an upper bound of the regions made, for any arguments: random grids,
    rooms, walks and lines over random halls, at several seeds each."""
    rng = np.random.default_rng(seed)
    W, H = rng.uniform(5, 60, 2)

    def rule():
        kind = rng.choice(["grid", "random_rooms", "drunkard_walk", "assembly_line"])
        if kind == "grid":
            args = {
                "cell": rng.uniform(0.5, 6, 2).round(2).tolist(),
                "spacing": round(float(rng.uniform(0, 1)), 2),
            }
            return {
                "generator": "grid",
                "args": args,
                "children": {"cell": "cell", "empty": "empty"},
            }
        if kind == "random_rooms":
            lo = int(rng.integers(1, 6))
            args = {
                "count": [lo, lo + int(rng.integers(0, 6))],
                "width": [1.0, 4.0],
                "height": [1.0, 4.0],
            }
            return {"generator": "random_rooms", "args": args, "children": {"room": "cell"}}
        if kind == "drunkard_walk":
            args = {
                "steps": int(rng.integers(1, 400)),
                "block": round(float(rng.uniform(0.5, 3)), 2),
            }
            return {"generator": "drunkard_walk", "args": args, "children": {"room": "cell"}}
        return {
            "generator": "assembly_line",
            "args": {"paths": [0, int(rng.integers(0, 4))], "line_width": 1.0, "path_width": 0.8},
            "children": {"line": "cell", "path": "cell", "material": "cell", "rest": "empty"},
        }

    s = {
        "name": "random",
        "root": {"width": float(W), "height": float(H), "type": "hall"},
        "region_types": {"hall": {}, "cell": {}, "empty": {}},
        "levels": [{"hall": rule()}, {"cell": rule()}, "merge", {"cell": rule()}],
    }
    from genie_gl.layout import parse_strategy

    strategy = parse_strategy(s, "random.json")
    nodes, work = layout_estimate(strategy)
    made = max(len(gg.generate_layout(strategy, seed=k, max_regions=10**9)) for k in range(4))
    assert made <= nodes <= work, (made, nodes, work)


@pytest.fixture(scope="module")
def scene_usd(tmp_path_factory):
    import trimesh

    s = gg.Scene()
    s.add(trimesh.creation.box((4, 4, 1)), [0, 0, 0.5], semantic=2)
    s.add(trimesh.creation.box((20, 20, 0.02)), np.eye(4), semantic=0)
    return gg.write_usd(s, tmp_path_factory.mktemp("huge") / "s.usda")


@HUGE
@pytest.mark.parametrize("command", ["capture", "dataset"])
def test_ten_thousand_cameras_are_refused_by_their_memory(command, scene_usd, tmp_path):
    first = scene_usd if command == "capture" else "assembly_line"
    run = (cli_proc if command == "capture" else cli)(
        command,
        first,
        "--cameras",
        "10000",
        "--sensor",
        "realsense_d435",
        "--out",
        tmp_path / "o",
        timeout=60,
    )
    refused(run, "estimated memory", "10000 cameras x 848x480 px")
    assert not (tmp_path / "o").exists()


@HUGE
@pytest.mark.parametrize("side", [16000, 20000])
def test_a_huge_sensor_is_refused_before_rendering(side, scene_usd, tmp_path):
    """20 000 px exceeds every side the GL context allows; 16 000 px passes that check but not
    the memory this run may use (3 GB): refused by its estimate, or by the renderer when the
    driver cannot allocate its targets, never a crash."""
    cal = write_calibration(tmp_path / "huge.yml", side, side)
    run = cli_proc(
        "capture",
        scene_usd,
        "--cameras",
        "1",
        "--sensor",
        cal,
        "--out",
        tmp_path / "o",
        "--no-progress",
        timeout=120,
        memory_gb=MEMORY_GB,
    )
    refused(run, f"{side}x{side} px")


@pytest.mark.gl
@HUGE
def test_the_renderer_refuses_targets_its_driver_cannot_allocate(tmp_path):
    """A side beyond the context's own limit (GL_MAX_TEXTURE_SIZE and the like) is refused by
    the renderer itself, whatever the caller checked."""
    import trimesh

    s = gg.Scene()
    s.add(trimesh.creation.box((1, 1, 1)), [0, 0, -3], semantic=1)
    with gg.Renderer(s) as r:
        side = r.gl.max_side + 1
        with pytest.raises(
            gg.ConfigError, match=f"{side}x8 px frames; each side must be at most {r.gl.max_side}"
        ):
            r.render(gg.Sensor.pinhole(side, 8, 100.0), np.eye(4))


@HUGE
def test_a_point_instancer_of_two_million_is_refused_before_reading(tmp_path, scene_usd):
    from pxr import Usd, UsdGeom, Vt

    p = tmp_path / "pi.usdc"
    st = Usd.Stage.CreateNew(str(p))
    UsdGeom.SetStageUpAxis(st, "Z")
    pi = UsdGeom.PointInstancer.Define(st, "/I")
    cube = UsdGeom.Cube.Define(st, "/I/proto")
    pi.CreatePrototypesRel().SetTargets([cube.GetPath()])
    n = 2_000_000
    pi.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(np.zeros(n, np.int32)))
    pos = np.zeros((n, 3), np.float32)
    pos[:, 0] = np.arange(n) * 3.0
    pi.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(pos))
    st.GetRootLayer().Save()
    run = cli_proc(
        "plan", "--scene", p, "--cameras", "1", "--no-progress", timeout=60, memory_gb=MEMORY_GB
    )
    refused(run, "point instancer /I: 2,000,000 instances, above the limit of 1,000,000")
    assert run.seconds < 40


@HUGE
def test_a_dataset_larger_than_the_disk_is_refused(tmp_path):
    run = cli(
        "dataset",
        "assembly_line",
        "--scenes",
        "1000000",
        "--max-disk-gb",
        "1",
        "--out",
        tmp_path / "o",
        timeout=60,
    )
    refused(run, "the run would write about", "--max-disk-gb")


@HUGE
def test_a_mobile_map_voxel_too_small_is_refused_by_its_memory(tmp_path):
    """A 0.1 µm voxel over a hall would be ~1e26 voxels: the bit set's size overflowed int64 and
    numpy raised; now the dataset's estimate refuses it before any work, and fuse() the same."""
    run = cli(
        "dataset",
        "assembly_line",
        "--capture",
        "mobile-map",
        "--voxel-m",
        "1e-7",
        "--out",
        tmp_path / "o",
        timeout=60,
    )
    refused(
        run,
        "estimated memory",
        "the map's bit set at --voxel-m 1e-07",
        "a larger --voxel-m",
        "--max-memory-gb",
    )
    assert run.seconds < 30
    assert not list((tmp_path / "o").glob("scenes/*"))
    with pytest.raises(LimitError, match="voxels"):
        gg.fuse([], bounds=[[0, 0, 0], [100, 100, 10]], voxel_m=1e-7)


@HUGE
def test_an_hour_long_trajectory_is_refused_by_its_disk(tmp_path):
    """--duration-s 3600 of a 4 x 15 Hz rig writes every frame's points: about 216 000 frames;
    refused by the disk limit up front."""
    run = cli(
        "dataset",
        "assembly_line",
        "--capture",
        "trajectory",
        "--rig",
        "d435_quad",
        "--duration-s",
        "3600",
        "--scenes",
        "10",
        "--max-disk-gb",
        "1",
        "--out",
        tmp_path / "o",
        timeout=60,
    )
    refused(run, "the run would write about", "--max-disk-gb", "a shorter --duration-s")
