"""``genie view``: the Rerun recording of small datasets, read back with Rerun's own reader
(``rerun.chunk.RrdReader``) and checked against the dataset's files: entities, point counts,
class and instance ids, positions, camera and body poses, intrinsics and images."""

from pathlib import Path

import numpy as np
import pytest

from genie_gl import labels
from genie_gl.cli import main
from genie_gl.errors import ConfigError
from genie_gl.export import semantickitti
from genie_gl.view import SceneView, read_views, write_rrd
from genie_gl.view.folders import read_tum_poses
from genie_gl.view.recording import instance_colors
from rerun.chunk import RrdReader

pytestmark = pytest.mark.gl


def chunks(rrd: Path) -> dict[str, list]:
    """Entity path -> its chunks' record batches, as Rerun's reader gives them."""
    out: dict[str, list] = {}
    for c in RrdReader(rrd).stream().to_chunks():
        out.setdefault(c.entity_path, []).append(c.to_record_batch())
    return out


def column(batches, name: str) -> list:
    """The rows of one component column over an entity's chunks (each row a list)."""
    rows = []
    for b in batches:
        if name in b.schema.names:
            rows += b.column(name).to_pylist()
    return rows


def test_a_static_dataset_gives_its_cloud_ids_classes_and_layout(datasets, tmp_path):
    rrd = write_rrd(read_views(datasets["static"]), tmp_path / "v.rrd")
    got = chunks(rrd)
    scene = datasets["static"] / "scenes" / "0000"
    poses = np.loadtxt(scene / "poses.txt", ndmin=2)
    xyz, sem, inst = [], [], []
    for j, pose in enumerate(poses):
        p, s, i = semantickitti.read(scene / "velodyne" / f"{j:06d}.bin")
        xyz.append(p + pose.reshape(3, 4)[:, 3])
        sem.append(s)
        inst.append(i)
    xyz, sem, inst = np.concatenate(xyz), np.concatenate(sem), np.concatenate(inst)
    assert len(xyz) > 1000
    positions = np.array(column(got["/scene_0000/world/cloud/class"], "Points3D:positions")[0])
    class_ids = np.array(column(got["/scene_0000/world/cloud/class"], "Points3D:class_ids")[0])
    assert positions.shape == xyz.shape
    np.testing.assert_allclose(positions, xyz, atol=1e-4)
    np.testing.assert_array_equal(class_ids, sem)
    ids = np.array(column(got["/scene_0000/world/cloud/instance"], "instance_id")[0])
    np.testing.assert_array_equal(ids, inst)
    colors = np.array(
        column(got["/scene_0000/world/cloud/instance"], "Points3D:colors")[0], np.uint32
    )
    rgb = instance_colors(inst).astype(np.uint32)
    np.testing.assert_array_equal(colors >> 8, rgb[:, 0] << 16 | rgb[:, 1] << 8 | rgb[:, 2])
    # one annotation context, at the root: the ten classes in the previews' colours
    context = column(got["/"], "AnnotationContext:context")[0][0]
    infos = {e["class_id"]: e["class_description"]["info"] for e in context}
    assert sorted(infos) == sorted(labels.CLASSES)
    for k, info in infos.items():
        assert info["label"] == labels.name(k)
        assert (
            info["color"] >> 8
            == labels.color(k)[0] << 16 | labels.color(k)[1] << 8 | labels.color(k)[2]
        )
    assert [p for p in got if "AnnotationContext:context" in got[p][0].schema.names] == ["/"]
    assert "/scene_0000/layout" in got


