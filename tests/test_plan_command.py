"""`genie plan` prints the plan before rendering; `genie capture` places cameras inside the
scene, follows the plan and sums each effect in its manifest; `genie dataset` too."""

import json

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.cli import main
from genie_gl.scene.model import Material

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def room(tmp_path_factory):
    """A 6 x 4 m room with walls 3 m high and two boxes, written as USD."""
    s = gg.Scene()
    s.add(
        trimesh.creation.box((6, 4, 0.02)),
        [3, 2, -0.01],
        material=Material(roughness=0.9),
        name="floor",
    )
    for i, (ext, c) in enumerate(
        [
            ((6, 0.1, 3), (3, -0.05, 1.5)),
            ((6, 0.1, 3), (3, 4.05, 1.5)),
            ((0.1, 4, 3), (-0.05, 2, 1.5)),
            ((0.1, 4, 3), (6.05, 2, 1.5)),
        ]
    ):
        s.add(trimesh.creation.box(ext), list(c), name=f"wall_{i}")
    s.add(
        trimesh.creation.box((0.6, 0.6, 0.8)),
        [2, 2, 0.4],
        semantic=1,
        material=Material(metallic=1, roughness=0.2),
    )
    s.add(trimesh.creation.box((0.6, 0.6, 0.8)), [4, 1.5, 0.4], semantic=1)
    path = tmp_path_factory.mktemp("room") / "room.usda"
    gg.write_usd(s, path)
    return path, s


def test_genie_plan_prints_the_plan_and_the_predicted_time(room, capsys):
    path, _ = room
    assert (
        main(
            [
                "plan",
                "--scene",
                str(path),
                "--sensor",
                "azure_kinect_nfov",
                "--cameras",
                "3",
                "--scenes",
                "10",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert (
        "plan for azure_kinect_nfov: 3 frames" in out
        and "tof_multipath" in out
        and "predicted" in out
    )
    assert (
        main(
            [
                "plan",
                "--scene",
                str(path),
                "--sensor",
                "azure_kinect_nfov",
                "--cameras",
                "3",
                "--json",
            ]
        )
        == 0
    )
    plan = json.loads(capsys.readouterr().out)
    assert len(plan["frames"]) == 3 and plan["predicted_dataset_s"] > 0
    names = [e["name"] for e in plan["frames"][0]["effects"]]
    assert names == [e.name for e in gg.load_sensor("azure_kinect_nfov").effects]
    assert all({"name", "run", "reason", "cost_ms"} <= set(e) for e in plan["frames"][0]["effects"])


def test_genie_plan_refuses_a_sensor_that_cannot_fit_in_one_line(room, capsys):
    path, _ = room
    assert main(["plan", "--scene", str(path), "--sensor", "zivid2_m70", "--cameras", "2"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "zivid2_m70" in err and "mount" in err
    assert (
        main(
            [
                "plan",
                "--scene",
                str(path),
                "--sensor",
                "zivid2_m70",
                "--cameras",
                "2",
                "--mount",
                "0.9",
            ]
        )
        == 0
    )


def test_genie_plan_warns_about_a_frame_with_nothing_in_range(room, tmp_path, capsys):
    path, _ = room
    away = np.eye(4)
    away[:3, 3] = [3, 2, 20]  # 20 m up, looking up (OpenCV z = world z)
    np.save(tmp_path / "poses.npy", np.stack([away]))
    assert (
        main(
            [
                "plan",
                "--scene",
                str(path),
                "--sensor",
                "azure_kinect_nfov",
                "--poses",
                str(tmp_path / "poses.npy"),
            ]
        )
        == 0
    )
    assert "frame 0: nothing" in capsys.readouterr().err


def test_genie_capture_places_cameras_inside_and_sums_effects(room, tmp_path, capsys):
    path, scene = room
    out = tmp_path / "cap"
    assert (
        main(
            [
                "capture",
                str(path),
                "--sensor",
                "realsense_d435",
                "--cameras",
                "2",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    manifest = json.loads((out / "manifest.json").read_text())
    effects = manifest["effects"]
    assert list(effects) == [e.name for e in gg.load_sensor("realsense_d435").effects]
    assert all(t["run"] + t["skipped"] == 2 for t in effects.values())
    assert effects["depth_noise"]["run"] == 2 and effects["depth_noise"]["changed"] > 0
    # the cameras stand inside the walls (placement over the floor), not on a ring outside
    from genie_gl.placement.genetic import scene_poses

    for pose in scene_poses(scene, gg.load_sensor("realsense_d435"), 2, 0):
        assert 0 < pose[0, 3] < 6 and 0 < pose[1, 3] < 4 and 0 < pose[2, 3] < 3


def test_dataset_manifest_lists_each_effect(tmp_path):
    out = tmp_path / "ds"
    assert (
        main(
            [
                "dataset",
                "assembly_line",
                "--scenes",
                "1",
                "--cameras",
                "2",
                "--sensor",
                "azure_kinect_nfov",
                "--points",
                "4000",
                "--min-points",
                "500",
                "--no-progress",
                "--previews",
                "0",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    effects = json.loads((out / "manifest.json").read_text())["effects"]
    assert set(effects) == {e.name for e in gg.load_sensor("azure_kinect_nfov").effects}
    assert all(t["run"] + t["skipped"] == 2 and t["ms"] >= 0 for t in effects.values())
    assert effects["depth_noise"]["changed"] > 0
