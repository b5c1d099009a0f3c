"""A failed ``genie scene`` leaves nothing it wrote: the USD it had written before its overview
failed is gone, and so are the folders it made for it; the user's files stay."""

import pytest

import genie_gl as gg
import genie_gl.commands.scene as scene_command
from genie_gl.cli import main
from genie_gl.errors import ConfigError
from tests.test_file_safety import assert_intact, plant


@pytest.fixture(scope="module")
def layout(tmp_path_factory):
    path = tmp_path_factory.mktemp("layout") / "layout.json"
    gg.generate_layout("assembly_line", seed=0).to_json(path)
    return path


def _fail_at_the_overview(monkeypatch, exc: BaseException, usd) -> None:
    def fail(scene, layout, out):
        assert out == usd and usd.is_file()  # midway: the scene file is written
        raise exc

    monkeypatch.setattr(scene_command, "_overview", fail)


def test_a_failed_overview_removes_the_scene_and_the_folders_made(
    tmp_path, layout, capsys, monkeypatch
):
    usd = tmp_path / "new" / "deep" / "s.usda"
    _fail_at_the_overview(monkeypatch, ConfigError("the overview failed"), usd)
    assert main(["scene", str(layout), "--out", str(usd), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == "genie scene: error: the overview failed"
    assert sum("error" in line for line in err) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_an_interrupted_scene_keeps_only_the_users_files(tmp_path, layout, monkeypatch):
    planted = plant(tmp_path)
    usd = tmp_path / "s.usda"
    _fail_at_the_overview(monkeypatch, KeyboardInterrupt(), usd)
    assert main(["scene", str(layout), "--out", str(usd), "--no-progress"]) == 130
    assert_intact(tmp_path, planted)
    left = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*") if p.is_file())
    assert left == sorted(planted)