def test_a_tum_recording_gives_every_camera_pose_intrinsics_and_image(datasets, tmp_path):
    rrd = write_rrd(read_views(datasets["tum"]), tmp_path / "v.rrd")
    got = chunks(rrd)
    scene = datasets["tum"] / "scenes" / "0000"
    sensor_dir = next(d for d in scene.iterdir() if (d / "groundtruth.txt").is_file())
    times, poses = read_tum_poses(sensor_dir / "groundtruth.txt")
    cam = f"/scene_0000/world/cameras/{sensor_dir.name}"
    assert len(times) >= 3
    t = np.array(column(got[cam], "time"))
    order = np.argsort(t)
    trans = np.array(column(got[cam], "Transform3D:translation")).reshape(-1, 3)[order]
    rot = np.array(column(got[cam], "Transform3D:mat3x3")).reshape(-1, 3, 3)[order]
    F32 = 1e-5  # Rerun keeps transforms in float32: ~3e-6 m at 40 m from the origin
    np.testing.assert_allclose(trans, poses[:, :3, 3], atol=F32)
    # Rerun's mat3x3 is column-major
    np.testing.assert_allclose(np.transpose(rot, (0, 2, 1)), poses[:, :3, :3], atol=1e-6)
    K = np.array(column(got[f"{cam}/image"], "Pinhole:image_from_camera")[0]).reshape(3, 3).T
    np.testing.assert_allclose(K, datasets["sensor"].K, atol=1e-6)
    assert column(got[f"{cam}/image"], "Pinhole:resolution")[0] == [[96.0, 72.0]]
    depth = column(got[f"{cam}/image/depth"], "DepthImage:buffer")
    sem = column(got[f"{cam}/image/semantic"], "SegmentationImage:buffer")
    assert len(depth) == len(sem) == len(times)
    from PIL import Image

    first = f"{times[0]:.6f}.png"
    want_depth = np.asarray(Image.open(sensor_dir / "depth" / first), np.float64) / 5000.0
    got_depth = np.array(depth[int(order[0])][0], np.uint8).view(np.float32).reshape(72, 96)
    np.testing.assert_allclose(got_depth, want_depth, atol=1e-6)
    want_sem = np.asarray(Image.open(sensor_dir / "semantic" / first)).astype(np.uint16)
    np.testing.assert_array_equal(
        np.array(sem[int(order[0])][0], np.uint8).view(np.uint16).reshape(72, 96), want_sem
    )
    assert want_sem.max() > 0
    # the body on the time line, and the trajectory as one line through its positions
    body_t, body = read_tum_poses(scene / "trajectory.txt")
    got_body = np.array(column(got["/scene_0000/world/body"], "Transform3D:translation")).reshape(
        -1, 3
    )
    np.testing.assert_allclose(np.sort(got_body, axis=0), np.sort(body[:, :3, 3], axis=0), atol=F32)
    strip = np.array(column(got["/scene_0000/world/trajectory"], "LineStrips3D:strips")[0][0])
    np.testing.assert_allclose(strip, body[:, :3, 3], atol=F32)


def test_a_semantickitti_recording_puts_its_cameras_where_tum_does(datasets, tmp_path):
    """The same scene and trajectory in two formats: camera 0 recovered from SemanticKITTI's
    world_pose, Tr, poses and P0 sits where TUM's ground truth puts the camera."""
    rrd = write_rrd(read_views(datasets["kitti"]), tmp_path / "v.rrd")
    got = chunks(rrd)
    tum_dir = next(
        d
        for d in (datasets["tum"] / "scenes" / "0000").iterdir()
        if (d / "groundtruth.txt").is_file()
    )
    _, poses = read_tum_poses(tum_dir / "groundtruth.txt")
    cam = "/scene_0000/world/cameras/group_00_cam0"
    t = np.array(column(got[cam], "time"))
    trans = np.array(column(got[cam], "Transform3D:translation")).reshape(-1, 3)[np.argsort(t)]
    np.testing.assert_allclose(trans, poses[:, :3, 3], atol=2e-5)  # float32 in Rerun
    K = np.array(column(got[f"{cam}/image"], "Pinhole:image_from_camera")[0]).reshape(3, 3).T
    np.testing.assert_allclose(K, datasets["sensor"].K, atol=1e-6)
    # every scan's points in the world: the count the scans hold
    n = sum(
        len(np.fromfile(f, "<f4")) // 4
        for f in (datasets["kitti"] / "scenes/0000/00/velodyne").glob("*.bin")
    )
    positions = column(got["/scene_0000/world/cloud/class"], "Points3D:positions")[0]
    assert len(positions) == n > 0


