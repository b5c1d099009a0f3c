"""Outputs opened by the field's own readers, without help: semantic-kitti-api's scan and label
classes and its evaluation logic, bop_toolkit's loaders (a faithful reading of inout.py, the
package is not on PyPI), Open3D's tensor PLY and PCD readers."""

import json
import os
import struct

import numpy as np
import pytest
import yaml

import genie_gl as gg
from genie_gl.cli import main
from genie_gl.export import semantickitti

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
    "0",
    "--workers",
    "1",
]


@pytest.fixture(scope="module")
def kitti(tmp_path_factory):
    out = tmp_path_factory.mktemp("kitti")
    # three sequences, one per split (the default 0.8, 0.1, 0.1 would put all three in train)
    assert main(["dataset", *ARGS, "--scenes", "3", "--split", "1,1,1", "--out", str(out)]) == 0
    return out


@pytest.mark.gl
def test_semantic_kitti_api_loads_and_evaluates_the_dataset(kitti):
    """evaluate_semantics.py's steps (the script is not in the wheel) with the API's own classes."""
    from auxiliary import (
        laserscan,
    )  # semantic-kitti-api (make setup: pip install --no-deps semantic-kitti-api)
    from auxiliary.np_ioueval import iouEval

    DATA = yaml.safe_load((kitti / "genie-gl.yaml").read_text())
    for key in (
        "labels",
        "color_map",
        "content",
        "learning_map",
        "learning_map_inv",
        "learning_ignore",
        "split",
    ):
        assert key in DATA
    assert DATA["labels"][6] == "storage cabinet" and DATA["labels"][9] == "small load carrier"
    assert sum(DATA["content"].values()) == pytest.approx(1.0)
    class_remap, class_inv_remap = DATA["learning_map"], DATA["learning_map_inv"]
    nr_classes = len(class_inv_remap)
    maxkey = max(class_remap.keys())
    remap_lut = np.zeros((maxkey + 100), dtype=np.int32)
    remap_lut[list(class_remap.keys())] = list(class_remap.values())
    ignore = [cl for cl, ign in DATA["learning_ignore"].items() if ign]
    counts = np.zeros(nr_classes, np.int64)
    for split in ("train", "valid", "test"):
        sequences = DATA["split"][split]
        assert sequences, f"split {split} is empty: the API would evaluate 0 scans"
        evaluator = iouEval(nr_classes, ignore)
        n_scans = 0
        for seq in sequences:
            seq_dir = kitti / "sequences" / "{0:02d}".format(int(seq))
            scans = sorted(str(p) for p in (seq_dir / "velodyne").iterdir())
            labels = sorted(str(p) for p in (seq_dir / "labels").iterdir())
            assert (
                len(scans) == len(labels) == len((seq_dir / "poses.txt").read_text().splitlines())
            )
            for scan_file, label_file in zip(scans, labels):
                scan = laserscan.SemLaserScan(DATA["color_map"], project=False)
                scan.open_scan(scan_file)
                scan.open_label(label_file)  # raises when counts differ
                label = remap_lut[scan.sem_label]
                pred = remap_lut[
                    np.fromfile(label_file, dtype=np.int32) & 0xFFFF
                ]  # predictions = the labels
                evaluator.addBatch(pred, label)
                counts += np.bincount(label, minlength=nr_classes)
                n_scans += 1
        assert n_scans > 0
        m_iou, iou = evaluator.getIoU()
        present = [
            c for c in range(nr_classes) if c not in ignore and evaluator.conf_matrix[:, c].sum()
        ]
        assert present and np.allclose(iou[present], 1.0) and m_iou > 0
    # content.py: the yaml's content is the share of points of every class over the whole dataset
    np.testing.assert_allclose(
        [DATA["content"][c] for c in range(nr_classes)], counts / counts.sum(), atol=1e-9
    )


