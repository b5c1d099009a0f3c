"""genie eval's inputs and outputs under faults: a feature cache that must follow the points
it was computed from (their pose and calibration too) and stays inside --out; raw labels a
genie-gl set's yaml does not name refused, never made classes of their own; a test set that is
the training set refused; unreadable label maps, poses and calibrations in one line naming the
file and line; a failed run leaves no manifest listing files it never wrote."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from genie_gl.errors import ConfigError
from genie_gl.eval import evaluate, read_set
from genie_gl.eval.classical import BoostParams
from genie_gl.eval.features import scans_features
from tests.eval.toy import make_set

from .common import cli, fault, refused

FAST = BoostParams(max_points=5_000, rounds=5, early_stop=3)
BAD = fault("bad file", "traceback")


def _poses(root: Path, seq: str = "00") -> Path:
    return root / "sequences" / seq / "poses.txt"


def _rotate_first_pose(root: Path, yaw: float) -> None:
    """Turn scan 0 of sequence 00 by ``yaw`` about z (its .bin untouched)."""
    p = _poses(root)
    lines = p.read_text().splitlines()
    m = np.eye(4)
    m[:3] = np.array(lines[0].split(), float).reshape(3, 4)
    c, s = np.cos(yaw), np.sin(yaw)
    r = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    m[:3, :3] = r @ m[:3, :3]
    lines[0] = " ".join(f"{v:.9e}" for v in m[:3].ravel())
    p.write_text("\n".join(lines) + "\n")


@fault("bad file", "wrong")
@pytest.mark.parametrize("change", ["pose rotation", "calib Tr"])
def test_the_feature_cache_follows_the_pose_and_calibration(change, tmp_path):
    """Once features are cached, rotating a scan's pose (or changing its calib Tr) leaves its
    .bin alone: the cache must not hand back the features of the old pose."""
    root = make_set(tmp_path / "s", scenes=1, seed=0, points=1500)
    if (
        change == "calib Tr"
    ):  # a pose that is not the identity, so that Tr matters (inv(Tr) pose Tr)
        _rotate_first_pose(root, 0.3)
    cache = tmp_path / "cache"
    before = scans_features(read_set(root).scans, cache=cache)
    if change == "pose rotation":
        _rotate_first_pose(root, np.pi / 2)
    else:
        calib = root / "sequences" / "00" / "calib.txt"
        text = calib.read_text().splitlines()
        text = [("Tr: 1 0 0 0 0 0 -1 0 0 1 0 0" if ln.startswith("Tr:") else ln) for ln in text]
        calib.write_text("\n".join(text) + "\n")
    scans = read_set(root).scans
    fresh = scans_features(scans)
    again = scans_features(scans, cache=cache)
    assert not np.array_equal(fresh, before)  # the change moved the points: features differ
    np.testing.assert_array_equal(again, fresh)


@fault("bad option", "loss")
def test_the_default_cache_is_inside_out(tmp_path):
    """`genie eval --out P/o` writes under P/o only: its cache is not P/eval-cache, shared by
    every run beside it."""
    sets = tmp_path / "sets"
    tr = make_set(sets / "tr", scenes=1, seed=0, points=800)
    te = make_set(sets / "te", scenes=1, seed=1, points=800)
    parent = tmp_path / "runs"
    parent.mkdir()
    run = cli(
        "eval",
        "--no-progress",
        "--train",
        tr,
        "--test",
        te,
        "--seeds",
        "0",
        "--workers",
        "1",
        "--out",
        parent / "o",
        timeout=120,
    )
    assert run.rc == 0, run.err
    assert sorted(p.name for p in parent.iterdir()) == ["o"]
    assert any((parent / "o" / "cache").rglob("*.npy"))
    manifest = json.loads((parent / "o" / "manifest.json").read_text())
    assert "cache" in manifest["outputs"] and "writing" not in manifest


@pytest.fixture(scope="module")
def sets(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("eval-faults")
    out = {
        "tr": make_set(d / "tr", scenes=2, seed=0, points=600),
        "te": make_set(d / "te", scenes=1, seed=1, points=600),
    }
    for name, value, where in (
        ("stray200", 200, "train"),
        ("stray70000", 70000, "train"),
        ("test200", 200, "test"),
    ):
        root = make_set(d / name, scenes=1, seed=2, points=600)
        f = next(root.glob("sequences/*/labels/*.label"))
        raw = np.fromfile(f, "<u4")
        raw[:50] = value  # 50 points of a label the set's yaml does not name
        raw.tofile(f)
        out[name] = root
    out["copy"] = d / "copy"
    shutil.copytree(out["tr"], out["copy"])
    out["binmap"] = d / "map.yaml"
    out["binmap"].write_bytes(bytes(range(256)) * 4)
    for name, text in (
        ("letters", "1 0 0 0 0 1 0 0 0 0 1 zero\n"),
        ("nan", "1 0 0 0 0 1 0 0 0 0 nan 0\n"),
        ("short", ""),
    ):
        root = make_set(d / name, scenes=1, seed=3, points=600)
        _poses(root).write_text(text if name != "short" else "1 0 0 0 0 1 0 0 0 0 1 0\n")
        if name == "short":  # a second scan in the sequence, its pose missing
            for sub, ext in (("velodyne", "bin"), ("labels", "label")):
                shutil.copy(
                    root / "sequences/00" / sub / f"000000.{ext}",
                    root / "sequences/00" / sub / f"000001.{ext}",
                )
        out[name] = root
    root = make_set(d / "calib", scenes=1, seed=4, points=600)
    calib = root / "sequences/00/calib.txt"
    calib.write_text(calib.read_text().replace("Tr: 1", "Tr: one"))
    out["calib"] = root
    root = make_set(d / "binyaml", scenes=1, seed=5, points=600)
    (root / "genie-gl.yaml").write_bytes(b"\xff\xfe" + bytes(range(256)))
    out["binyaml"] = root
    root = make_set(d / "renamed", scenes=1, seed=6, points=600)
    (root / "genie-gl.yaml").write_text(
        (root / "genie-gl.yaml").read_text().replace("1: pallet", "1: palette")
    )
    out["renamed"] = root
    return out


TT = ["--train", "{tr}", "--test", "{te}"]
CASES = [
    (
        fault("bad file", "wrong"),
        ["--train", "{stray200}", "--test", "{te}"],
        ["000000.label: label 200 (on 50 of", "outside the label map", "genie-gl.yaml: ids 0-9"],
    ),
    (
        fault("bad file", "hang"),
        ["--train", "{stray70000}", "--test", "{te}"],
        ["000000.label: label 4464 (on 50 of", "outside the label map", "genie-gl.yaml: ids 0-9"],
    ),
    (
        BAD,
        ["--train", "{tr}", "--test", "{test200}"],
        ["000000.label: label 200 (on 50 of", "outside the label map"],
    ),
    (
        fault("bad option", "wrong"),
        ["--train", "{tr}", "--test", "{tr}"],
        ["--test", "2 of its 2 scans are training scans too", "the same file", "--allow-overlap"],
    ),
    (
        fault("bad option", "wrong"),
        ["--train", "{tr}", "--test", "{copy}:01"],
        [
            "--test",
            "1 of its 1 scans are training scans too",
            "the same points as",
            "--allow-overlap",
        ],
    ),
    (BAD, TT + ["--label-map", "{binmap}"], ["--label-map", "map.yaml: not a text file"]),
    (
        BAD,
        ["--train", "{letters}", "--test", "{te}"],
        ["poses.txt: line 1", "'zero' is not a number"],
    ),
    (BAD, ["--train", "{nan}", "--test", "{te}"], ["poses.txt: line 1", "number 11 of 12 is nan"]),
    (
        fault("bad file", "wrong"),
        ["--train", "{short}", "--test", "{te}"],
        ["poses.txt: 1 poses, but scan 000001.bin needs line 2"],
    ),
    (
        BAD,
        ["--train", "{calib}", "--test", "{te}"],
        ["calib.txt: line 5 (Tr)", "'one.", "is not a number"],
    ),
    (
        BAD,
        ["--train", "{binyaml}", "--test", "{te}"],
        ["genie-gl.yaml: cannot read the label-map yaml (not a text file"],
    ),
]


@pytest.mark.parametrize(
    "mark, argv, needles",
    [pytest.param(m, a, n, marks=m, id=" ".join(a)[:60]) for m, a, n in CASES],
)
def test_a_bad_eval_input_is_one_line_and_writes_nothing(mark, argv, needles, sets, tmp_path):
    args = [a.format(**{k: str(v) for k, v in sets.items()}) for a in argv]
    run = cli("eval", "--no-progress", "--seeds", "0", *args, "--out", tmp_path / "o", timeout=60)
    refused(run, *needles)
    assert run.seconds < 30
    assert not (tmp_path / "o").exists()


@fault("bad option", "wrong")
def test_an_overlap_asked_for_is_allowed(sets, tmp_path):
    run = cli(
        "eval",
        "--no-progress",
        "--seeds",
        "0",
        "--workers",
        "1",
        "--train",
        sets["tr"],
        "--test",
        f"{sets['tr']}:00",
        "--allow-overlap",
        "--out",
        tmp_path / "o",
        timeout=120,
    )
    assert run.rc == 0, run.err
    assert (tmp_path / "o" / "metrics.json").is_file()


@fault("bad option", "wrong")
def test_a_failed_eval_leaves_a_manifest_of_what_exists(sets, tmp_path):
    """A run that fails in a folder of its own leaves no folder; one that fails where an earlier
    run finished leaves that run's files and a manifest listing exactly what is there."""
    out = tmp_path / "o"
    run = cli(
        "eval", "--no-progress", "--train", tmp_path / "missing", "--test", sets["te"], "--out", out
    )
    refused(run, "missing: no such dataset folder")
    assert not out.exists()
    ok = cli(
        "eval",
        "--no-progress",
        "--seeds",
        "0",
        "--workers",
        "1",
        "--train",
        sets["tr"],
        "--test",
        sets["te"],
        "--out",
        out,
        timeout=120,
    )
    assert ok.rc == 0, ok.err
    (out / "notes.txt").write_text("mine")
    first = {
        p.name: p.read_bytes() for p in out.iterdir() if p.is_file() and p.name != "manifest.json"
    }
    for argv in (
        ["--train", tmp_path / "missing", "--test", sets["te"]],
        ["--train", sets["tr"], "--test", sets["stray200"]],
        ["--train", sets["tr"], "--test", sets["renamed"]],
    ):  # found once the sets are read
        run = cli("eval", "--no-progress", "--seeds", "0", *argv, "--out", out)
        assert run.rc == 2 and "Traceback" not in run.err
        manifest = json.loads((out / "manifest.json").read_text())
        listed = set(manifest["outputs"])
        assert listed == {p.name for p in out.iterdir()} - {"manifest.json", "notes.txt"}, listed
        assert {"metrics.json", "predictions", "report.md", "timings.json"} <= listed
        assert "writing" not in manifest
        assert {
            p.name: p.read_bytes()
            for p in out.iterdir()
            if p.is_file() and p.name != "manifest.json"
        } == first


