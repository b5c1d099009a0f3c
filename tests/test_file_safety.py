"""Write only what you create: every command and API function that writes keeps the user's
files byte for byte, refuses (one line) a name it would have to take from them, and deletes
nothing it did not write (genie_gl/outputs.py)."""

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.cli import main

ONE_SCENE = [
    "assembly_line",
    "--scenes",
    "1",
    "--cameras",
    "2",
    "--sensor",
    "ideal_pinhole",
    "--points",
    "4000",
    "--min-points",
    "500",
    "--no-progress",
    "--previews",
    "1",
    "--workers",
    "1",
]


def plant(folder: Path) -> dict[str, str]:
    """The user's own files, in the places a careless writer would touch: a loose file, a file
    named like a temporary file, a folder named like a scene, a nested temporary file."""
    files = {
        "notes.txt": b"my notes\n",
        "draft.tmp": b"not yours\n",
        "old.tmp.png": b"\x89PNG not yours",
        "scenes_of_mine/0000/cloud.ply": b"ply? no: mine",
        "work/deep/x.tmp": b"nested tmp, mine",
        "sequences_backup/00/velodyne/000000.bin": bytes(range(16)),
    }
    for rel, data in files.items():
        p = folder / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)
    return {rel: hashlib.sha256(data).hexdigest() for rel, data in files.items()}


def assert_intact(folder: Path, planted: dict[str, str]) -> None:
    for rel, digest in planted.items():
        p = folder / rel
        assert p.is_file(), f"{rel} was removed"
        assert hashlib.sha256(p.read_bytes()).hexdigest() == digest, f"{rel} was changed"


def one_line(argv, capsys, *needles) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    for n in needles:
        assert n in err, err
    return err


@pytest.fixture(scope="module")
def scene_usd(tmp_path_factory) -> Path:
    s = gg.Scene()
    t = np.eye(4)
    t[:3, 3] = (0.0, 0.0, 0.5)
    s.add(trimesh.creation.box((4, 4, 1)), t, semantic=2)
    s.add(trimesh.creation.box((20, 20, 0.02)), np.eye(4), semantic=0)
    return gg.write_usd(s, tmp_path_factory.mktemp("scene") / "s.usda")


# --- commands ------------------------------------------------------------------------------


def test_layout_writes_beside_the_users_files_and_reruns(tmp_path, capsys):
    planted = plant(tmp_path)
    assert main(["layout", "assembly_line", "--seed", "0", "--out", str(tmp_path)]) == 0
    assert (
        main(["layout", "storage_area", "--seed", "1", "--out", str(tmp_path)]) == 0
    )  # its own: replaced
    assert_intact(tmp_path, planted)
    m = json.loads((tmp_path / "manifest.json").read_text())
    assert m["command"] == "layout" and m["outputs"] == ["labels.npy", "layout.json", "layout.png"]
    assert json.loads((tmp_path / "layout.json").read_text())["meta"]["seed"] == 1


def test_layout_refuses_a_name_the_user_holds(tmp_path, capsys):
    (tmp_path / "layout.png").write_bytes(b"my picture")
    one_line(
        ["layout", "assembly_line", "--out", str(tmp_path)], capsys, "'layout.png'", "did not write"
    )
    assert (tmp_path / "layout.png").read_bytes() == b"my picture"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["layout.png"]  # nothing written


def test_layout_refuses_a_foreign_manifest_and_another_commands_folder(tmp_path, capsys):
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "manifest.json").write_text('{"mine": 1}')
    one_line(
        ["layout", "assembly_line", "--out", str(tmp_path / "a")],
        capsys,
        "manifest.json",
        "did not write",
    )
    assert (tmp_path / "a" / "manifest.json").read_text() == '{"mine": 1}'
    assert main(["layout", "assembly_line", "--out", str(tmp_path / "b")]) == 0
    one_line(["capture", "x.usda", "--out", str(tmp_path / "b")], capsys, "genie layout")


def test_layout_in_the_current_folder_keeps_it(tmp_path, capsys, monkeypatch):
    planted = plant(tmp_path)
    monkeypatch.chdir(tmp_path)
    assert main(["layout", "assembly_line", "--out", "."]) == 0
    assert_intact(tmp_path, planted)
    assert (tmp_path / "layout.json").is_file()