def test_sequences_stay_two_digit_past_100_scenes(tmp_path):
    rng = np.random.default_rng(0)
    dirs = []
    for i in range(230):
        n = 3 + i % 4
        c = gg.PointCloud(
            rng.normal(size=(n, 3)).astype(np.float32),
            np.full(n, i % 10, np.uint16),
            np.arange(n, dtype=np.uint32),
            np.array([float(i), 0.0, 0.0]),
        )
        semantickitti.write_scans([c, c] if i % 5 else [], tmp_path / "scenes" / f"{i:04d}")
        dirs.append(tmp_path / "scenes" / f"{i:04d}")
    groups = semantickitti.assemble_sequences(tmp_path, dirs, counts={1: 5})
    names = sorted(p.name for p in (tmp_path / "sequences").iterdir())
    assert names == [f"{s:02d}" for s in range(77)] and all(len(n) == 2 for n in names)
    assert groups[0] == [0, 1, 2] and groups[76] == [228, 229]
    # sequence 01 holds scenes 3, 4, 5 in order: 2 + 2 + 0 scans, numbered contiguously
    assert sorted(p.name for p in (tmp_path / "sequences/01/velodyne").iterdir()) == [
        f"{k:06d}.bin" for k in range(4)
    ]
    poses = (tmp_path / "sequences/01/poses.txt").read_text().splitlines()
    assert [float(p.split()[3]) for p in poses] == [3.0, 3.0, 4.0, 4.0]
    split = yaml.safe_load((tmp_path / "genie-gl.yaml").read_text())["split"]
    assert sorted(split["train"] + split["valid"] + split["test"]) == list(range(77))
    assert len(split["valid"]) == len(split["test"]) == 8


def test_instance_ids_beyond_16_bits_are_renumbered_or_refused(tmp_path):
    n = 6
    c = gg.PointCloud(
        np.zeros((n, 3), np.float32),
        np.ones(n, np.uint16),
        np.array([0, 70000, 5, 70000, 2**31 + 7, 5], np.uint32),
        np.zeros(3),
    )
    b = gg.export(c, tmp_path, format="semantickitti")
    raw = np.fromfile(tmp_path / "sequences/00/labels/000000.label", "<u4") >> 16
    assert raw.tolist() == [0, 2, 1, 2, 3, 1]
    assert semantickitti.read(b)[2].tolist() == c.instance.tolist()
    with pytest.raises(gg.GenieError, match="limit 65535"):
        semantickitti.pack_labels(np.array([1]), np.array([65536]))
    many = np.arange(1, 70002, dtype=np.uint32)
    with pytest.raises(gg.GenieError, match=r"70001 instances \(limit 65535\)"):
        semantickitti.encode_instances(many)


def random_cloud(n=300, seed=0):
    rng = np.random.default_rng(seed)
    return gg.PointCloud(
        rng.normal(size=(n, 3)).astype(np.float32),
        rng.integers(0, 10, n).astype(np.uint16),
        rng.integers(0, 2**31 - 1, n).astype(np.uint32),
        np.array([1e5, 2.0, 0.25]),
        rng.integers(0, 256, (n, 3)).astype(np.uint8),
    )


def test_open3d_tensor_readers_keep_the_labels(tmp_path):
    import open3d as o3d

    c = random_cloud()
    ply = o3d.t.io.read_point_cloud(str(gg.export(c, tmp_path, format="ply")))
    np.testing.assert_array_equal(ply.point["positions"].numpy(), c.xyz)
    np.testing.assert_array_equal(ply.point["semantic"].numpy().ravel(), c.semantic)
    np.testing.assert_array_equal(ply.point["instance"].numpy().ravel(), c.instance)
    assert ply.point["semantic"].dtype == o3d.core.Dtype.Int32
    path = gg.export(c, tmp_path, format="pcd")
    pcd = o3d.t.io.read_point_cloud(str(path))
    np.testing.assert_array_equal(pcd.point["positions"].numpy(), c.xyz)
    np.testing.assert_array_equal(pcd.point["label"].numpy().ravel(), c.semantic)
    np.testing.assert_array_equal(pcd.point["instance"].numpy().ravel(), c.instance)
    np.testing.assert_array_equal(pcd.point["colors"].numpy(), c.rgb)
    header = path.read_bytes().split(b"DATA binary\n")[0].decode()
    assert "np." not in header and "(" not in header.split("\n", 1)[1]
    assert header.splitlines()[0].endswith("origin 100000 2 0.25")


