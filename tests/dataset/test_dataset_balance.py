"""``genie dataset --class-balance`` / ``--points-budget``: seeded, independent of workers."""

import hashlib
import json
import shutil
from pathlib import Path

import pytest

from genie_gl.cli import main
from tests.dataset.test_dataset import assert_scenes_are_what_the_public_api_makes

pytestmark = pytest.mark.gl
ARGS = [
    "assembly_line",
    "--scenes",
    "2",
    "--cameras",
    "2",
    "--sensor",
    "ideal_pinhole",
    "--points",
    "4000",
    "--min-points",
    "200",
    "--no-progress",
    "--previews",
    "0",
    "--class-balance",
    "paper",
]


def digest(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file() and p.name != "manifest.json"
    }


def test_balanced_dataset_is_the_same_with_one_or_two_workers_and_reports_its_target(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    assert main(["dataset", *ARGS, "--workers", "1", "--out", str(a)]) == 0
    assert main(["dataset", *ARGS, "--workers", "2", "--out", str(b)]) == 0
    da = digest(a)
    assert da == digest(b) and any(k.startswith("sequences/01/velodyne/") for k in da)
    assert_scenes_are_what_the_public_api_makes(a, points=(1, 4000))  # right, not only the same
    m = json.loads((a / "manifest.json").read_text())["class_balance"]
    rows = m["classes"]
    total = sum(r["points"] for r in rows.values())
    assert total == m["points"] > 0
    # the classes not named short keep the target's proportions among themselves (the short
    # ones' missing points grow them all by one factor)
    ratios = [
        r["reached_pct"] / r["target_pct"]
        for name, r in rows.items()
        if r["target_pct"] and r["target_pct"] > 2 and name not in m["short"]
    ]
    assert len(ratios) >= 2 and max(ratios) / min(ratios) < 1.01
    assert "target" in (a / "histogram.txt").read_text().splitlines()[0]


def test_points_budget_caps_the_dataset(tmp_path):
    args = [a for a in ARGS if a not in ("--class-balance", "paper")]
    assert (
        main(
            ["dataset", *args, "--workers", "1", "--points-budget", "5000", "--out", str(tmp_path)]
        )
        == 0
    )
    points = json.loads((tmp_path / "manifest.json").read_text())["class_balance"]["points"]
    assert 4900 <= points <= 5000
    stats = [json.loads(p.read_text()) for p in sorted(tmp_path.glob("scenes/*/stats.json"))]
    assert sum(sum(s["class_points"].values()) for s in stats) == points


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--class-balance", "nowhere.json"], "cannot read the file"),
        (["--class-balance", "paper", "--format", "bop"], "point-cloud format"),
        (["--points-budget", "0"], "--points-budget 0"),
    ],
)
def test_bad_balance_input_fails_with_one_line(extra, message, tmp_path, capsys):
    args = [a for a in ARGS if a not in ("--class-balance", "paper")]
    assert main(["dataset", *args, *extra, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1


def test_balanced_dataset_resumes_from_its_caches_to_the_same_bytes(tmp_path, capsys):
    out = tmp_path / "d"
    args = ["dataset", *ARGS, "--workers", "1", "--out", str(out)]
    assert main(args) == 0
    before = digest(out)
    shutil.rmtree(out / "scenes" / "0001")  # as if killed before the balanced scene was renamed in
    assert main(args) == 0
    assert digest(out) == before
    m = json.loads((out / "manifest.json").read_text())
    # scene 1 written again from its cache, nothing rendered again
    assert (m["scenes_made"], m["scenes_skipped"]) == (1, 1) and m["runs"][-1][
        "stage_s_total"
    ] == {}
    capsys.readouterr()
    # another balance is another dataset: refused, naming the option
    assert main([*args, "--points-budget", "3000"]) == 2
    assert "points_budget" in capsys.readouterr().err
