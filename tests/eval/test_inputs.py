"""Bad input is one line naming the file, the field and what was expected; a foreign
SemanticKITTI-layout set is read through a label-map file, and its predictions are written
in its own raw ids."""

import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from genie_gl.cli import main
from genie_gl.commands import eval as command
from genie_gl.errors import ConfigError
from genie_gl.eval import evaluate, read_set
from genie_gl.eval.classical import BoostParams
from genie_gl.eval.protocols import PRESETS
from genie_gl.eval.run import MODELS
from tests.eval.toy import make_set, relabel

FAST = BoostParams(max_points=20_000, rounds=30, early_stop=10)
THEIRS = {0: "unlabeled", 40: "floor", 50: "shelf", 51: "euro-pallet", 70: "box"}


def _foreign(tmp_path: Path) -> Path:
    """The toy set as someone else's scans: their raw ids and their own yaml."""
    root = make_set(tmp_path / "foreign", scenes=2, seed=1)
    relabel(root, {0: 40, 2: 50, 1: 51, 9: 70})
    (root / "genie-gl.yaml").unlink()
    (root / "scans.yaml").write_text(
        yaml.safe_dump({"labels": THEIRS, "learning_map": {k: k for k in THEIRS}})
    )
    return root


def _mapping(tmp_path: Path, **extra) -> Path:
    p = tmp_path / "map.yaml"
    data = {
        "map": {
            0: "ignore",
            "floor": "background",
            "shelf": "rack",
            51: "pallet",
            "box": "small_load_carrier",
        }
    }
    data.update(extra)
    p.write_text(yaml.safe_dump(data))
    return p


def test_a_foreign_set_needs_a_label_map(tmp_path):
    root = _foreign(tmp_path)
    with pytest.raises(
        ConfigError, match=r"scans.yaml: this set's classes are not genie-gl's.*--label-map"
    ):
        read_set(root)


def test_a_foreign_set_through_its_label_map_scores_as_ours_and_is_written_in_its_ids(tmp_path):
    ours_test = make_set(tmp_path / "ours", scenes=2, seed=1)
    root = _foreign(tmp_path)
    s = read_set(root, label_map=_mapping(tmp_path))
    assert sorted(np.unique(np.concatenate([x.label for x in s.scans])).tolist()) == [0, 1, 2, 9]
    train = make_set(tmp_path / "train", scenes=3, seed=0)
    kw = dict(seeds=[0], params=FAST, pictures=False)
    a = evaluate([train], [ours_test], out=tmp_path / "a", **kw).tests[0].runs[0]
    b = evaluate([train], [s], out=tmp_path / "b", **kw).tests[0].runs[0]
    # the same truth, class by class (their floor is estimated, ours known: features differ
    # slightly)
    assert (a.confusion.sum(1) == b.confusion.sum(1)).all()
    assert abs(a.miou - b.miou) < 0.05
    written = np.concatenate(
        [
            np.fromfile(f, "<u4")
            for f in sorted((tmp_path / "b" / "predictions" / "seed0").rglob("*.label"))
        ]
    )
    assert set(np.unique(written & 0xFFFF).tolist()) <= {
        40,
        50,
        51,
        70,
    }  # the upper half: instance ids


def test_label_outside_the_map(tmp_path):
    root = _foreign(tmp_path)
    relabel(root, {70: 77})
    with pytest.raises(
        ConfigError,
        match=r"000000.label: label 77 \(on 1332 of 5996 points\) is outside the label map "
        r"\(.*map.yaml: ids 0, 40, 50-51, 70\)",
    ):
        read_set(root, label_map=_mapping(tmp_path))
    assert read_set(root, label_map=_mapping(tmp_path, default="ignore")).n_points > 0


def test_label_map_with_an_unknown_class_says_did_you_mean(tmp_path):
    root = _foreign(tmp_path)
    p = tmp_path / "bad.yaml"
    p.write_text(yaml.safe_dump({"map": {"shelf": "rak"}}))
    with pytest.raises(
        ConfigError, match=r"map\['shelf'\]: unknown class 'rak'; did you mean 'rack'"
    ):
        read_set(root, label_map=p)


def test_empty_and_unlabelled_sets(tmp_path):
    root = make_set(tmp_path / "s", scenes=1, seed=0)
    shutil.rmtree(root / "sequences" / "00" / "labels")
    with pytest.raises(ConfigError, match=r"sequences/00: unlabelled sequence"):
        read_set(root)
    empty = tmp_path / "e"
    (empty / "sequences").mkdir(parents=True)
    (empty / "genie-gl.yaml").write_text((root / "genie-gl.yaml").read_text())
    with pytest.raises(ConfigError, match="empty set"):
        read_set(empty)
    ignored = _foreign(tmp_path / "f")
    p = tmp_path / "none.yaml"
    p.write_text(yaml.safe_dump({"map": {0: "ignore"}, "default": "ignore"}))
    with pytest.raises(ConfigError, match="unlabelled set"):
        read_set(ignored, label_map=p)