def test_a_usd_scene_gives_its_meshes_with_class_ids(tmp_path):
    import trimesh

    import genie_gl as gg

    scene = gg.Scene()
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), np.eye(4), semantic=2)
    T = np.eye(4)
    T[:3, 3] = (3.0, 0.0, 0.5)
    scene.add(trimesh.creation.box((1.0, 2.0, 1.0)), T, semantic=8)
    gg.write_usd(scene, tmp_path / "s.usda")
    got = chunks(write_rrd(read_views(tmp_path / "s.usda"), tmp_path / "s.rrd"))
    meshes = sorted(p for p in got if "/world/meshes/" in p)
    assert len(meshes) == 2
    classes = sorted(set(column(got[m], "Mesh3D:class_ids")[0]) for m in meshes)
    assert classes == [{2}, {8}]
    v = np.array(column(got[meshes[1]], "Mesh3D:vertex_positions")[0])
    np.testing.assert_allclose(v.mean(axis=0), (3.0, 0.0, 0.5), atol=1e-5)


def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys):
    assert main(["view", str(tmp_path / "missing")]) == 2
    (tmp_path / "empty").mkdir()
    assert main(["view", str(tmp_path / "empty")]) == 2
    (tmp_path / "x.txt").write_text("hello")
    assert main(["view", str(tmp_path / "x.txt")]) == 2
    assert main(["view", str(tmp_path / "empty"), "--serve", "--bind", "localhost:80"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 4 and all(line.startswith("genie view: error: ") for line in err)
    # a file of the user's at --out is never overwritten
    (tmp_path / "mine.rrd").write_text("my notes")
    views = read_views(tmp_path / "s.usda") if (tmp_path / "s.usda").exists() else None
    with pytest.raises(ConfigError, match="not written by genie-gl"):
        write_rrd(views or [SceneView("x", np.zeros((1, 3)))], tmp_path / "mine.rrd")
    assert (tmp_path / "mine.rrd").read_text() == "my notes"


def test_a_scanner_dataset_gives_every_heads_points_by_class_and_by_ring(tmp_path):
    from plyfile import PlyData

    from genie_gl.dataset.config import DatasetConfig
    from genie_gl.dataset.run import run_dataset

    out = tmp_path / "scans"
    cfg = dict(
        strategy="storage_area",
        scenes=1,
        capture="scans",
        rig="forklift_vlp16",
        duration_s=0.2,
        format="ply",
        workers=1,
        seed=2,
        previews=0,
        out=str(out),
    )
    run_dataset(DatasetConfig.parse(cfg), progress=False)
    files = sorted((out / "scenes" / "0000").glob("*/*.ply"))
    assert files
    rows = [PlyData.read(str(f))["vertex"] for f in files]  # plyfile: an independent reader
    xyz = np.concatenate([np.stack([r["x"], r["y"], r["z"]], 1) for r in rows])
    ring = np.concatenate([r["ring"] for r in rows])
    sem = np.concatenate([r["semantic"] for r in rows])
    assert len(xyz) > 1000 and len(np.unique(ring)) > 8
    got = chunks(write_rrd(read_views(out), tmp_path / "v.rrd"))
    positions = np.array(column(got["/scene_0000/world/cloud/class"], "Points3D:positions")[0])
    np.testing.assert_allclose(positions, xyz, atol=1e-4)
    np.testing.assert_array_equal(
        column(got["/scene_0000/world/cloud/class"], "Points3D:class_ids")[0], sem
    )
    np.testing.assert_array_equal(column(got["/scene_0000/world/cloud/ring"], "ring")[0], ring)
