"""``genie scan`` and ``gg.export_scans``: a bad scanner file is one line and writes nothing;
a short walk of the wearable comes out as a SemanticKITTI dataset per head and a ROS bag."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

import genie_gl as gg
from genie_gl.capture import scanning
from genie_gl.resources import data_dir

ROOT = Path(__file__).resolve().parents[2]


def genie(*args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "genie_gl.cli", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"},
        timeout=600,
    )


@pytest.mark.parametrize(
    "change, field",
    [
        ({"elevation_deg": [float("nan")] * 16}, "elevation_deg[0]"),
        ({"channel_time_us": [0.0, 3.0, 2.0] + [4.0] * 13}, "channel_time_us[2]"),
    ],
)
# (every mistake of the list is refused by the loader: tests/sensors/test_scanner.py)
def test_a_bad_scanner_file_on_the_command_line_is_one_line_and_nothing_is_written(
    tmp_path, change, field
):
    data = yaml.safe_load((data_dir("sensors") / "velodyne_vlp16.lidar.yml").read_text())
    data.update(change)
    bad = tmp_path / "bad.lidar.yml"
    bad.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    r = genie(
        "scan",
        "storage_area",
        "--scanner",
        str(bad),
        "--out",
        str(out),
        "--no-progress",
        cwd=tmp_path,
    )
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and str(bad) in lines[0] and field in lines[0], r.stderr
    assert not out.exists()


def test_a_walk_of_the_wearable_as_kitti_sequences_and_a_bag(tmp_path, monkeypatch):
    layout = gg.generate_layout("storage_area", seed=1)
    scene = gg.build_scene(layout, seed=1)
    path = gg.make_trajectory(layout, scene, "aisles", seed=1, motion="person", duration_s=1.0)
    rig = gg.load_scanner_rig("navvis_wearable")
    scans = gg.scan(scene, rig, path, seed=1, duration_s=0.35)
    assert [s.head for s in scans] == ["top"] * 3 + ["vertical"] * 3
    files = gg.export_scans(scans, tmp_path / "kitti", format="kitti")
    assert len(files) == 6
    for k in (0, 1):
        seq = tmp_path / "kitti" / "sequences" / f"{k:02d}"
        assert len(np.loadtxt(seq / "poses.txt").reshape(-1, 12)) == 3
        scan = np.fromfile(seq / "velodyne" / "000000.bin", "<f4").reshape(-1, 4)
        assert len(scan) == len(scans[3 * k]) and 0 < scan[:, 3].max() <= 1.0
    bag = gg.export_scans(scans, tmp_path / "ros", format="rosbag")[0]
    assert (bag / "metadata.yaml").exists()
    # the same seed makes the same scans, in the same order, with 1 worker or 2 forked ones
    # (the profiles' effects on: footprint sub-rays, range noise from each scan's own stream)
    forked = []
    in_workers = scanning._in_workers
    monkeypatch.setattr(
        scanning, "_in_workers", lambda make, jobs, w: forked.append(w) or in_workers(make, jobs, w)
    )
    again = gg.scan(scene, rig, path, seed=1, duration_s=0.35, workers=2)
    assert forked == [2]  # the 5 scans after the first were made by the forked workers
    assert [(s.head, s.index) for s in again] == [(s.head, s.index) for s in scans]
    fields = ("world_xyz", "sensor_xyz", "range_m", "intensity", "ring", "time_s", "instance",
              "semantic", "return_number", "returns", "firing_poses")  # fmt: skip
    for a, b in zip(scans, again, strict=True):
        for f in fields:
            assert getattr(a, f).tobytes() == getattr(b, f).tobytes(), f
    with pytest.raises(gg.ConfigError, match="workers must be at least 1"):
        gg.scan(scene, rig, path, seed=1, duration_s=0.35, workers=0)


def test_a_scan_worker_that_dies_is_one_error(monkeypatch):
    """A worker process that dies making a scan (here: it exits at once) stops the call with
    one error naming what happened, not a hang or a traceback from the pool."""
    import os

    layout = gg.generate_layout("storage_area", seed=1)
    scene = gg.build_scene(layout, seed=1)
    path = gg.make_trajectory(layout, scene, "aisles", seed=1, motion="person", duration_s=1.0)
    rig = gg.load_scanner_rig("navvis_wearable")
    parent, take_scan = os.getpid(), scanning.take_scan

    def die_in_a_worker(*args, **kwargs):  # inherited by the forked workers
        if os.getpid() != parent:
            os._exit(3)
        return take_scan(*args, **kwargs)

    monkeypatch.setattr(scanning, "take_scan", die_in_a_worker)
    with pytest.raises(gg.ConfigError, match="a worker process died making the scans"):
        gg.scan(scene, rig, path, seed=1, duration_s=0.35, workers=2)
