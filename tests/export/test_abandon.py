"""A failed export (``gg.export``, ``gg.export_scans``, behind ``genie scan``) leaves nothing it
wrote: the folder it made is gone, a folder of the user's keeps their files and nothing else
(genie_gl/outputs.py ``OutputFolder.abandoning``). The files are written for real; a stage
after the first of them is made to fail."""

from dataclasses import replace

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.effects.scanner_profile import load_scanner
from genie_gl.errors import ExportError
from genie_gl.export import lidar_output
from genie_gl.export import semantickitti as skitti
from genie_gl.motion.trajectory import Trajectory, planar_poses
from tests.export.test_lidar_formats import floor_scan
from tests.test_file_safety import assert_intact, plant


def _files(folder) -> list[str]:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())


@pytest.fixture(scope="module")
def scans():
    s = replace(load_scanner("velodyne_vlp16"), effects=())
    traj = Trajectory(
        np.array([0.0, 1.0]), planar_poses(np.array([[0.0, 0.0], [2.0, 0.0]]), np.zeros(2), 1.5)
    )
    return [floor_scan(s, traj, 0.1 * k, k) for k in range(3)]


def _cloud() -> gg.PointCloud:
    xyz = np.arange(30, dtype=np.float32).reshape(10, 3)
    return gg.PointCloud(
        xyz=xyz, semantic=np.ones(10, np.uint16), instance=np.arange(10, dtype=np.uint32)
    )


@pytest.mark.parametrize("made", [True, False])
def test_an_interrupted_scan_export_leaves_only_the_users_files(tmp_path, scans, made, monkeypatch):
    out = tmp_path / "scans" if made else tmp_path
    planted = {} if made else plant(tmp_path)
    real = lidar_output.scan_cloud
    seen = []

    def second_interrupted(scan, *a, **k):
        if seen:  # the first scan's file is written by now
            assert list(out.glob(f"{scans[0].head}/*.pcd"))
            raise KeyboardInterrupt
        seen.append(scan.index)
        return real(scan, *a, **k)

    monkeypatch.setattr(lidar_output, "scan_cloud", second_interrupted)
    with pytest.raises(KeyboardInterrupt):
        gg.export_scans(scans, out, format="pcd")
    assert seen == [0]
    if made:
        assert not out.exists()
    else:
        assert_intact(tmp_path, planted)
        assert _files(tmp_path) == sorted(planted)


def test_a_failed_cloud_export_removes_the_folder_it_made(tmp_path, monkeypatch):
    out = tmp_path / "cloud"
    written = []
    real = skitti._write_scan

    def note(cloud, seq, frame):
        written.append(real(cloud, seq, frame))
        return written[-1]

    def fail(*_a, **_k):
        assert written and written[-1].is_file()  # midway: the scan is written
        raise ExportError("the label map failed")

    monkeypatch.setattr(skitti, "_write_scan", note)
    monkeypatch.setattr(skitti, "label_map_yaml", fail)
    with pytest.raises(ExportError, match="the label map failed"):
        gg.export(_cloud(), out, format="semantickitti")
    assert not out.exists()
    planted = plant(tmp_path)
    with pytest.raises(ExportError):
        gg.export(_cloud(), tmp_path, format="semantickitti")
    assert_intact(tmp_path, planted)
    assert _files(tmp_path) == sorted(planted)
