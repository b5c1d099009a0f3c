"""A failed ``genie bench`` leaves nothing it wrote: the folder it made is gone, a folder of
the user's keeps their files and gets no manifest (genie_gl/outputs.py,
``OutputFolder.abandoning``)."""

import genie_gl.bench.accuracy
from genie_gl.cli import main
from tests.test_file_safety import assert_intact, plant


def _files(folder) -> list[str]:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())


def test_a_bad_option_found_by_the_benchmark_removes_the_folder_it_made(tmp_path, capsys):
    """--knobs is read by the benchmark itself, after its folder is claimed (and made)."""
    out = tmp_path / "bench"
    assert main(["bench", "accuracy", "--knobs", "bogus", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("genie bench: error: --knobs: unknown bogus"), err
    assert not out.exists()


def test_a_bad_option_leaves_the_users_folder_as_it_was(tmp_path, capsys):
    planted = plant(tmp_path)
    assert main(["bench", "accuracy", "--knobs", "bogus", "--out", str(tmp_path)]) == 2
    assert_intact(tmp_path, planted)
    assert _files(tmp_path) == sorted(planted)  # no manifest.json left behind


def test_an_interrupted_benchmark_leaves_the_users_folder_as_it_was(tmp_path, monkeypatch):
    planted = plant(tmp_path)

    def interrupt(*_a, **_k):
        assert (tmp_path / "manifest.json").is_file()  # the run had begun writing
        raise KeyboardInterrupt

    monkeypatch.setattr(genie_gl.bench.accuracy, "make_case", interrupt)
    assert main(["bench", "accuracy", "--out", str(tmp_path)]) == 130
    assert_intact(tmp_path, planted)
    assert _files(tmp_path) == sorted(planted)
