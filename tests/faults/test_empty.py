"""Empty or degenerate results are errors or loud warnings naming the input, never success:
no asset placed, no point captured, a dataset with nothing labelled, an empty cloud exported."""

import json
import logging

import numpy as np
import pytest
import trimesh

import genie_gl as gg

from .common import cli, fault, refused

WRONG_FILE = fault("bad file", "wrong")
WRONG_API = fault("bad API call", "wrong")


def tiny_regions() -> dict:
    """A hall of 0.2 m cells, each for a pallet (1.2 x 0.8 m): no asset fits any region."""
    return {
        "name": "tiny",
        "root": {"width": 6, "height": 4, "type": "hall"},
        "region_types": {
            "hall": {},
            "spot": {"final": True, "semantic": 1, "asset_group": "pallet"},
            "rest": {"final": True},
        },
        "levels": [
            {
                "hall": {
                    "generator": "grid",
                    "args": {"cell": [0.2, 0.2]},
                    "children": {"cell": "spot", "empty": "rest"},
                }
            }
        ],
    }


@WRONG_FILE
def test_a_scene_without_an_asset_is_said(caplog):
    layout = gg.generate_layout(tiny_regions(), seed=0)
    with caplog.at_level(logging.WARNING, logger="genie_gl.scene.build"):
        scene = gg.build_scene(layout, seed=0)
    assert all(i.semantic == 0 for i in scene.instances)
    assert (
        "build_scene: no asset placed: the layout of tiny holds floor and walls only" in caplog.text
    )
    assert "too small for their assets" in caplog.text


@WRONG_FILE
def test_a_dataset_with_nothing_labelled_is_an_error(tmp_path):
    """The dataset's own last check, on the stats of scenes that hold only background."""
    from genie_gl.dataset.config import DatasetConfig
    from genie_gl.dataset.run import _check_not_empty

    cfg = DatasetConfig.parse({"strategy": "s.json", "out": str(tmp_path), "scenes": 2})
    with pytest.raises(gg.ConfigError, match=r"hold nothing labelled: every point is background"):
        _check_not_empty(cfg, [{"class_points": {"0": 1000}}, {"class_points": {"0": 5}}])
    with pytest.raises(
        gg.ConfigError, match=r"hold no point: every chunk has fewer than --min-points"
    ):
        _check_not_empty(cfg, [{"class_points": {}}, {"class_points": {}}])
    _check_not_empty(
        cfg, [{"class_points": {"0": 1000, "3": 1}}, {"class_points": {}}]
    )  # one labelled point


@pytest.mark.gl
@WRONG_API
def test_a_capture_that_sees_nothing_is_an_error(tmp_path):
    """Cameras looking up, away from everything: the plan warns, the capture says no point
    was captured, naming the scene and the sensor; nothing is exported."""
    s = gg.Scene()
    s.add(trimesh.creation.box((4, 4, 1)), [0, 0, 0.5], semantic=2)
    usd = gg.write_usd(s, tmp_path / "s.usda")
    up = np.eye(4)
    up[2, 3] = 3.0  # OpenCV camera: +z forward; at z = 3 m looking up
    (tmp_path / "poses.json").write_text(json.dumps([up.tolist()]))
    run = cli(
        "capture", usd, "--poses", tmp_path / "poses.json", "--out", tmp_path / "o", "--no-progress"
    )
    err = run.err.strip().splitlines()
    assert run.rc == 2, run.err
    assert "s.usda: no point captured: none of the 1 cameras of sensor ideal_pinhole" in err[-1]
    assert not (tmp_path / "o" / "cloud.ply").exists()


@WRONG_API
def test_an_empty_cloud_is_not_exported(tmp_path):
    empty = gg.PointCloud(
        np.zeros((0, 3), np.float32), np.zeros(0, np.uint16), np.zeros(0, np.uint32)
    )
    for fmt in ("ply", "pcd", "npz", "semantickitti"):
        with pytest.raises(gg.GenieError, match="the cloud holds no point; nothing was written"):
            gg.export(empty, tmp_path / fmt, format=fmt)
    assert not any(tmp_path.iterdir())


@WRONG_API
@pytest.mark.parametrize(
    "make, needle",
    [
        (lambda: gg.Sensor.pinhole(64, 48, 1e-9), "a field of view no lens renders"),
        (
            lambda: gg.Sensor.pinhole(0, 48, 30.0),
            "width: expected a whole number in 1..1000000, got 0",
        ),
    ],
)
def test_a_degenerate_sensor_is_refused(make, needle):
    with pytest.raises(gg.ConfigError, match=needle.replace(".", r"\.")):
        make()


@WRONG_FILE
def test_a_degenerate_calibration_is_refused_by_the_cli(tmp_path):
    import cv2

    fs = cv2.FileStorage(str(tmp_path / "c.yml"), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 640)
    fs.write("image_height", 480)
    fs.write("camera_matrix", np.array([[1e-9, 0, 320], [0, 1e-9, 240], [0, 0, 1]]))
    fs.write("distortion_coefficients", np.zeros((5, 1)))
    fs.release()
    refused(
        cli("plan", "--scene", "none.usda", "--sensor", tmp_path / "c.yml"),
        "c.yml",
        "a field of view no lens renders",
    )
