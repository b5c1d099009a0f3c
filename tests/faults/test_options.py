"""Bad options to every command: one line naming the option, what was expected and what came;
exit status 2; before any work and before anything is written."""

from pathlib import Path

import numpy as np
import pytest
import trimesh

import genie_gl as gg

from .common import cli, fault, refused

OPTION = fault("bad option", "traceback")
WRONG = fault("bad option", "wrong")


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("inputs")
    s = gg.Scene()
    s.add(trimesh.creation.box((4, 4, 1)), np.eye(4), semantic=2)
    s.add(trimesh.creation.box((20, 20, 0.02)), np.eye(4), semantic=0)
    gg.generate_layout("assembly_line", seed=0).to_json(d / "layout.json")
    (d / "a_file").write_text("x")
    return {
        "usd": gg.write_usd(s, d / "s.usda"),
        "layout": d / "layout.json",
        "file": d / "a_file",
        "dir": d,
    }


SEED = "expected a whole number in 0..2**63-1"
CASES = [
    # genie layout
    (OPTION, ["layout", "assembly_line", "--seed", "-1"], [SEED, "got -1"]),
    (OPTION, ["layout", "assembly_line", "--seed", "1.5"], [SEED, "got 1.5"]),
    (OPTION, ["layout", "assembly_line", "--seed", "x"], [SEED, "got 'x'"]),
    (OPTION, ["layout", "assembly_line", "--seed", str(2**63)], [SEED]),
    (
        OPTION,
        ["layout", "assembly_line", "--resolution", "0"],
        ["--resolution", "expected a finite number in (0, 1000]"],
    ),
    (OPTION, ["layout", "assembly_line", "--resolution", "nan"], ["--resolution", "got nan"]),
    (OPTION, ["layout", "assembly_line", "--resolution", "1e-5"], ["use a coarser --resolution"]),
    (
        OPTION,
        ["layout", "assembly_line", "--max-nodes", "0"],
        ["--max-nodes", "expected a whole number in 1.."],
    ),
    (
        OPTION,
        ["layout", "assembly_lin", "--out", "{dir}/never"],
        ["no shipped layout of that name", "did you mean 'assembly_line'"],
    ),
    (OPTION, ["layout", "assembly_line"], ["give a STRATEGY and --out DIR"]),
    (OPTION, ["layout", "assembly_line", "--out", "{file}"], ["is a file; expected a folder"]),
    (
        OPTION,
        ["layout", "assembly_line", "--out", "{file}/sub"],
        ["not writable", "is a file, not a folder"],
    ),
    # genie scene
    (OPTION, ["scene", "{layout}", "--seed", "-1"], [SEED]),
    (
        OPTION,
        ["scene", "{layout}", "--out", "{dir}/s.txt"],
        ["expected a .usda, .usdc or .usd file name"],
    ),
    (
        OPTION,
        ["scene", "{layout}", "--out", "{dir}"],
        ["expected a .usda, .usdc or .usd file name"],
    ),
    (
        OPTION,
        ["scene", "{dir}/none.json", "--out", "{dir}/n.usda"],
        ["none.json", "cannot read the layout JSON"],
    ),
    (
        OPTION,
        ["scene", "assembly_line", "--out", "{dir}/n.usda"],
        ["assembly_line", "cannot read the layout JSON"],
    ),
    # genie capture
    (
        OPTION,
        ["capture", "{usd}", "--cameras", "0"],
        ["--cameras", "expected a whole number in 1..10000, got 0"],
    ),
    (OPTION, ["capture", "{usd}", "--cameras", "10001"], ["--cameras", "got 10001"]),
    (OPTION, ["capture", "{usd}", "--cameras", "1.5"], ["--cameras", "got 1.5"]),
    (OPTION, ["capture", "{usd}", "--seed", "-3"], [SEED]),
    (OPTION, ["capture", "{usd}", "--mount", "nan"], ["--mount", "got nan"]),
    (OPTION, ["capture", "{usd}", "--mount", "-1"], ["--mount", "got -1"]),
    (OPTION, ["capture", "{usd}", "--height", "0"], ["--mount/--height", "got 0"]),
    (OPTION, ["capture", "{usd}", "--format", "plyy"], ["--format 'plyy'", "did you mean 'ply'"]),
    (
        OPTION,
        ["capture", "{usd}", "--sensor", "kinect_v3"],
        ["kinect_v3", "did you mean 'kinect_v2'"],
    ),
    (OPTION, ["capture", "{usd}", "--poses", "{dir}/none.npy"], ["none.npy", "cannot read poses"]),
    (OPTION, ["capture", "{usd}", "--out", "{file}"], ["is a file; expected a folder"]),
    # genie plan
    (OPTION, ["plan", "--scene", "{usd}", "--seed", "-1"], [SEED, "got -1"]),
    (OPTION, ["plan", "--scene", "{usd}", "--mount", "nan"], ["--mount", "got nan"]),
    (OPTION, ["plan", "--scene", "{usd}", "--cameras", "100000"], ["--cameras", "got 100000"]),
    (OPTION, ["plan", "--scene", "{usd}", "--scenes", "0"], ["--scenes", "got 0"]),
    (
        OPTION,
        ["plan", "--scene", "{usd}", "--cameras", "2", "--poses", "p.npy"],
        ["not allowed with argument"],
    ),
    (OPTION, ["plan", "--scene", "{dir}/none.usda"], ["none.usda", "no such USD file"]),
    # genie dataset
    (OPTION, ["dataset", "assembly_line", "--mount", "nan"], ["--mount nan", "finite number"]),
    (OPTION, ["dataset", "assembly_line", "--mount", "0"], ["--mount 0.0", "greater than 0"]),
    (
        OPTION,
        ["dataset", "assembly_line", "--workers", "0"],
        ["--workers 0", "greater than or equal to 1"],
    ),
    (
        OPTION,
        ["dataset", "assembly_line", "--scenes", "1.5"],
        ["--scenes", "invalid int value: '1.5'"],
    ),
    (
        OPTION,
        ["dataset", "assembly_line", "--split", "1,-1,0"],
        ["--split", "expected three shares >= 0"],
    ),
    (OPTION, ["dataset", "assembly_line", "--split", "0,0,0"], ["--split", "not all 0"]),
    (OPTION, ["dataset", "assembly_line", "--max-nodes", "0"], ["--max-nodes 0"]),
    (OPTION, ["dataset", "assembly_line", "--format", "kitti"], ["--format", "unknown"]),
    (OPTION, ["dataset", "assembly_line", "--out", "{file}"], ["is a file; expected a folder"]),
    # genie dataset: cameras that move (an option the capture does not use is refused, never
    # ignored)
    (
        WRONG,
        ["dataset", "assembly_line", "--rig", "d435_quad"],
        ["--rig 'd435_quad'", "--capture static does not use it"],
    ),
    (
        WRONG,
        ["dataset", "assembly_line", "--voxel-m", "0.05"],
        ["--voxel-m", "is for --capture mobile-map"],
    ),
    (
        WRONG,
        ["dataset", "assembly_line", "--capture", "trajectory", "--cameras", "2"],
        ["--cameras 2", "--capture trajectory does not use it"],
    ),
    (
        WRONG,
        ["dataset", "assembly_line", "--capture", "trajectory", "--mount", "1.2"],
        ["--mount 1.2", "does not use it"],
    ),
    (
        WRONG,
        ["dataset", "assembly_line", "--capture", "trajectory", "--registration", "none"],
        ["--registration", "is for --capture mobile-map"],
    ),
    (
        OPTION,
        ["dataset", "assembly_line", "--capture", "trajectory", "--path", "aisle"],
        ["--path 'aisle'", "did you mean 'aisles'"],
    ),
    (
        OPTION,
        ["dataset", "assembly_line", "--capture", "trajectory", "--rig", "d435_qud"],
        ["did you mean 'd435_quad'"],
    ),
    (
        OPTION,
        ["dataset", "assembly_line", "--capture", "mobile-map", "--duration-s", "nan"],
        ["--duration-s nan"],
    ),
    (
        OPTION,
        ["dataset", "assembly_line", "--capture", "mobile-map", "--voxel-m", "0"],
        ["--voxel-m 0.0"],
    ),
    (
        OPTION,
        ["dataset", "assembly_line", "--capture", "trajectory", "--format", "bop"],
        ["--format bop takes --capture static, not trajectory"],
    ),
    (
        OPTION,
        ["dataset", "assembly_line", "--capture", "mobil-map"],
        ["--capture 'mobil-map': unknown", "did you mean 'mobile-map'"],
    ),
    # genie plan --rig: a recording's plan and a standing plan do not share options
    (
        WRONG,
        ["plan", "--scene", "{usd}", "--path", "aisles"],
        ["--path aisles", "give --rig RIG too"],
    ),
    (
        WRONG,
        ["plan", "--scene", "{usd}", "--duration-s", "5"],
        ["--duration-s 5.0", "give --rig RIG too"],
    ),
    (
        WRONG,
        ["plan", "--scene", "{usd}", "--rig", "d435_quad", "--poses", "p.npy"],
        ["--poses p.npy", "drop it"],
    ),
    (
        WRONG,
        ["plan", "--scene", "{usd}", "--rig", "d435_quad", "--cameras", "3"],
        ["--cameras 3", "drop it"],
    ),
    (
        WRONG,
        ["plan", "--scene", "{usd}", "--rig", "d435_quad", "--mount", "1"],
        ["--mount 1.0", "drop it"],
    ),
    (
        OPTION,
        ["plan", "--scene", "{usd}", "--rig", "d435_quad", "--path", "aisle"],
        ["did you mean 'aisles'"],
    ),
    (OPTION, ["plan", "--scene", "{usd}", "--rig", "d435_qud"], ["did you mean 'd435_quad'"]),
    (
        OPTION,
        ["plan", "--scene", "{usd}", "--rig", "d435_quad", "--duration-s", "0"],
        ["--duration-s", "got 0"],
    ),
    # genie bench
    (OPTION, ["bench", "rendr"], ["invalid choice: 'rendr'"]),
    (OPTION, ["bench", "sequence", "--repeat", "0"], ["--repeat", "got 0"]),
    (OPTION, ["bench", "sequence", "--duration-s", "nan"], ["--duration-s", "got nan"]),
    (OPTION, ["bench", "sequence", "--seed", "-1"], [SEED]),
    (OPTION, ["bench", "odometry", "--duration-s", "0"], ["--duration-s", "got 0"]),
    (OPTION, ["bench", "odometry", "--seed", "x"], [SEED, "got 'x'"]),
    (OPTION, ["bench", "odometry", "--path", "aisle"], ["invalid choice: 'aisle'"]),
    (
        WRONG,
        ["bench", "accuracy", "--path", "aisles"],
        ["--path aisles", "need a strategy or layout --scene"],
    ),
    (
        WRONG,
        ["bench", "accuracy", "--path", "aisles", "--scene", "{usd}"],
        ["need a strategy or layout --scene"],
    ),
    (OPTION, ["bench", "layout", "--repeats", "0"], ["--repeats", "got 0"]),
    (OPTION, ["bench", "render", "--scenes", "10k"], ["--scenes", "did you mean '100k'"]),
    (OPTION, ["bench", "render", "--tools", "open3d"], ["--tools", "did you mean 'Open3D'"]),
    (OPTION, ["bench", "render", "--repeats", "0"], ["--repeats", "got 0"]),
    (OPTION, ["bench", "pipeline", "--workers", "1,x"], ["--workers", "got 'x'"]),
    (OPTION, ["bench", "accuracy", "--budget-mm", "-1"], ["--budget-mm", "got -1"]),
    (OPTION, ["bench", "accuracy", "--seed", "-1"], [SEED]),
    (OPTION, ["bench", "layout", "--out", "{file}"], ["is a file; expected a folder"]),
    # genie report-card
    (OPTION, ["report-card", "--sensor", "kinect_v2", "--seed", "-1"], [SEED]),
    (
        OPTION,
        ["report-card", "--sensor", "kinect_v2", "--frames", "1"],
        ["--frames", "at least 2 frames"],
    ),
    (OPTION, ["report-card", "--sensor", "kinect_v2", "--frames", "2.5"], ["--frames", "got 2.5"]),
    (
        OPTION,
        [
            "report-card",
            "--sensor",
            "kinect_v2",
            "--captures",
            "{dir}",
            "--calibration",
            "{file}",
            "--wall-distance",
            "nan",
        ],
        ["--wall-distance", "got nan"],
    ),
    (
        OPTION,
        ["report-card", "--sensor", "kinect_v2", "--depth-scale", "0"],
        ["--depth-scale", "got 0"],
    ),
    (OPTION, ["report-card", "--sensor", "kinect_v3"], ["kinect_v3", "did you mean 'kinect_v2'"]),
    (
        OPTION,
        ["report-card", "--sensor", "kinect_v2", "--out", "{file}"],
        ["is a file; expected a folder"],
    ),
    # the top level
    (OPTION, ["laoyut"], ["invalid choice: 'laoyut'"]),
]


