"""``genie dataset --capture trajectory|mobile-map``: the same bytes with 1 and 2 workers and
on a resumed run, the formats each capture takes, mobile-map chunks of 25 000 points and a
class-balanced mobile-map run reaching its target."""

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from genie_gl.cli import main
from genie_gl.dataset import DatasetConfig, run_dataset
from genie_gl.dataset.modes import get_mode
from genie_gl.errors import ConfigError

pytestmark = pytest.mark.gl


def files(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file() and p.name != "manifest.json" and "previews" not in p.parts
    }


def cfg(out, **kw):
    base = dict(
        strategy="storage_area",
        scenes=2,
        sensor="ideal_pinhole",
        capture="trajectory",
        duration_s=1.5,
        format="semantickitti",
        out=str(out),
        workers=1,
        seed=4,
        previews=0,
    )
    return DatasetConfig.parse(base | kw)


def test_a_trajectory_dataset_is_the_same_with_one_and_two_workers_and_resumes(tmp_path):
    run_dataset(cfg(tmp_path / "a"), progress=False)
    run_dataset(cfg(tmp_path / "b", workers=2), progress=False)
    a, b = files(tmp_path / "a"), files(tmp_path / "b")
    assert a == b
    assert {
        "sequences/00/poses.txt",
        "sequences/01/poses.txt",
        "scenes/0001/trajectory.txt",
        "scenes/0000/00/world_pose.txt",
    } <= set(a)
    poses = np.loadtxt(tmp_path / "a" / "sequences" / "00" / "poses.txt")
    assert poses.shape == (16, 12)
    m = json.loads((tmp_path / "a" / "manifest.json").read_text())
    assert m["fingerprint"]["parts"]["capture"] == "trajectory" and m["sequences"] == {
        "00": [0],
        "01": [1],
    }
    # a scene lost is made again, the same bytes
    import shutil

    shutil.rmtree(tmp_path / "a" / "scenes" / "0001")
    made = run_dataset(cfg(tmp_path / "a"), progress=False)
    assert made["scenes_made"] == 1 and files(tmp_path / "a") == b
    with pytest.raises(ConfigError, match="other inputs.*duration_s"):
        run_dataset(cfg(tmp_path / "a", duration_s=2.0), progress=False)


def test_each_format_names_the_captures_it_takes(tmp_path, capsys):
    with pytest.raises(ConfigError, match="--format tum takes --capture trajectory, not static"):
        cfg(tmp_path, capture="static", format="tum")
    with pytest.raises(
        ConfigError,
        match="--format ply takes --capture static or mobile-map or scans or scan-map, "
        "not trajectory; "
        "--capture trajectory writes e57, rosbag, semantickitti, tum",
    ):
        cfg(tmp_path, format="ply")
    assert (
        main(
            [
                "dataset",
                "storage_area",
                "--capture",
                "trajectory",
                "--path",
                "nowhere.txt",
                "--out",
                str(tmp_path / "x"),
            ]
        )
        == 2
    )
    assert (
        "--path 'nowhere.txt': expected aisles, random or a waypoints file"
        in capsys.readouterr().err
    )
    # a static run's fingerprint does not hold the moving options
    static = DatasetConfig.parse(dict(strategy="storage_area", out=str(tmp_path / "s")))
    from genie_gl.dataset.manifest import fingerprint
    from genie_gl.layout import load_strategy
    from genie_gl.effects.profile import load_sensor

    parts = fingerprint(static, load_strategy("storage_area"), load_sensor("realsense_d435"))[
        "parts"
    ]
    moving = {"capture", "rig", "path", "motion", "duration_s", "voxel_m", "registration"}
    assert not moving & set(parts) and {"cameras", "format", "seed"} <= set(parts)