# --- bop_toolkit (thodan/bop_toolkit, bop_toolkit_lib/inout.py): its loaders, read faithfully


def bop_load_json(path, keys_to_int=False):
    def convert(x):
        return {int(k) if k.lstrip("-").isdigit() else k: v for k, v in x.items()}

    with open(path) as f:
        return json.load(f, object_hook=convert) if keys_to_int else json.load(f)


def bop_load_ply(path):
    """inout.load_ply: binary PLY of float/double/int/uchar properties, triangles only."""
    f = open(path, "rb")
    n_pts = n_faces = 0
    pt_props, face_props, vertex_section, face_section = [], [], False, False
    while True:
        line = f.readline().decode("utf8").rstrip("\n").rstrip("\r")
        if line.startswith("element vertex"):
            n_pts, vertex_section, face_section = int(line.split()[-1]), True, False
        elif line.startswith("element face"):
            n_faces, vertex_section, face_section = int(line.split()[-1]), False, True
        elif line.startswith("element"):
            vertex_section = face_section = False
        elif line.startswith("property") and vertex_section:
            pt_props.append((line.split()[-1], line.split()[-2]))
        elif line.startswith("property list") and face_section:
            e = line.split()
            assert e[-1] in ("vertex_indices", "vertex_index")
            face_props += [("n_corners", e[2])] + [(f"ind_{i}", e[3]) for i in range(3)]
        elif line.startswith("format"):
            assert "binary" in line
        elif line.startswith("end_header"):
            break
    formats = {"float": ("f", 4), "double": ("d", 8), "int": ("i", 4), "uchar": ("B", 1)}
    names = [p[0] for p in pt_props]
    model = {"pts": np.zeros((n_pts, 3)), "faces": np.zeros((n_faces, 3))}
    assert {"nx", "ny", "nz"} <= set(names), "the BOP renderer needs vertex normals"
    model["normals"] = np.zeros((n_pts, 3))
    for i in range(n_pts):
        vals = {}
        for name, typ in pt_props:
            fmt = formats[typ]  # KeyError for a type the toolkit cannot read
            vals[name] = struct.unpack(fmt[0], f.read(fmt[1]))[0]
        model["pts"][i] = [vals["x"], vals["y"], vals["z"]]
        model["normals"][i] = [vals["nx"], vals["ny"], vals["nz"]]
    for i in range(n_faces):
        for name, typ in face_props:
            fmt = formats[typ]
            v = struct.unpack(fmt[0], f.read(fmt[1]))[0]
            if name == "n_corners":
                assert v == 3, "Only triangular faces are supported."
            else:
                model["faces"][i, int(name[-1])] = v
    assert f.read() == b""
    return model