def test_folders_of_other_formats(tmp_path):
    bop = tmp_path / "bop"
    (bop / "train_pbr").mkdir(parents=True)
    with pytest.raises(ConfigError, match="a BOP image dataset"):
        read_set(bop)
    with pytest.raises(ConfigError, match="no such dataset folder"):
        read_set(tmp_path / "missing")
    other = tmp_path / "other"
    other.mkdir()
    with pytest.raises(ConfigError, match="not a dataset genie eval reads"):
        read_set(other)
    seq = make_set(tmp_path / "sk", scenes=1, seed=0) / "sequences" / "00"
    with pytest.raises(ConfigError, match="a single sequence folder"):
        read_set(seq)


def test_mismatched_label_maps(tmp_path):
    a = make_set(tmp_path / "a", scenes=1, seed=0)
    b = make_set(tmp_path / "b", scenes=1, seed=1)
    cfg = yaml.safe_load((b / "genie-gl.yaml").read_text())
    cfg["labels"][12] = "conveyor"
    (b / "genie-gl.yaml").write_text(yaml.safe_dump(cfg))
    c = make_set(tmp_path / "c", scenes=1, seed=2)
    cfg["labels"][12] = "robot arm"
    (c / "genie-gl.yaml").write_text(yaml.safe_dump(cfg))
    with pytest.raises(
        ConfigError, match=r"mismatched label maps: .* names class 12 'conveyor', .* 'robot arm'"
    ):
        evaluate([a, b], [c], seeds=[0], params=FAST)


def test_test_classes_never_seen_in_training_are_reported_not_a_crash(tmp_path, capsys):
    train = make_set(tmp_path / "t", scenes=2, seed=0)
    relabel(train, {9: 0})  # no small load carrier in training
    test = make_set(tmp_path / "s", scenes=1, seed=1)
    rc = main(
        [
            "eval",
            "--train",
            str(train),
            "--test",
            str(test),
            "--seeds",
            "0",
            "--out",
            str(tmp_path / "o"),
            "--workers",
            "1",
            "--no-progress",
        ]
    )
    assert rc == 0
    out = capsys.readouterr().out
    assert "never seen in training: small load carrier" in out
    assert (tmp_path / "o" / "report.md").read_text().count("never seen in training") == 1


def test_cli_bad_input_is_one_line(tmp_path, capsys):
    root = make_set(tmp_path / "s", scenes=1, seed=0)
    assert (
        main(
            [
                "eval",
                "--train",
                str(root),
                "--test",
                str(tmp_path / "nope"),
                "--out",
                str(tmp_path / "o"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nope: no such dataset folder" in err[0]
    assert (
        main(
            [
                "eval",
                "--train",
                str(root),
                "--test",
                str(root),
                "--seeds",
                "a",
                "--out",
                str(tmp_path / "o"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert "--seeds" in err and "expected a whole number in 0..2**63-1, got 'a'" in err
    assert (
        main(
            [
                "eval",
                "--train",
                str(root),
                "--test",
                str(root),
                "--model",
                "randal",
                "--seeds",
                "0",
                "--out",
                str(tmp_path / "o"),
            ]
        )
        == 2
    )
    assert "did you mean 'randla'" in capsys.readouterr().err


def test_eval_writes_only_what_it_creates(tmp_path, capsys):
    root = make_set(tmp_path / "s", scenes=2, seed=0)
    out = tmp_path / "o"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    args = [
        "eval",
        "--train",
        f"{root}:00",
        "--test",
        f"{root}:01",
        "--seeds",
        "0",
        "--out",
        str(out),
        "--workers",
        "1",
        "--no-progress",
    ]
    assert main(args) == 0
    assert (out / "notes.txt").read_text() == "mine"
    manifest = (out / "manifest.json").read_text()
    assert (
        '"command": "eval"' in manifest
        and "metrics.json" in manifest
        and "notes.txt" not in manifest
    )
    assert main(args) == 0  # its own outputs are replaced on a re-run
    mine = tmp_path / "p"
    mine.mkdir()
    (mine / "metrics.json").write_text("{}")
    assert main(args[:-5] + ["--out", str(mine), "--workers", "1", "--no-progress"]) == 2
    assert "already holds 'metrics.json', which genie-gl did not write" in capsys.readouterr().err
    assert (mine / "metrics.json").read_text() == "{}"


def test_the_commands_names_are_the_harness_names():
    """`genie eval --help` lists the models and presets without importing them: the same names."""
    assert command.MODELS == MODELS and command.PRESETS == PRESETS