def _fill(argv: list[str], files: dict[str, Path], tmp_path: Path) -> list[str]:
    out = [a.format(**{k: str(v) for k, v in files.items()}) for a in argv]
    if (
        "--out" not in out
        and out[0] not in ("plan", "report-card")
        and not (out[0] == "layout" and len(out) == 2)
    ):
        out += ["--out", str(tmp_path / ("o.usda" if out[0] == "scene" else "o"))]
    return out


@pytest.mark.parametrize(
    "mark, argv, needles",
    [pytest.param(m, a, n, marks=m, id=" ".join(a)[:60]) for m, a, n in CASES],
)
def test_a_bad_option_is_one_line_before_any_work(mark, argv, needles, files, tmp_path):
    run = cli(*_fill(argv, files, tmp_path), timeout=60)
    refused(run, *needles)
    assert run.seconds < 30
    assert not (tmp_path / "o").exists() and not (tmp_path / "o.usda").exists()  # nothing written


@WRONG
def test_plan_mount_places_cameras_at_that_height(files):
    """--mount is used, never ignored (and NaN is refused above): every camera at 1.7 m over the
    floor."""
    run = cli(
        "plan",
        "--scene",
        files["usd"],
        "--cameras",
        "3",
        "--mount",
        "1.7",
        "--json",
        "--no-progress",
    )
    assert run.rc == 0, run.err
    import json

    plan = json.loads(run.out)
    assert len(plan["frames"]) == 3
    scene = gg.read_usd(files["usd"])
    from genie_gl.placement.genetic import scene_poses

    poses = scene_poses(scene, gg.load_sensor("ideal_pinhole"), 3, 0, mount_height_m=1.7)
    floor = scene.bounds()[0][2]
    np.testing.assert_allclose([p[2, 3] - floor for p in poses], 1.7, atol=1e-9)