@pytest.mark.gl
def test_bop_toolkit_loaders_and_checks_accept_the_dataset(tmp_path):
    import imageio.v2 as imageio

    assert main(["dataset", *ARGS, "--scenes", "1", "--format", "bop", "--out", str(tmp_path)]) == 0
    cam = bop_load_json(tmp_path / "camera.json")
    assert set(cam) == {"cx", "cy", "depth_scale", "fx", "fy", "height", "width"}
    info = bop_load_json(tmp_path / "models" / "models_info.json", keys_to_int=True)
    allowed = {
        "diameter",
        "min_x",
        "min_y",
        "min_z",
        "size_x",
        "size_y",
        "size_z",
        "symmetries_discrete",
        "symmetries_continuous",
    }
    scene = tmp_path / "train_pbr" / "000000"
    sc = bop_load_json(scene / "scene_camera.json", keys_to_int=True)
    gt = bop_load_json(scene / "scene_gt.json", keys_to_int=True)
    gi = bop_load_json(scene / "scene_gt_info.json", keys_to_int=True)
    assert sorted(sc) == sorted(gt) == sorted(gi) == [0, 1]
    for oid, e in info.items():
        assert set(e) <= allowed, f"keys BOP does not define: {set(e) - allowed}"
        m = bop_load_ply(tmp_path / "models" / f"obj_{oid:06d}.ply")
        # misc.calc_pts_diameter: the largest distance between two model points
        pts = m["pts"]
        d = max(np.sqrt(((pts[i] - pts[i + 1 :]) ** 2).sum(1)).max() for i in range(len(pts) - 1))
        assert e["diameter"] == pytest.approx(d, rel=1e-5)
        np.testing.assert_allclose(np.linalg.norm(m["normals"], axis=1), 1.0, atol=1e-5)
        np.testing.assert_allclose(pts.min(0), [e["min_x"], e["min_y"], e["min_z"]], atol=1e-3)
        for S in e.get("symmetries_discrete", []):  # each maps the model onto itself
            from scipy.spatial import cKDTree

            S = np.array(S).reshape(4, 4)
            assert cKDTree(pts).query(pts @ S[:3, :3].T + S[:3, 3])[0].max() < 1.0
    for im in sc:
        K = np.array(sc[im]["cam_K"]).reshape(3, 3)
        assert K[0, 0] > 0 and K[1, 1] > 0 and np.array_equal(K[2], [0, 0, 1])
        assert "cam_model" not in sc[im]
        depth = imageio.imread(scene / "depth" / f"{im:06d}.png").astype(
            np.float32
        )  # inout.load_depth
        depth_mm = depth * sc[im]["depth_scale"]
        assert depth.max() <= 65535 and depth_mm.max() > 0
        assert (
            65535 * sc[im]["depth_scale"] / 10 < depth_mm.max() <= 65535 * sc[im]["depth_scale"]
            or sc[im]["depth_scale"] == 0.1
        )  # the finest step at which the farthest depth fits
        assert len(gt[im]) == len(gi[im]) > 0
        for g, inf in zip(gt[im], gi[im]):
            assert g["obj_id"] in info
            R, t = np.array(g["cam_R_m2c"]).reshape(3, 3), np.array(g["cam_t_m2c"])
            np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-6)
            assert t[2] > 0 and set(inf) >= {
                "bbox_obj",
                "bbox_visib",
                "px_count_all",
                "px_count_valid",
                "px_count_visib",
                "visib_fract",
            }
    assert not list((tmp_path / "train_pbr").glob(".tmp-*"))


@pytest.mark.gl
def test_output_folders_and_files_get_the_usual_permissions(kitti):
    old = os.umask(0o022)
    os.umask(old)
    if old != 0o022:
        pytest.skip(f"umask {old:o}: the usual permissions follow from umask 022")
    modes = {p: p.stat().st_mode & 0o777 for p in kitti.rglob("*")}  # the root is pytest's (0700)
    assert {oct(m) for p, m in modes.items() if p.is_dir()} == {"0o755"}
    assert {oct(m) for p, m in modes.items() if p.is_file()} == {"0o644"}


def test_ply_and_npz_keep_the_full_instance_range(tmp_path):
    import plyfile

    c = gg.PointCloud(
        np.zeros((3, 3), np.float32),
        np.array([1, 2, 65535], np.uint16),
        np.array([1, 2**31, 2**32 - 1], np.uint32),
        np.zeros(3),
    )
    v = plyfile.PlyData.read(str(gg.export(c, tmp_path, format="ply")))["vertex"].data
    assert v["instance"].tolist() == c.instance.tolist() and v["semantic"].tolist() == [1, 2, 65535]
    z = np.load(gg.export(c, tmp_path, format="npz"))
    assert z["instance"].dtype == np.uint32 and z["instance"].tolist() == c.instance.tolist()


@pytest.mark.gl
def test_every_stage_of_a_scene_is_named_for_the_progress_bar(tmp_path):
    from genie_gl.dataset import DatasetConfig, run_scene
    from genie_gl.dataset.scene import STAGES

    cfg = DatasetConfig(
        strategy="assembly_line",
        out=str(tmp_path),
        scenes=1,
        cameras=1,
        sensor="ideal_pinhole",
        points=1000,
        min_points=100,
        previews=0,
    )
    seen = []
    stats = run_scene(cfg, 0, stage=seen.append)
    assert seen == list(STAGES) and set(stats["timings_s"]) == set(STAGES)
    assert run_scene(cfg, 0, stage=seen.append)["skipped"] and len(seen) == len(
        STAGES
    )  # a finished scene: no stages
