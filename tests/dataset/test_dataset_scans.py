"""``genie dataset --capture scans|scan-map --rig <scanner rig>``: a VLP-16 carried along a
0.3 s walk, its raw scans in the scanner formats read back by independent readers, the map
fused from them in chunks of exactly ``--points`` points, the same bytes with 1 and 2 workers,
and a resume that makes nothing and changes no byte (a deleted scene made again the same)."""

import hashlib
import shutil
from pathlib import Path

import numpy as np
import pytest

from genie_gl.cli import main
from genie_gl.dataset import DatasetConfig, run_dataset
from genie_gl.errors import ConfigError

RIG = "forklift_vlp16"  # one VLP-16 head at 10 Hz


def files(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
        and p.name not in ("manifest.json", ".genie-lock")
        and "previews" not in p.parts
    }


def cfg(out, **kw):
    base = dict(
        strategy="storage_area",
        scenes=1,
        capture="scans",
        rig=RIG,
        duration_s=0.3,
        format="semantickitti",
        out=str(out),
        workers=1,
        seed=4,
        previews=0,
    )
    return DatasetConfig.parse(base | kw)


@pytest.mark.slow  # two worker processes each compile the ray kernels (~40 s under load)
def test_scans_are_the_same_bytes_with_one_and_two_workers(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    run_dataset(cfg(a, scenes=2), progress=False)
    run_dataset(cfg(b, scenes=2, workers=2), progress=False)
    assert files(a) == files(b) and len(files(a)) > 20


def test_scans_are_kitti_sequences_and_a_resume_changes_no_byte(tmp_path):
    a = tmp_path / "a"
    run_dataset(cfg(a, scenes=2), progress=False)
    fa = files(a)
    seq = a / "scenes" / "0000" / "sequences" / "00"
    bins = sorted((seq / "velodyne").glob("*.bin"))
    assert len(bins) == 3  # 0.3 s of a 10 Hz head: three whole revolutions
    poses = np.loadtxt(seq / "poses.txt").reshape(-1, 12)
    assert (
        poses.shape == (3, 12)
        and (seq / "calib.txt").is_file()
        and "scenes/0001/trajectory.txt" in fa
    )
    for p in bins:  # KITTI: x y z remission as float32; one uint32 label per point
        xyzr = np.fromfile(p, np.float32).reshape(-1, 4)
        labels = np.fromfile(seq / "labels" / (p.stem + ".label"), np.uint32)
        assert (
            len(xyzr) == len(labels) > 20000
        )  # a VLP-16 revolution: 16 x ~1808 beams, most of them hit
        assert 0.0 <= xyzr[:, 3].min() and xyzr[:, 3].max() <= 1.0
        r = np.linalg.norm(xyzr[:, :3], axis=1)
        assert (
            r.min() >= 0.9 and r.max() <= 100.0
        )  # the VLP-16's range window, in the scanner's frame
    # a re-run makes nothing and changes no byte; a deleted scene is made again, the same bytes
    mtimes = {
        p: p.stat().st_mtime_ns for p in (a / "scenes").rglob("*") if p.is_file()
    }  # the scenes' files
    made = run_dataset(cfg(a, scenes=2), progress=False)
    assert made["scenes_made"] == 0 and files(a) == fa
    assert all(p.stat().st_mtime_ns == t for p, t in mtimes.items())  # not even rewritten
    shutil.rmtree(a / "scenes" / "0001")
    made = run_dataset(cfg(a, scenes=2), progress=False)
    assert made["scenes_made"] == 1 and files(a) == fa


@pytest.mark.parametrize("fmt", ["rosbag", "las", "e57", "pcd", "ply"])
def test_scans_in_each_scanner_format_read_back(tmp_path, fmt):
    out = tmp_path / fmt
    run_dataset(cfg(out, format=fmt), progress=False)
    scene = out / "scenes" / "0000"
    kitti = None
    if fmt == "las":
        import laspy

        las = laspy.read(scene / "map.las")
        kitti = len(las.points)
    elif fmt == "e57":
        import pye57

        e57 = pye57.E57(str(scene / "scans.e57"))
        assert e57.scan_count == 3
        kitti = sum(
            len(e57.read_scan_raw(i, ignore_unsupported_fields=True)["cartesianX"])
            for i in range(3)
        )
    elif fmt == "rosbag":
        from rosbags.highlevel import AnyReader

        with AnyReader([scene / "bag"]) as reader:
            clouds = [
                reader.deserialize(raw, c.msgtype)
                for c, _, raw in reader.messages()
                if c.msgtype == "sensor_msgs/msg/PointCloud2"
            ]
            assert len(clouds) == 3
            kitti = sum(m.width * m.height for m in clouds)
    else:
        import open3d as o3d

        paths = sorted(scene.rglob(f"*.{fmt}"))
        assert len(paths) == 3
        kitti = sum(len(o3d.io.read_point_cloud(str(p)).points) for p in paths)
    import json

    stats = json.loads((scene / "stats.json").read_text())
    assert (
        kitti == stats["points_total"] > 60000
    )  # every point of every scan, counted where it was made


def test_scan_map_chunks_hold_exactly_points_and_resume(tmp_path):
    import laspy

    out = tmp_path / "m"
    c = cfg(
        out, capture="scan-map", format="las", points=2000, chunk_m=4.0, min_points=0, voxel_m=0.02
    )
    run_dataset(c, progress=False)
    chunks = sorted((out / "scenes" / "0000").glob("cloud_*.las"))
    assert chunks and all(
        len(laspy.read(p).points) == 2000 for p in chunks
    )  # cut to exactly --points
    import json

    assert json.loads((out / "scenes" / "0000" / "stats.json").read_text())["chunks"] == len(chunks)
    assert (
        "real" in (out / "histogram.txt").read_text().splitlines()[0]
    )  # Table 3's real column beside it
    before = files(out)
    assert run_dataset(c, progress=False)["scenes_made"] == 0 and files(out) == before


def test_a_scanner_rig_is_refused_by_the_camera_modes_and_a_camera_rig_by_the_scanner_modes(
    tmp_path, capsys
):
    with pytest.raises(
        ConfigError, match="--rig navvis_wearable: a scanner rig; its capture is --capture scans"
    ):
        cfg(tmp_path, capture="trajectory", rig="navvis_wearable")
    with pytest.raises(ConfigError, match="--format tum takes --capture trajectory"):
        cfg(tmp_path, format="tum")
    assert (
        main(
            [
                "dataset",
                "storage_area",
                "--capture",
                "scans",
                "--rig",
                "d435_quad",
                "--out",
                str(tmp_path / "x"),
                "--no-progress",
            ]
        )
        == 2
    )
    assert "takes a scanner rig" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()