@fault("bad API call", "wrong")
def test_a_failure_after_the_inputs_are_read_removes_what_it_began(sets, tmp_path):
    """Mismatched class names, found once the sets are read: the folder this call made is
    gone again, nothing half-written is left."""
    a = make_set(tmp_path / "a", scenes=1, seed=7, points=600)
    b = make_set(tmp_path / "b", scenes=1, seed=8, points=600)
    y = (b / "genie-gl.yaml").read_text().replace("1: pallet", "1: palette")
    (b / "genie-gl.yaml").write_text(y)
    with pytest.raises(ConfigError, match="mismatched label maps"):
        evaluate(
            [a], [b], seeds=[0], params=FAST, out=tmp_path / "o", cache=tmp_path / "o" / "cache"
        )
    assert not (tmp_path / "o").exists()


@fault("bad API call", "wrong")
def test_read_set_refuses_a_stray_label_in_a_set_of_ours(sets):
    with pytest.raises(
        ConfigError, match=r"label 200 \(on 50 of \d+ points\) is outside the label map"
    ):
        read_set(sets["stray200"])
    assert max(s.label.max() for s in read_set(sets["tr"]).scans) <= 9


def _ply_edit(old: bytes, new: bytes):
    def edit(f: Path) -> None:
        f.write_bytes(f.read_bytes().replace(old, new, 1))

    return edit


