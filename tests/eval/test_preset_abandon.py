"""A failed ``genie eval --preset`` leaves nothing it wrote but its cache of features (finished
work the next run reuses, recorded in the manifest): the evaluations it finished before the
failure go, the user's files stay (genie_gl/outputs.py ``OutputFolder.abandoning``). The
evaluations run for real on toy sets (a short training); the second is interrupted."""

import json

import pytest

import genie_gl.commands.eval as eval_command
from genie_gl.cli import main
from genie_gl.eval import protocols
from genie_gl.eval.classical import BoostParams
from tests.eval.toy import make_set
from tests.test_file_safety import assert_intact, plant


@pytest.fixture(scope="module")
def sets(tmp_path_factory):
    root = tmp_path_factory.mktemp("preset")
    return {
        "real": make_set(root / "real", scenes=1, seed=10, points=2000),
        "test": make_set(root / "test", scenes=1, seed=11, points=2000),
        "syn": make_set(root / "syn", scenes=2, seed=12, points=2000),
    }


def test_an_interrupted_finetune_keeps_only_the_users_files_and_its_cache(
    tmp_path, sets, monkeypatch
):
    planted = plant(tmp_path)
    done: list[str] = []
    evaluate = protocols.evaluate

    def second_interrupted(*a, out, **k):
        if len(done) == 1:  # target_only is written by now
            assert (tmp_path / "target_only" / "metrics.json").is_file()
            raise KeyboardInterrupt
        done.append(out.name)
        return evaluate(*a, out=out, **k)

    monkeypatch.setattr(protocols, "evaluate", second_interrupted)
    fast = BoostParams(max_points=10_000, rounds=20, early_stop=5)
    monkeypatch.setattr(eval_command, "_params", lambda *_a: fast)
    argv = ["eval", "--preset", "finetune", "--target-train", str(sets["real"])]
    argv += ["--target-test", str(sets["test"]), "--train", str(sets["syn"])]
    argv += ["--seeds", "0", "--no-progress", "--out", str(tmp_path)]
    assert main(argv) == 130
    assert done == ["target_only"]
    assert_intact(tmp_path, planted)
    ours = {p.relative_to(tmp_path).parts[0] for p in tmp_path.rglob("*") if p.is_file()}
    assert ours - {r.split("/")[0] for r in planted} == {"cache", "manifest.json"}
    m = json.loads((tmp_path / "manifest.json").read_text())
    assert m["command"] == "eval-preset" and m["outputs"] == ["cache"]
