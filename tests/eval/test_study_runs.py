"""A study's bookkeeping: a training kept under OUT/runs is reused only for the same datasets, and
a study's reproduce line names the sizes it ran with."""

import json
from pathlib import Path

from genie_gl.studies.report import _header
from genie_gl.studies.runner import Context, _plan, _done


def _context(out: Path, scenes: int, test_scenes: int = 4) -> Context:
    return Context(out, out / "cache", (0, 1, 2), scenes, test_scenes, 16, 1, False)


def _write_metrics(path: Path, c: Context, t) -> None:
    path.mkdir(parents=True)
    metrics = {
        "model": t.model,
        "seeds": list(c.seeds),
        "train": [str(d.folder(c.cache)) for d in t.train],
        "tests": [{"spec": str(d.folder(c.cache))} for d in t.test],
    }
    (path / "metrics.json").write_text(json.dumps(metrics))


def test_a_training_of_another_size_is_not_reused(tmp_path):
    small = _context(tmp_path, 5, 2)
    t = _plan("accuracy", small)[0]
    _write_metrics(tmp_path / "runs" / t.name, small, t)
    assert _done(t, small)
    for other in (_context(tmp_path, 10, 4), _context(tmp_path, 5, 3)):  # 5, 3: other tests only
        t_other = next(x for x in _plan("accuracy", other) if x.name == t.name)
        assert not _done(t_other, other)


def test_the_reproduce_line_names_sizes_that_are_not_the_defaults(tmp_path):
    cmd = "genie eval --study accuracy --out out/studies --yes"
    assert f"Reproduce: `{cmd}`" in _header("t", _context(tmp_path, 10, 4), cmd)
    small = _header("t", _context(tmp_path, 5, 2), cmd)
    want = "genie eval --study accuracy --scenes 5 --test-scenes 2 --out out/studies --yes"
    assert f"Reproduce: `{want}`" in small