def test_mobile_map_chunks_hold_25000_points_and_show_the_real_shares(tmp_path):
    from genie_gl.export.las import read

    out = tmp_path / "m"
    run_dataset(
        cfg(out, scenes=1, capture="mobile-map", format="las", duration_s=6.0, voxel_m=0.03),
        progress=False,
    )
    chunks = sorted((out / "scenes" / "0000").glob("cloud_*.las"))
    sizes = [len(read(p)) for p in chunks]
    assert sizes and max(sizes) == 25000 and sum(s == 25000 for s in sizes) >= 1
    text = (out / "histogram.txt").read_text()
    assert (
        "real" in text.splitlines()[0] and " 81.49%" in text
    )  # background: 998 260 of 1 224 995 points


def test_a_class_balanced_mobile_map_reaches_its_target(tmp_path):
    out = tmp_path / "bal"
    run_dataset(
        cfg(
            out,
            scenes=2,
            capture="mobile-map",
            format="npz",
            duration_s=8.0,
            voxel_m=0.03,
            path="random",
            class_balance="paper-real",
            min_points=500,
        ),
        progress=False,
    )
    hist = json.loads((out / "histogram.json").read_text())
    m = json.loads((out / "manifest.json").read_text())
    total = sum(hist.values())
    target = {int(k): v for k, v in m["inputs"]["class_balance"]["target"].items()}
    from genie_gl import labels

    # the classes this hall holds none of are named short; the others share the rest as asked
    short = set(m["class_balance"]["short"])
    assert short == {"car", "jack", "dolly", "forklift"}
    rest = sum(v for k, v in target.items() if labels.name(k) not in short)
    for k, share in target.items():
        if labels.name(k) not in short:
            assert hist.get(labels.name(k), 0) / total == pytest.approx(share / rest, abs=0.002), (
                labels.name(k)
            )


def test_a_rigs_files_are_in_the_fingerprint(tmp_path):
    """With --rig, the rig file and each of its sensors' profile and calibration files are
    inputs of the run (a changed one is refused on resume)."""
    c = cfg(tmp_path, rig="d435_quad")
    read = get_mode(c.capture).input_files(c)
    assert Path(read["rig"]).name == "d435_quad.yaml"
    for name in ("front", "left", "back", "right"):
        assert Path(read[f"rig {name} profile"]).name == "realsense_d435.yaml"
        assert Path(read[f"rig {name} calibration"]).is_file()


def test_the_manifest_counts_the_cost_and_effects_of_every_frame_of_a_recording(tmp_path):
    """``cost`` and ``effects`` sum every frame of the recording (16 shots of a D435 at 10 Hz
    over 1.5 s), not a preview of it: each effect is decided on every frame."""
    made = run_dataset(
        cfg(tmp_path / "d", scenes=1, sensor="realsense_d435", previews=1), progress=False
    )
    m = json.loads((tmp_path / "d" / "manifest.json").read_text())
    assert made["scenes_made"] == 1 and np.loadtxt(
        tmp_path / "d" / "sequences" / "00" / "poses.txt"
    ).shape == (16, 12)
    assert m["effects"] and all(e["run"] + e["skipped"] == 16 for e in m["effects"].values())
    assert m["cost"]["frames"] == 16 and m["cost"]["capture"]["render"]["total_ms"] > 0


def test_a_recordings_frames_are_counted_once_rendered(tmp_path):
    """The recording is rendered as the writer reads it: its frames are counted once the
    writer has read them all (the scene's record said 0 shots), and the time the writer waited
    for them is the capture stage's (it was stamped before the first frame)."""
    run_dataset(cfg(tmp_path / "t", scenes=1, duration_s=0.5), progress=False)
    m = json.loads((tmp_path / "t" / "manifest.json").read_text())
    stages = m["runs"][-1]["scene_s"][0]["stages"]
    assert stages["capture"] > 0 and stages["cloud"] == 0.0
    stats = json.loads((tmp_path / "t" / "scenes" / "0000" / "stats.json").read_text())
    assert stats["trajectory"]["shots"] == stats["cameras"] == m["cost"]["frames"] > 0
