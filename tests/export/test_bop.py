"""BOP export read back with independent readers (OpenCV for PNGs, plyfile for models, json)."""

import json

import cv2
import numpy as np
import pytest
import trimesh
from plyfile import PlyData

import genie_gl as gg
from genie_gl.export import bop
from genie_gl.capture import silhouettes
from genie_gl.render import Renderer
from genie_gl.sensors.pose import look_at


def two_box_scene():
    scene = gg.Scene()
    floor, back, front = np.eye(4), np.eye(4), np.eye(4)
    floor[2, 3] = -0.06  # top 1 cm below the boxes: nothing but the front box hides them
    scene.add(trimesh.creation.box((8, 8, 0.1)), floor, semantic=0, instance=1)  # background: no gt
    back[:3, 3] = [0.0, 1.0, 0.5]
    front[:3, 3] = [0.3, -0.2, 0.3]
    scene.add(
        scene.add_mesh(trimesh.creation.box((1.2, 0.8, 1.0)), name="crate"),
        back,
        semantic=9,
        instance=7,
    )
    scene.add(
        scene.add_mesh(trimesh.creation.box((0.4, 0.4, 0.6)), name="pallet_eur"),
        front,
        semantic=1,
        instance=8,
    )
    return scene


@pytest.mark.gl
def test_bop_scene_reads_back_with_poses_masks_and_depth(tmp_path):
    scene = two_box_scene()
    sensor = gg.Sensor(320, 240, np.array([[300.0, 0, 160.2], [0, 310.0, 119.7], [0, 0, 1]]))
    poses = [look_at([0.5, -3.0, 1.6], [0.1, 0.6, 0.4]), look_at([2.5, -2.0, 2.0], [0.0, 0.5, 0.4])]
    with Renderer(scene) as r:
        frames = [r.render(sensor, p) for p in poses]
        full = [silhouettes(r, sensor, p, [7, 8]) for p in poses]
    folder = bop.write_scene(scene, frames, tmp_path, scene_id=3, full_masks=full)
    assert folder == tmp_path / "train_pbr" / "000003"
    cam = json.loads((tmp_path / "camera.json").read_text())
    assert (cam["fx"], cam["cy"], cam["width"], cam["depth_scale"]) == (300.0, 119.7, 320, 1.0)
    sc = json.loads((folder / "scene_camera.json").read_text())
    gt = json.loads((folder / "scene_gt.json").read_text())
    info = json.loads((folder / "scene_gt_info.json").read_text())
    assert sorted(sc) == ["0", "1"] and (folder / "scene_gt.json").read_text().startswith(
        '{\n  "0": '
    )
    ids = bop.object_ids()
    for im, f in enumerate(frames):
        K = np.array(sc[str(im)]["cam_K"]).reshape(3, 3)
        np.testing.assert_array_equal(K, sensor.K)
        # depth: 1 mm steps, read as OpenCV reads a 16-bit PNG
        d = cv2.imread(str(folder / "depth" / f"{im:06d}.png"), cv2.IMREAD_UNCHANGED)
        assert d.dtype == np.uint16
        np.testing.assert_allclose(
            d * sc[str(im)]["depth_scale"] / 1000.0, f.depth, atol=0.5e-3 + 1e-6
        )
        # world-to-camera pose in mm
        R, t = (
            np.array(sc[str(im)]["cam_R_w2c"]).reshape(3, 3),
            np.array(sc[str(im)]["cam_t_w2c"]) / 1000,
        )
        np.testing.assert_allclose(np.linalg.inv(poses[im])[:3], np.c_[R, t], atol=1e-9)
        assert [g["obj_id"] for g in gt[str(im)]] == [bop.object_id("crate"), ids["pallet_eur"]]
        for gt_id, (g, inf, iid) in enumerate(zip(gt[str(im)], info[str(im)], [7, 8])):
            # the model (mm, read by plyfile) posed by cam_R/t_m2c projects onto the full
            # silhouette's box
            ply = PlyData.read(str(tmp_path / "models" / f"obj_{g['obj_id']:06d}.ply"))
            X = np.stack([ply["vertex"][k] for k in "xyz"], 1).astype(np.float64)
            Xc = X @ np.array(g["cam_R_m2c"]).reshape(3, 3).T + g["cam_t_m2c"]
            uv = (Xc @ K.T)[:, :2] / Xc[:, 2:]
            x0, y0, w, h = inf["bbox_obj"]
            np.testing.assert_allclose([uv[:, 0].min(), uv[:, 1].min()], [x0, y0], atol=1.0)
            np.testing.assert_allclose(
                [uv[:, 0].max(), uv[:, 1].max()], [x0 + w - 1, y0 + h - 1], atol=1.0
            )
            vis = cv2.imread(
                str(folder / "mask_visib" / f"{im:06d}_{gt_id:06d}.png"), cv2.IMREAD_UNCHANGED
            )
            np.testing.assert_array_equal(vis, np.where(f.instance == iid, 255, 0))
            mask = cv2.imread(
                str(folder / "mask" / f"{im:06d}_{gt_id:06d}.png"), cv2.IMREAD_UNCHANGED
            )
            assert (
                inf["px_count_all"]
                == (mask == 255).sum()
                >= inf["px_count_visib"]
                == (vis == 255).sum()
            )
            assert inf["visib_fract"] == pytest.approx(inf["px_count_visib"] / inf["px_count_all"])
        # the front box hides part of the back one; nothing hides the front one
        assert info[str(im)][0]["visib_fract"] < 0.99 and info[str(im)][1]["visib_fract"] == 1.0
    models = json.loads((tmp_path / "models" / "models_info.json").read_text())
    e = models[str(ids["pallet_eur"])]
    assert (e["size_x"], e["size_y"], e["size_z"]) == pytest.approx((400, 400, 600))
    assert e["diameter"] == pytest.approx(np.sqrt(400**2 + 400**2 + 600**2))
    assert not list(tmp_path.glob("train_pbr/.tmp-*"))  # nothing half-written left


def test_depth_png_keeps_range_and_zero_means_missing():
    d = np.array([[0.0, 1.2344, 65.535, 65.6, -1.0]], np.float32)
    np.testing.assert_array_equal(bop.depth_png(d, 1.0), [[0, 1234, 65535, 0, 0]])
    np.testing.assert_array_equal(bop.depth_png(d, 0.1), [[0, 12344, 0, 0, 0]])