CHUNKS = [  # (mark, format, how the file is broken, what the one line says)
    (
        BAD,
        "ply",
        _ply_edit(b"element vertex ", b"element vertex x"),
        "header line 5 ('element vertex x",
    ),
    (
        BAD,
        "ply",
        _ply_edit(b"comment origin ", b"comment origin zz "),
        "header line 4 ('comment origin zz",
    ),
    (
        BAD,
        "ply",
        lambda f: f.write_bytes(f.read_bytes()[:-40]),
        "truncated: 5920 bytes of vertex data for the 298",
    ),
    (BAD, "npz", lambda f: f.write_bytes(b"garbage" * 10), "not a readable NPZ cloud"),
    (
        fault("bad file", "wrong"),
        "npz",
        lambda f: np.savez(f, xyz=np.zeros((3, 3), np.float32), semantic=np.array([0, 1, 2.5])),
        "semantic is float64; expected whole class ids",
    ),
    (
        fault("bad file", "wrong"),
        "npz",
        lambda f: np.savez(
            f,
            xyz=np.zeros((3, 3), np.float32),
            semantic=np.zeros(3, np.uint16),
            origin=np.array([0, np.nan, 0]),
        ),
        "origin [0.0, nan, 0.0]: expected three finite numbers",
    ),
]


