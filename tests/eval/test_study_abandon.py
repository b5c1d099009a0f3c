"""A failed ``genie eval --study`` leaves nothing it wrote: the folder it made is gone, a folder
of the user's keeps their files and gets no manifest, an unfinished training leaves no folder
(genie_gl/outputs.py ``OutputFolder.abandoning``, genie_gl/studies/runner.py). The stages that
would take minutes (timing the effects, making the datasets) are the ones made to fail or
replaced; everything the study writes is written for real."""

import errno
import json

import genie_gl.studies.runner as runner
from genie_gl.cli import main
from tests.test_file_safety import assert_intact, plant


def _files(folder) -> list[str]:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())


def _costs(out) -> list[str]:
    return [
        "eval",
        "--study",
        "costs",
        "--cameras",
        "1",
        "--yes",
        "--no-progress",
        "--out",
        str(out),
    ]


def _timed(*_a, **_k) -> dict:
    """What the timing stage returns (its own tests time the effects for real)."""
    return {
        "profile": "p",
        "strategy": "s",
        "seed": 0,
        "frames": 1,
        "repeats": 5,
        "date": "2026-11-29 06:00 UTC",
        "load_before": 1.0,
        "load_after": 1.0,
        "seconds": 1.0,
        "(ideal render)": 20.0,
        "(full profile)": 31.0,
        "effects": {},
    }


def test_a_disk_full_midway_removes_the_folder_the_study_made(tmp_path, capsys, monkeypatch):
    out = tmp_path / "study"
    write = runner.atomic_write_text

    def full_at_the_report(path, text):
        if path.name == "costs.md":
            assert (out / "costs.json").is_file()  # midway: the figures are written
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        return write(path, text)

    monkeypatch.setattr(runner, "time_effects", _timed)
    monkeypatch.setattr(runner, "atomic_write_text", full_at_the_report)
    assert main(_costs(out)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "No space left on device" in err[0], err
    assert not out.exists()


def test_an_interrupted_study_leaves_the_users_folder_as_it_was(tmp_path, monkeypatch):
    planted = plant(tmp_path)

    def interrupt(*_a, **_k):
        assert (tmp_path / "manifest.json").is_file()  # the run had begun writing
        raise KeyboardInterrupt

    monkeypatch.setattr(runner, "time_effects", interrupt)
    assert main(_costs(tmp_path)) == 130
    assert_intact(tmp_path, planted)
    assert _files(tmp_path) == sorted(planted)


def test_a_users_report_is_refused_before_anything_is_written(tmp_path, capsys):
    planted = plant(tmp_path)
    (tmp_path / "costs.md").write_text("mine")
    assert main(_costs(tmp_path)) == 2
    assert "costs.md" in capsys.readouterr().err
    assert_intact(tmp_path, planted)
    assert _files(tmp_path) == sorted([*planted, "costs.md"])  # no manifest.json


def test_an_interrupted_training_leaves_no_unfinished_run(tmp_path, monkeypatch):
    """Interrupted while a training makes its datasets: its runs/ folder (and its mark of the
    process that trains) goes, the user's files stay, nothing else is left."""
    planted = plant(tmp_path)
    begun = []

    def interrupt(spec, cache, **_k):
        begun.extend(p for p in (tmp_path / "runs").iterdir() if (p / ".training-pid").is_file())
        raise KeyboardInterrupt

    monkeypatch.setattr(runner.ds, "ensure", interrupt)
    argv = ["eval", "--study", "strategy", "--yes", "--no-progress", "--out", str(tmp_path)]
    assert main(argv) == 130
    assert len(begun) == 1  # a training had begun: its folder, its mark
    assert_intact(tmp_path, planted)
    assert _files(tmp_path) == sorted(planted)
    assert not (tmp_path / "runs").exists()


def test_a_finished_study_is_kept_when_the_next_one_fails(tmp_path, monkeypatch):
    """Two runs into one folder: the second, failing, removes what it wrote, not the first's."""
    monkeypatch.setattr(runner, "time_effects", _timed)
    assert main(_costs(tmp_path)) == 0
    first = (tmp_path / "costs.md").read_text()

    def interrupt(*_a, **_k):
        raise KeyboardInterrupt

    monkeypatch.setattr(runner.ds, "ensure", interrupt)
    argv = ["eval", "--study", "strategy", "--yes", "--no-progress", "--out", str(tmp_path)]
    assert main(argv) == 130
    assert (tmp_path / "costs.md").read_text() == first
    m = json.loads((tmp_path / "manifest.json").read_text())
    assert m["study"] == "costs" and m["outputs"] == ["costs.json", "costs.md"]
    assert _files(tmp_path) == ["costs.json", "costs.md", "manifest.json"]
