"""genie eval's bad options and bad dataset files: one line naming the option or the file and
what was expected, before any training; an option of another way of running it refused, never
ignored; a seed given twice refused (it would show a spread of 0)."""

from pathlib import Path

import numpy as np
import pytest

from tests.eval.toy import make_set

from .common import cli, fault, refused

OPTION = fault("bad option", "traceback")
WRONG = fault("bad option", "wrong")
BAD = fault("bad file", "traceback")


def _truncate(path: Path, keep: int) -> None:
    path.write_bytes(path.read_bytes()[:keep])


@pytest.fixture(scope="module")
def sets(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("eval-sets")
    out = {
        "tr": make_set(d / "tr", scenes=2, seed=0, points=600),
        "te": make_set(d / "te", scenes=1, seed=1, points=600),
    }
    out["badbin"] = make_set(d / "badbin", scenes=1, seed=2, points=600)
    f = next(out["badbin"].glob("sequences/*/velodyne/*.bin"))
    _truncate(f, f.stat().st_size - 5)
    out["badlabel"] = make_set(d / "badlabel", scenes=1, seed=3, points=600)
    f = next(out["badlabel"].glob("sequences/*/labels/*.label"))
    _truncate(f, f.stat().st_size - 8)
    out["nan"] = make_set(d / "nan", scenes=1, seed=4, points=600)
    f = next(out["nan"].glob("sequences/*/velodyne/*.bin"))
    a = np.fromfile(f, "<f4")
    a[4:8] = np.nan  # the second point
    a.tofile(f)
    out["badply"] = make_set(d / "badply", scenes=1, seed=5, fmt="ply", points=600)
    _truncate(next(out["badply"].glob("scenes/*/*.ply")), 100)
    out["badyaml"] = make_set(d / "badyaml", scenes=1, seed=6, points=600)
    (out["badyaml"] / "genie-gl.yaml").write_text("labels: [\n")
    (d / "empty").mkdir()
    out["empty"] = d / "empty"
    out["dir"] = d
    return out


TT = ["--train", "{tr}", "--test", "{te}"]
CASES = [
    (OPTION, TT + ["--workers", "0"], ["--workers", "expected a whole number in 1..1024, got 0"]),
    (OPTION, TT + ["--seeds", "1.5"], ["--seeds", "got 1.5"]),
    (WRONG, TT + ["--seeds", "0,0,1"], ["--seeds 0,0,1", "seed 0 given more than once"]),
    (WRONG, TT + ["--scenes", "3"], ["--scenes", "it is for --study"]),
    (WRONG, TT + ["--target-train", "{tr}"], ["--target-train", "it is for --preset"]),
    (WRONG, TT + ["--yes"], ["--yes", "it is for --study"]),
    (WRONG, ["--study", "sensor", "--train", "{tr}"], ["--train: not used by genie eval --study"]),
    (
        WRONG,
        [
            "--preset",
            "mix",
            "--target-train",
            "{tr}",
            "--target-test",
            "{te}",
            "--train",
            "{tr}",
            "--test",
            "{te}",
        ],
        ["--test: not used by genie eval --preset"],
    ),
    (
        WRONG,
        ["--bench", "--train", "{tr}", "--model", "height"],
        ["--model: not used by genie eval --bench"],
    ),
    (WRONG, TT + ["--label-map", "{dir}/none.yaml"], ["--label-map", "none.yaml: no such file"]),
    (OPTION, TT + ["--model", "clasical"], ["did you mean 'classical'"]),
    (
        OPTION,
        ["--train", "{tr}:trian", "--test", "{te}"],
        [":trian", "expected train, valid, test"],
    ),
    (OPTION, ["--train", "{dir}/none", "--test", "{te}"], ["none: no such dataset folder"]),
    (BAD, ["--train", "{empty}", "--test", "{te}"], ["empty: not a dataset genie eval reads"]),
    (
        BAD,
        ["--train", "{badbin}", "--test", "{te}"],
        ["000000.bin", "not a whole number of (x, y, z, remission)"],
    ),
    (BAD, ["--train", "{badlabel}", "--test", "{te}"], ["000000.label", "labels for"]),
    (
        BAD,
        ["--train", "{nan}", "--test", "{te}"],
        ["000000.bin", "1 of", "not finite", "the first is point 1"],
    ),
    (BAD, ["--train", "{badply}", "--test", "{te}"], ["cloud_000.ply"]),
    (
        BAD,
        ["--train", "{badyaml}", "--test", "{te}"],
        ["genie-gl.yaml", "cannot read the label-map yaml"],
    ),
]


@pytest.mark.parametrize(
    "mark, argv, needles",
    [pytest.param(m, a, n, marks=m, id=" ".join(a)[:60]) for m, a, n in CASES],
)
def test_a_bad_eval_option_or_file_is_one_line_before_training(mark, argv, needles, sets, tmp_path):
    args = [a.format(**{k: str(v) for k, v in sets.items()}) for a in argv]
    run = cli("eval", "--no-progress", *args, "--out", tmp_path / "o", timeout=60)
    refused(run, *needles)
    assert run.seconds < 30
    assert not (tmp_path / "o" / "metrics.json").exists()