@WRONG
def test_the_placement_hint_names_an_option_every_placing_command_has(files, tmp_path):
    """zivid2_m70 cannot see the floor from the usual mounts: the error names --mount, and
    --mount works in capture, plan and dataset alike (the hint used to name an option
    genie dataset did not have)."""
    for argv in (
        ["capture", files["usd"], "--out", tmp_path / "c"],
        ["plan", "--scene", files["usd"]],
        ["dataset", "assembly_line", "--out", tmp_path / "d"],
    ):
        err = refused(cli(*argv, "--sensor", "zivid2_m70", "--cameras", "2"), "--mount M")
        assert "genie --mount" not in err
    # with a mount the placement works: a dataset run goes on to its next check (the limit given)
    refused(
        cli(
            "dataset",
            "assembly_line",
            "--sensor",
            "zivid2_m70",
            "--cameras",
            "2",
            "--mount",
            "0.6",
            "--max-nodes",
            "1",
            "--out",
            tmp_path / "d",
        ),
        "--max-nodes",
    )
    run = cli(
        "plan",
        "--scene",
        files["usd"],
        "--sensor",
        "zivid2_m70",
        "--cameras",
        "2",
        "--mount",
        "0.6",
        "--no-progress",
    )
    assert run.rc == 0, run.err


