"""A failed ``genie dataset`` that finished no scene leaves nothing it wrote (there is nothing to
resume from): the folder it made is gone, a folder of the user's keeps their files and nothing
else. The scene is made for real; writing its layout, after its files, is made to fail."""

import pytest

from genie_gl.cli import main
from genie_gl.errors import ConfigError
from genie_gl.layout.model import Layout
from tests.test_file_safety import ONE_SCENE, assert_intact, plant

pytestmark = pytest.mark.gl


def _fail_in_the_scene(monkeypatch, exc: BaseException) -> list:
    """Writing a scene's layout (into its temporary folder, after its files) raises."""
    seen = []
    real = Layout.to_json

    def to_json(self, path, *a, **k):
        if path.parent.name.startswith(".tmp-"):
            seen.append(sorted(p.name for p in path.parent.rglob("*")))
            raise exc
        return real(self, path, *a, **k)

    monkeypatch.setattr(Layout, "to_json", to_json)
    return seen


def test_a_failed_first_scene_removes_the_folder_it_made(tmp_path, capsys, monkeypatch):
    out = tmp_path / "ds"
    seen = _fail_in_the_scene(monkeypatch, ConfigError("the scene failed"))
    assert main(["dataset", *ONE_SCENE, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == "genie dataset: error: the scene failed"
    assert sum("error" in line for line in err) == 1
    assert seen and seen[0]  # midway: the scene's files were written
    assert not out.exists()


def test_an_interrupted_first_scene_keeps_only_the_users_files(tmp_path, monkeypatch):
    planted = plant(tmp_path)
    seen = _fail_in_the_scene(monkeypatch, KeyboardInterrupt())
    assert main(["dataset", *ONE_SCENE, "--out", str(tmp_path)]) == 130
    assert seen and seen[0]
    assert_intact(tmp_path, planted)
    left = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*") if p.is_file())
    assert left == sorted(planted)