@pytest.mark.gl
def test_scene_replaces_only_its_own_usd_and_picture(tmp_path, capsys):
    assert main(["layout", "assembly_line", "--out", str(tmp_path / "lay")]) == 0
    layout = str(tmp_path / "lay" / "layout.json")
    out = tmp_path / "s.usda"
    assert main(["scene", layout, "--out", str(out), "--no-progress"]) == 0
    assert (
        main(["scene", layout, "--seed", "3", "--out", str(out), "--no-progress"]) == 0
    )  # its own
    mine = tmp_path / "mine.usda"
    mine.write_text("#usda 1.0\n")
    capsys.readouterr()  # the runs above may have told of compiling the kernels (a cold cache)
    one_line(
        ["scene", layout, "--out", str(mine), "--no-progress"], capsys, "not written by genie-gl"
    )
    assert mine.read_text() == "#usda 1.0\n"
    (tmp_path / "t.png").write_bytes(b"my png")
    one_line(["scene", layout, "--out", str(tmp_path / "t.usda"), "--no-progress"], capsys, "t.png")
    assert (tmp_path / "t.png").read_bytes() == b"my png" and not (tmp_path / "t.usda").exists()


@pytest.mark.gl
def test_capture_writes_beside_the_users_files(tmp_path, capsys, scene_usd):
    planted = plant(tmp_path)
    argv = [
        "capture",
        str(scene_usd),
        "--cameras",
        "2",
        "--format",
        "ply",
        "--out",
        str(tmp_path),
        "--no-progress",
    ]
    assert main(argv) == 0
    assert main(argv) == 0
    assert_intact(tmp_path, planted)
    assert json.loads((tmp_path / "manifest.json").read_text())["outputs"] == ["cloud.ply"]
    (tmp_path / "u").mkdir()
    (tmp_path / "u" / "sequences").mkdir()
    one_line(
        [
            "capture",
            str(scene_usd),
            "--cameras",
            "2",
            "--format",
            "semantickitti",
            "--out",
            str(tmp_path / "u"),
            "--no-progress",
        ],
        capsys,
        "'sequences'",
    )


@pytest.mark.gl
def test_dataset_keeps_the_users_files_and_its_temporary_names(tmp_path, capsys):
    planted = plant(tmp_path)
    assert main(["dataset", *ONE_SCENE, "--out", str(tmp_path)]) == 0
    assert (
        main(["dataset", *ONE_SCENE, "--out", str(tmp_path)]) == 0
    )  # the resume clears only its own
    assert_intact(tmp_path, planted)
    m = json.loads((tmp_path / "manifest.json").read_text())
    assert {"scenes", "sequences", "genie-gl.yaml", "previews"} <= set(m["outputs"])
    assert not set(m["outputs"]) & {p.split("/")[0] for p in planted}


@pytest.mark.gl
def test_dataset_refuses_a_folder_with_scenes_it_did_not_make(tmp_path, capsys):
    (tmp_path / "scenes" / "0000").mkdir(parents=True)
    (tmp_path / "scenes" / "0000" / "x.tmp").write_bytes(b"mine")
    (tmp_path / "scenes" / ".tmp-0001-7").mkdir()
    one_line(["dataset", *ONE_SCENE, "--out", str(tmp_path)], capsys, "'scenes'", "did not write")
    assert (tmp_path / "scenes" / "0000" / "x.tmp").read_bytes() == b"mine"
    assert (tmp_path / "scenes" / ".tmp-0001-7").is_dir()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scenes"]


@pytest.mark.gl
def test_dataset_refuses_fewer_scenes_than_it_holds(tmp_path, capsys):
    assert main(["dataset", *ONE_SCENE[:2], "2", *ONE_SCENE[3:], "--out", str(tmp_path)]) == 0
    before = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*"))
    one_line(
        ["dataset", *ONE_SCENE, "--out", str(tmp_path)],
        capsys,
        "holds a dataset of 2 scenes",
        "--scenes 2",
    )
    assert sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*")) == before


def test_bench_keeps_the_users_files(tmp_path, capsys):
    planted = plant(tmp_path)
    (tmp_path / "layout.json").write_text("{}")
    one_line(["bench", "layout", "--out", str(tmp_path)], capsys, "'layout.json'")
    assert (tmp_path / "layout.json").read_text() == "{}"
    assert_intact(tmp_path, planted)


@pytest.mark.gl
def test_a_benchmark_writes_beside_the_users_files(tmp_path, capsys):
    """genie bench stability (one case) runs to the end in a folder of the user's files."""
    planted = plant(tmp_path)
    assert main(["bench", "stability", "--case", "far_near", "--out", str(tmp_path)]) in (0, 1)
    assert_intact(tmp_path, planted)
    m = json.loads((tmp_path / "manifest.json").read_text())
    assert m["command"] == "bench" and m["outputs"] == ["stability.json"]