@pytest.mark.parametrize("bench", ["sequence", "odometry"])
@fault("bad option", "traceback")
def test_a_benchmark_refuses_a_bad_rig_or_strategy_before_its_folder(bench, tmp_path):
    """The rig and strategy are read before ``--out`` is claimed: nothing is made for a typo."""
    refused(
        cli("bench", bench, "--rig", "d435_qud", "--out", tmp_path / "o"),
        "did you mean 'd435_quad'",
    )
    refused(
        cli("bench", bench, "--strategy", "storage_are", "--out", tmp_path / "o"),
        "did you mean 'storage_area'",
    )
    assert not (tmp_path / "o").exists()


@fault("bad option", "traceback")
def test_a_missing_optional_package_is_one_line_naming_its_install(tmp_path, monkeypatch):
    """genie bench odometry without KISS-ICP installed: one line naming the package and its
    extra, never an ImportError's traceback."""
    import sys

    # import kiss_icp (and any of its modules another test imported) now fails as if not installed
    for name in ["kiss_icp", *(m for m in sys.modules if m.startswith("kiss_icp."))]:
        monkeypatch.setitem(sys.modules, name, None)
    run = cli("bench", "odometry", "--duration-s", "1", "--out", tmp_path / "o")
    refused(run, "needs the Python package 'kiss_icp'", "pip install 'genie-gl[bench]'")
