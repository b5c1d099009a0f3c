"""Runs that never lose work: killed at random moments they resume to the bytes of an
uninterrupted run (SemanticKITTI and BOP); a folder of other inputs, a second run into the
same folder and damaged scenes are each handled."""

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from genie_gl.cli import main
from tests.dataset.test_dataset import assert_scenes_are_what_the_public_api_makes

pytestmark = pytest.mark.gl
ARGS = [
    "assembly_line",
    "--cameras",
    "2",
    "--sensor",
    "ideal_pinhole",
    "--points",
    "3000",
    "--min-points",
    "500",
    "--no-progress",
    "--previews",
    "1",
    "--scenes",
    "2",
    "--workers",
    "1",
]


def digest(root: Path) -> dict[str, str]:
    """Hash of every file but the manifest (it holds timings): computed here, not by genie-gl."""
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file() and p.name != "manifest.json"
    }


def cli(*extra: str) -> list[str]:
    return [sys.executable, "-m", "genie_gl.cli", "dataset", *ARGS, *extra]


@pytest.fixture(scope="module")
def references(tmp_path_factory):
    """Uninterrupted runs, one per format, made on first use: (folder, wall seconds)."""
    made = {}

    def get(fmt):
        if fmt not in made:
            out = tmp_path_factory.mktemp(f"ref-{fmt}")
            t = time.perf_counter()
            assert main(["dataset", *ARGS, "--format", fmt, "--out", str(out)]) == 0
            made[fmt] = (out, time.perf_counter() - t)
        return made[fmt]

    return get


@pytest.fixture
def reference(references):
    return ("semantickitti", *references("semantickitti"))


def loadable_as_bop_toolkit_lists_it(root: Path) -> None:
    """Every scene bop_toolkit would list (glob("*"), which skips the hidden .tmp-* folders) is
    whole and its objects' models are there: a killed run leaves a loadable dataset."""
    import glob

    for scene in sorted(glob.glob(str(root / "train_pbr" / "*"))):
        gt = json.loads((Path(scene) / "scene_gt.json").read_text())
        json.loads((Path(scene) / "scene_camera.json").read_text())
        assert (root / "camera.json").exists()
        info = json.loads((root / "models" / "models_info.json").read_text())
        for objs in gt.values():
            for g in objs:
                assert (
                    str(g["obj_id"]) in info
                    and (root / "models" / f"obj_{g['obj_id']:06d}.ply").exists()
                )


@pytest.mark.parametrize("fmt", ["semantickitti", "bop"])
def test_killed_at_random_moments_resumes_to_the_same_bytes(references, fmt, tmp_path):
    ref, wall = references(fmt)
    rng = np.random.default_rng(7)
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).parent.parent.parent))
    kills = 0
    # random moments within the run (the child also spends >= 1 s importing); should both land
    # after it finished, the folder is emptied and the run killed early: a kill is always tested
    for attempt, delay in enumerate([*(1.0 + rng.uniform(0.1, 0.8, 2) * wall), 1.0, 1.0]):
        if attempt >= 2:
            if kills:
                break
            shutil.rmtree(tmp_path)
            tmp_path.mkdir()
        proc = subprocess.Popen(
            cli("--format", fmt, "--out", str(tmp_path)),
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        try:
            proc.wait(timeout=delay)
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGKILL)
            proc.wait()
            kills += 1
            if fmt == "bop":
                loadable_as_bop_toolkit_lists_it(tmp_path)
    assert kills >= 1, "the run finished before any kill: nothing was tested"
    assert main(["dataset", *ARGS, "--format", fmt, "--out", str(tmp_path)]) == 0
    assert digest(tmp_path) == digest(ref)
    if (
        fmt == "semantickitti"
    ):  # and the bytes are right, not only the same: the public API's scenes
        assert_scenes_are_what_the_public_api_makes(tmp_path, points=(500, 3000))
    m = json.loads((tmp_path / "manifest.json").read_text())
    assert (
        len(m["runs"]) >= 1 and m["runs"][-1]["scenes_made"] + m["runs"][-1]["scenes_skipped"] == 2
    )


def test_damaged_scene_is_made_again_and_timings_are_appended(reference, tmp_path):
    fmt, ref, _ = reference
    import shutil

    shutil.copytree(ref, tmp_path / "d")
    out = tmp_path / "d"
    victim = next((out / "scenes" / "0001").rglob("*.bin"))
    victim.write_bytes(victim.read_bytes()[:-16])  # truncated
    (out / "scenes" / "0000" / "layout.json").unlink()  # missing
    assert main(["dataset", *ARGS, "--out", str(out)]) == 0
    assert digest(out) == digest(ref)
    m = json.loads((out / "manifest.json").read_text())
    assert [r["scenes_made"] for r in m["runs"]] == [2, 2]
    assert (
        main(["dataset", *ARGS, "--out", str(out)]) == 0
    )  # nothing to redo: appended, not overwritten
    assert [r["scenes_made"] for r in json.loads((out / "manifest.json").read_text())["runs"]] == [
        2,
        2,
        0,
    ]


@pytest.mark.parametrize(
    "change, what",
    [
        (["--seed", "1"], "seed 0 -> 1"),
        (["--points", "2000"], "points"),
        (["--sensor", "kinect_v2"], "sensor profile"),
    ],
)
def test_resume_into_a_folder_of_other_inputs_is_refused(reference, tmp_path, capsys, change, what):
    fmt, ref, _ = reference
    import shutil

    shutil.copytree(ref, tmp_path / "d")
    before = digest(tmp_path / "d")
    assert main(["dataset", *ARGS, *change, "--out", str(tmp_path / "d")]) == 2
    err = capsys.readouterr().err.strip()
    assert "made from other inputs" in err and what in err and len(err.splitlines()) == 1
    assert digest(tmp_path / "d") == before


def test_a_second_run_into_the_same_folder_is_refused_while_the_first_holds_it(tmp_path, capsys):
    from genie_gl.dataset.manifest import OutputLock

    tmp_path.mkdir(exist_ok=True)
    held = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import fcntl, sys, time; f = open(sys.argv[1], 'a+'); "
            "f.write('pid 1 test'); f.flush(); fcntl.flock(f, fcntl.LOCK_EX); print('held', "
            "flush=True); "
            "time.sleep(60)",
            str(tmp_path / ".genie-lock"),
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert held.stdout.readline().strip() == "held"
        assert main(["dataset", *ARGS, "--out", str(tmp_path)]) == 2
        err = capsys.readouterr().err
        assert "another genie dataset run" in err and len(err.strip().splitlines()) == 1
    finally:
        held.kill()
        held.wait()
    with OutputLock(tmp_path):  # the holder died: its lock is stale and taken over
        assert (tmp_path / ".genie-lock").read_text().startswith(f"pid {os.getpid()}")
    assert not (tmp_path / ".genie-lock").exists()  # released on exit
