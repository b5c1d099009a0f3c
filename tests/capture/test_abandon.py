"""A failed ``genie capture`` leaves nothing it wrote: the folder it made is gone, a folder of
the user's keeps their files and nothing else (genie_gl/outputs.py,
``OutputFolder.abandoning``). The scene is rendered for real; only the last export stage
(the label map, written after the scan files) is made to fail."""

from pathlib import Path

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.export import semantickitti as skitti
from genie_gl.cli import main
from genie_gl.errors import ExportError
from tests.test_file_safety import assert_intact, plant


@pytest.fixture(scope="module")
def box_scene(tmp_path_factory) -> Path:
    s = gg.Scene()
    t = np.eye(4)
    t[:3, 3] = (0.0, 0.0, 0.5)
    s.add(trimesh.creation.box((4, 4, 1)), t, semantic=2)
    s.add(trimesh.creation.box((20, 20, 0.02)), np.eye(4), semantic=0)
    return gg.write_usd(s, tmp_path_factory.mktemp("scene") / "s.usda")


def _capture(scene: Path, out: Path) -> list[str]:
    return [
        "capture",
        str(scene),
        "--cameras",
        "1",
        "--format",
        "semantickitti",
        "--out",
        str(out),
        "--no-progress",
    ]


def _fail_after_the_scans(monkeypatch, exc: BaseException) -> list[Path]:
    """The label map raises; returns where the scan files were when it did."""
    seen: list[Path] = []
    orig = skitti._write_scan

    def scan_then_note(cloud, seq, frame):
        seen.append(orig(cloud, seq, frame))
        return seen[-1]

    def fail(*_a, **_k):
        assert seen and seen[-1].is_file()  # the run failed midway: its scan is written
        raise exc

    monkeypatch.setattr(skitti, "_write_scan", scan_then_note)
    monkeypatch.setattr(skitti, "label_map_yaml", fail)
    return seen


@pytest.mark.gl
def test_a_failed_capture_removes_the_folder_it_made(tmp_path, capsys, monkeypatch, box_scene):
    out = tmp_path / "run"
    seen = _fail_after_the_scans(monkeypatch, ExportError("the label map failed"))
    assert main(_capture(box_scene, out)) == 2
    err = capsys.readouterr().err.strip().splitlines()  # a first run may tell of compiling
    assert err[-1] == "genie capture: error: the label map failed"
    assert sum("error" in line for line in err) == 1
    assert seen and not out.exists()


@pytest.mark.gl
def test_an_interrupted_capture_keeps_only_the_users_files(tmp_path, monkeypatch, box_scene):
    planted = plant(tmp_path)
    seen = _fail_after_the_scans(monkeypatch, KeyboardInterrupt())
    assert main(_capture(box_scene, tmp_path)) == 130
    assert seen
    assert_intact(tmp_path, planted)
    left = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*") if p.is_file())
    assert left == sorted(planted)  # no sequences/, no manifest.json
