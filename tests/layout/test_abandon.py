"""A failed ``genie layout`` leaves nothing it wrote: the folder it made is gone, a folder of
the user's keeps their files and nothing else, an earlier layout keeps what this run did not
replace (genie_gl/outputs.py, ``OutputFolder.abandoning``)."""

import json

import genie_gl.layout
from genie_gl.cli import main
from genie_gl.errors import ConfigError
from tests.faults.test_disks import PLANTED, check, needs_namespaces, on_disk
from tests.test_file_safety import assert_intact, plant


def _fail_at_the_picture(monkeypatch, exc: BaseException) -> None:
    """The picture stage raises, after layout.json and the manifest are written."""

    def fail(*_a, **_k):
        raise exc

    monkeypatch.setattr(genie_gl.layout, "save_layout_png", fail)


def test_a_failed_layout_removes_the_folder_it_made(tmp_path, capsys, monkeypatch):
    out = tmp_path / "new" / "run"
    _fail_at_the_picture(monkeypatch, ConfigError("the picture failed"))
    assert main(["layout", "assembly_line", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.splitlines() == ["genie layout: error: the picture failed"]
    assert not out.exists()


def test_an_interrupted_layout_keeps_only_the_users_files(tmp_path, monkeypatch):
    planted = plant(tmp_path)
    _fail_at_the_picture(monkeypatch, KeyboardInterrupt())
    assert main(["layout", "assembly_line", "--out", str(tmp_path)]) == 130  # 128 + SIGINT
    assert_intact(tmp_path, planted)
    left = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*") if p.is_file())
    assert left == sorted(planted)  # no layout.json, no manifest.json


def test_a_failed_rerun_removes_only_what_it_replaced(tmp_path, capsys, monkeypatch):
    planted = plant(tmp_path)
    assert main(["layout", "assembly_line", "--seed", "0", "--out", str(tmp_path)]) == 0
    png = (tmp_path / "layout.png").read_bytes()
    _fail_at_the_picture(monkeypatch, ConfigError("the picture failed"))
    assert main(["layout", "storage_area", "--seed", "1", "--out", str(tmp_path)]) == 2
    assert_intact(tmp_path, planted)
    assert not (tmp_path / "layout.json").exists()  # this run's, half a layout: gone
    assert (tmp_path / "layout.png").read_bytes() == png  # the earlier run's, untouched
    m = json.loads((tmp_path / "manifest.json").read_text())
    assert m["seed"] == 0 and m["outputs"] == ["labels.npy", "layout.png"]


@needs_namespaces
def test_a_full_disk_leaves_the_users_folder_as_it_was(tmp_path):
    """A real full disk (a tmpfs of 48 kB) stops the layout midway: the one-line error, and
    the folder holds the user's files only."""
    report = on_disk(tmp_path, "size=48k", argv=["layout", "assembly_line", "--out", "{out}"])
    check(report, "No space left on device")
    assert sorted(report["files"]) == sorted(PLANTED)