@pytest.mark.parametrize(
    "mark, fmt, edit, needle",
    [pytest.param(*c, marks=c[0], id=f"{c[1]}: {c[3][:30]}") for c in CHUNKS],
)
def test_a_broken_chunk_file_is_one_line_naming_it(mark, fmt, edit, needle, tmp_path):
    root = make_set(tmp_path / "s", scenes=1, seed=0, fmt=fmt, points=300)
    f = next(root.glob(f"scenes/*/*.{fmt}"))
    edit(f)
    with pytest.raises(ConfigError) as e:
        read_set(root)
    assert str(e.value).startswith(str(f)) and needle in str(e.value), str(e.value)
    assert len(str(e.value).splitlines()) == 1


@fault("bad file", "traceback")
def test_a_class_no_map_names_is_scored_by_its_id(tmp_path):
    """A PLY set holds a strategy's own class 12 (no yaml names it) that training never saw:
    reported as "class 12", where the summary line died with KeyError: 12."""
    from genie_gl.cloud.pointcloud import PointCloud
    from genie_gl.eval.data import read_ply
    from genie_gl.export import ply

    tr = make_set(tmp_path / "tr", scenes=1, seed=0, fmt="ply", points=600)
    src = make_set(tmp_path / "src", scenes=1, seed=1, fmt="ply", points=600)
    xyz, sem, _ = read_ply(next(src.glob("scenes/*/*.ply")))
    sem[:40] = 12
    ply.write(
        PointCloud(xyz=xyz, semantic=sem.astype(np.uint16), instance=np.zeros(len(sem), np.uint32)),
        tmp_path / "te" / "scenes" / "0000" / "cloud_000.ply",
    )
    run = cli(
        "eval",
        "--no-progress",
        "--seeds",
        "0",
        "--workers",
        "1",
        "--train",
        tr,
        "--test",
        tmp_path / "te",
        "--out",
        tmp_path / "o",
        timeout=120,
    )
    assert run.rc == 0 and "Traceback" not in run.err, run.err[-2000:]
    assert "never seen in training: class 12" in run.out
    metrics = json.loads((tmp_path / "o" / "metrics.json").read_text())
    assert metrics["tests"][0]["unseen_classes"] == ["class 12"]


@fault("bad option", "wrong")
def test_a_failed_preset_leaves_no_folder_and_a_good_one_runs(sets, tmp_path):
    """The preset claims its folder first: a run that fails on a missing set leaves no folder
    with a manifest of nothing; the same preset on real sets finishes (its options pass)."""
    run = cli(
        "eval",
        "--no-progress",
        "--preset",
        "finetune",
        "--target-train",
        tmp_path / "none",
        "--target-test",
        sets["te"],
        "--train",
        sets["tr"],
        "--seeds",
        "0",
        "--out",
        tmp_path / "p",
    )
    refused(run, "none: no such dataset folder")
    assert not (tmp_path / "p").exists()
    ok = cli(
        "eval",
        "--no-progress",
        "--preset",
        "finetune",
        "--target-train",
        f"{sets['tr']}:00",
        "--target-test",
        sets["te"],
        "--train",
        f"{sets['tr']}:01",
        "--seeds",
        "0",
        "--workers",
        "1",
        "--out",
        tmp_path / "p",
        timeout=300,
    )
    assert ok.rc == 0 and "Traceback" not in ok.err, ok.err[-2000:]
    manifest = json.loads((tmp_path / "p" / "manifest.json").read_text())
    assert set(manifest["outputs"]) == {p.name for p in (tmp_path / "p").iterdir()} - {
        "manifest.json"
    }
    assert not (tmp_path / "cache").exists() and (tmp_path / "p" / "cache").is_dir()


@fault("bad API call", "wrong")
def test_stray_labels_ignored_only_when_asked(sets, tmp_path):
    """The explicit way past a stray id in a set of ours: a --label-map that maps our classes
    and ignores the rest; the 50 stray points are then left out, the others kept."""
    p = tmp_path / "map.yaml"
    p.write_text("map: {" + ", ".join(f"{c}: {c}" for c in range(10)) + "}\ndefault: ignore\n")
    s = read_set(sets["stray200"], label_map=p)
    labels = np.concatenate([x.label for x in s.scans])
    assert int((labels == -1).sum()) == 50 and labels.max() <= 9