# --- the API ---------------------------------------------------------------------------------


def _cloud() -> "gg.PointCloud":
    xyz = np.arange(30, dtype=np.float32).reshape(10, 3)
    return gg.PointCloud(
        xyz=xyz, semantic=np.ones(10, np.uint16), instance=np.arange(10, dtype=np.uint32)
    )


@pytest.mark.parametrize(
    "fmt, name",
    [
        ("ply", "cloud.ply"),
        ("pcd", "cloud.pcd"),
        ("npz", "cloud.npz"),
        ("semantickitti", "sequences"),
    ],
)
def test_export_writes_beside_the_users_files_and_refuses_their_names(tmp_path, fmt, name):
    planted = plant(tmp_path)
    gg.export(_cloud(), tmp_path, format=fmt)
    gg.export(_cloud(), tmp_path, format=fmt)  # its own file: replaced
    assert_intact(tmp_path, planted)
    other = tmp_path / "other"
    (other / name).parent.mkdir(parents=True)
    (other / name).write_bytes(b"mine") if "." in name else (other / name).mkdir()
    with pytest.raises(gg.ConfigError, match="did not write"):
        gg.export(_cloud(), other, format=fmt)
    assert sorted(p.name for p in other.iterdir()) == [name]


def test_single_file_writers_replace_only_their_own(tmp_path):
    from genie_gl.sensors.accuracy import AccuracySettings, write_accuracy
    from genie_gl.layout import save_layout_png
    from genie_gl.export import e57, las, npz, pcd, ply
    from genie_gl.sensors.calibration import Calibration, write_calibration

    layout = gg.generate_layout("assembly_line", seed=0)
    s = gg.Scene()
    s.add(trimesh.creation.box((1, 1, 1)), np.eye(4), semantic=1)
    calib = Calibration(64, 48, np.array([[50.0, 0, 32], [0, 50.0, 24], [0, 0, 1]]), np.zeros(5))
    writers = {
        "l.json": lambda p: layout.to_json(p),
        "l.png": lambda p: save_layout_png(layout, p),
        "s.usda": lambda p: gg.write_usd(s, p),
        "c.yml": lambda p: write_calibration(calib, p),
        "a.yaml": lambda p: write_accuracy(p, AccuracySettings()),
        "c.ply": lambda p: ply.write(_cloud(), p),
        "c.pcd": lambda p: pcd.write(_cloud(), p),
        "c.npz": lambda p: npz.write(_cloud(), p),
        "c.las": lambda p: las.write(_cloud(), p),
        "c.e57": lambda p: e57.write([_cloud()], p),
    }
    for name, write in writers.items():
        write(tmp_path / name)
        write(tmp_path / name)  # what it wrote: replaced
        mine = tmp_path / f"mine-{name}"
        mine.write_bytes(b"the user's own " + name.encode())
        with pytest.raises(gg.ConfigError, match="not written by genie-gl"):
            write(mine)
        assert mine.read_bytes() == b"the user's own " + name.encode()
    assert not [p.name for p in tmp_path.iterdir() if ".tmp" in p.name]


@pytest.mark.gl
def test_a_bag_replaces_only_its_own_folder(tmp_path):
    """A ROS 2 bag is a folder: the writer replaces a bag it wrote, and refuses a folder of the
    user's of that name (it used to delete it), leaving no temporary folder behind."""
    from genie_gl.capture.trajectory import record
    from genie_gl.export.rosbag import write_recording
    from genie_gl.motion.paths import make_trajectory
    from genie_gl.motion.rig import Rig

    layout = gg.generate_layout("assembly_line", seed=0)
    scene = gg.build_scene(layout, seed=0)
    rig = Rig.single(gg.load_sensor("ideal_pinhole"), rate_hz=2.0)
    tr = make_trajectory(layout, scene, "aisles", seed=0, duration_s=1.0)
    bag = tmp_path / "bag"
    for _ in range(2):  # its own bag: replaced
        write_recording(rig, tr, record(scene, rig, tr, seed=0, depth_only=True), bag)
    assert sorted(p.name for p in bag.iterdir()) == ["bag.mcap", "metadata.yaml"]
    mine = tmp_path / "mine"
    (mine / "notes").mkdir(parents=True)
    (mine / "notes" / "a.txt").write_text("the user's own")
    with pytest.raises(gg.ConfigError, match="not written by genie-gl"):
        write_recording(rig, tr, record(scene, rig, tr, seed=0, depth_only=True), mine)
    assert (mine / "notes" / "a.txt").read_text() == "the user's own"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag", "mine"]
