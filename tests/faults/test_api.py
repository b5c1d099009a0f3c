"""Bad calls of the public API: the package's own error (a GenieError), one line naming the
argument, with the words the CLI uses for the same value; never a traceback from numpy,
pathlib or moderngl deep inside."""

import threading

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.cli import main

from .common import fault

API = fault("bad API call", "traceback")
WRONG = fault("bad API call", "wrong")


@pytest.fixture(scope="module")
def world():
    layout = gg.generate_layout("assembly_line", seed=0)
    scene = gg.Scene()
    scene.add(trimesh.creation.box((4, 4, 1)), [0, 0, 0.5], semantic=2)
    scene.add(trimesh.creation.box((20, 20, 0.02)), np.eye(4), semantic=0)
    sensor = gg.Sensor.pinhole(32, 24, 30.0)
    pose = np.eye(4)
    pose[:3, :3] = np.diag([1.0, -1.0, -1.0])  # looking down
    pose[2, 3] = 6.0
    return {"layout": layout, "scene": scene, "sensor": sensor, "pose": pose}


SEED = r"expected a whole number in 0\.\.2\*\*63-1"
CALLS = [
    (
        "generate_layout seed -1",
        lambda w: gg.generate_layout("assembly_line", seed=-1),
        f"seed: {SEED}, got -1",
    ),
    (
        "generate_layout seed 1.5",
        lambda w: gg.generate_layout("assembly_line", seed=1.5),
        f"seed: {SEED}, got 1.5",
    ),
    (
        "generate_layout seed '3'",
        lambda w: gg.generate_layout("assembly_line", seed="3"),
        "seed: expected a whole",
    ),
    (
        "generate_layout seed True",
        lambda w: gg.generate_layout("assembly_line", seed=True),
        "seed: expected a whole",
    ),
    ("generate_layout seed 2**63", lambda w: gg.generate_layout("assembly_line", seed=2**63), SEED),
    (
        "generate_layout a list",
        lambda w: gg.generate_layout(["x"], seed=0),
        "strategy: expected a Strategy",
    ),
    (
        "generate_layout a bad dict",
        lambda w: gg.generate_layout({"name": "x"}, seed=0),
        r"\$\.root: Field required",
    ),
    (
        "generate_layout max_regions 0",
        lambda w: gg.generate_layout("assembly_line", max_regions=0),
        "max_regions",
    ),
    (
        "build_scene a name",
        lambda w: gg.build_scene("assembly_line", seed=0),
        "build_scene: layout: expected a Layout, got str 'assembly_line'; make one with "
        "gg.generate_layout",
    ),
    (
        "build_scene seed -1",
        lambda w: gg.build_scene(w["layout"], seed=-1),
        f"build_scene: seed: {SEED}",
    ),
    (
        "place_sensors a name",
        lambda w: gg.place_sensors(w["layout"], "kinect_v2", n=2),
        "place_sensors: sensor: expected a Sensor, got str 'kinect_v2'; make one with "
        "gg.load_sensor",
    ),
    (
        "place_sensors n 0",
        lambda w: gg.place_sensors(w["layout"], w["sensor"], n=0),
        "place_sensors: n: expected",
    ),
    ("place_sensors n 2.5", lambda w: gg.place_sensors(w["layout"], w["sensor"], n=2.5), "got 2.5"),
    (
        "place_sensors n 1e6",
        lambda w: gg.place_sensors(w["layout"], w["sensor"], n=10**6),
        "1..10000",
    ),
    (
        "place_sensors mount nan",
        lambda w: gg.place_sensors(w["layout"], w["sensor"], n=2, mount_height_m=float("nan")),
        "mount_height_m: expected a finite number",
    ),
    (
        "place_sensors a scene",
        lambda w: gg.place_sensors(w["scene"], w["sensor"], n=2),
        "expected a Layout, got a Scene",
    ),
    (
        "plan a path",
        lambda w: gg.plan("s.usda", w["sensor"], [w["pose"]]),
        "plan: scene: expected a Scene, got str",
    ),
    (
        "plan one pose",
        lambda w: gg.plan(w["scene"], w["sensor"], w["pose"]),
        r"plan: poses: expected a list of \(4, 4\) poses, got one \(4, 4\) matrix; pass \[pose\]",
    ),
    (
        "plan no pose",
        lambda w: gg.plan(w["scene"], w["sensor"], []),
        "plan: poses: expected at least one pose",
    ),
    (
        "plan a scaled pose",
        lambda w: gg.plan(w["scene"], w["sensor"], [np.diag([2.0, 1, 1, 1])]),
        "not a rotation",
    ),
    (
        "capture a sensor name",
        lambda w: gg.capture(w["scene"], "kinect_v2", [w["pose"]], seed=0),
        "capture: sensor: expected a Sensor, got str 'kinect_v2'",
    ),
    (
        "capture seed -1",
        lambda w: gg.capture(w["scene"], w["sensor"], [w["pose"]], seed=-1),
        f"capture: seed: {SEED}",
    ),
    (
        "capture seed 0.5",
        lambda w: gg.capture(w["scene"], w["sensor"], [w["pose"]], seed=0.5),
        "got 0.5",
    ),
    (
        "capture a string of poses",
        lambda w: gg.capture(w["scene"], w["sensor"], "poses.npy", seed=0),
        "capture: poses: expected a list",
    ),
    (
        "capture a 3x4 pose",
        lambda w: gg.capture(w["scene"], w["sensor"], [np.eye(4)[:3]], seed=0),
        r"shape \(3, 4\)",
    ),
    (
        "render a path",
        lambda w: gg.render("s.usda", w["sensor"], w["pose"]),
        "render: scene: expected a Scene",
    ),
    (
        "render a list of poses",
        lambda w: gg.render(w["scene"], w["sensor"], [w["pose"]]),
        r"render: pose",
    ),
    (
        "Renderer a layout",
        lambda w: gg.Renderer(w["layout"]),
        "Renderer: scene: expected a Scene, got a Layout",
    ),
    (
        "to_cloud nothing",
        lambda w: gg.to_cloud([]),
        "to_cloud: frames: expected at least one Frame",
    ),
    (
        "to_cloud a scene",
        lambda w: gg.to_cloud(w["scene"]),
        "to_cloud: frames: expected a list of Frames",
    ),
    (
        "to_cloud a list of poses",
        lambda w: gg.to_cloud([w["pose"]]),
        r"to_cloud: frames\[0\]: expected a Frame",
    ),
    (
        "export a list of frames",
        lambda w: gg.export([1, 2], "out"),
        "export: cloud: expected a PointCloud, got a list of 2",
    ),
    (
        "export an unknown format",
        lambda w: gg.export(
            gg.PointCloud(
                np.zeros((1, 3), np.float32), np.ones(1, np.uint16), np.ones(1, np.uint32)
            ),
            "out",
            format="plyy",
        ),
        "did you mean 'ply'",
    ),
    (
        "load_rig a number",
        lambda w: gg.load_rig(3),
        "rig: expected a file name or the name of a shipped rig",
    ),
    (
        "load_sensor None",
        lambda w: gg.load_sensor(None),
        "sensor: expected a file name or the name of a shipped",
    ),
    (
        "make_trajectory a scene",
        lambda w: gg.make_trajectory(w["scene"]),
        "make_trajectory: layout: expected a Layout, got a Scene",
    ),
    (
        "make_trajectory seed -1",
        lambda w: gg.make_trajectory(w["layout"], seed=-1),
        f"make_trajectory: seed: {SEED}",
    ),
    (
        "make_trajectory duration 1e9",
        lambda w: gg.make_trajectory(w["layout"], duration_s=1e9),
        r"duration_s: expected a finite number in \(0, 3600\]",
    ),
    (
        "make_trajectory path aisle",
        lambda w: gg.make_trajectory(w["layout"], path="aisle"),
        "did you mean 'aisles'",
    ),
    (
        "record a sensor",
        lambda w: gg.record(w["scene"], w["sensor"], None, seed=0),
        "record: rig: expected a Rig, got a Sensor; make one with gg.load_rig",
    ),
    (
        "record poses",
        lambda w: gg.record(w["scene"], gg.load_rig("d435_quad"), [w["pose"]], seed=0),
        "record: trajectory: expected a Trajectory, got a list of 1",
    ),
    (
        "record seed 0.5",
        lambda w: gg.record(
            w["scene"],
            gg.load_rig("d435_quad"),
            gg.make_trajectory(w["layout"], duration_s=1.0),
            seed=0.5,
        ),
        "record: seed: expected a whole number",
    ),
    (
        "fuse bounds",
        lambda w: gg.fuse([], bounds=[1, 2, 3]),
        r"fuse: bounds: expected a \(2, 3\) box",
    ),
    (
        "fuse poses",
        lambda w: gg.fuse([w["pose"]], bounds=[[0, 0, 0], [1, 1, 1]]),
        r"fuse: frames\[0\]: expected a Frame",
    ),
    (
        "Sensor.pinhole width 10.5",
        lambda w: gg.Sensor.pinhole(10.5, 8, 10.0),
        "width: expected a whole number",
    ),
    (
        "Sensor.pinhole fx 1e-9",
        lambda w: gg.Sensor.pinhole(64, 48, 1e-9),
        "a field of view no lens renders",
    ),
]


@pytest.mark.parametrize(
    "name, call, needle", [pytest.param(*c, marks=API, id=c[0]) for c in CALLS]
)
def test_a_bad_call_raises_the_packages_own_error(name, call, needle, world, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # nothing may be written; if it were, it lands here
    with pytest.raises(gg.GenieError, match=needle) as info:
        call(world)
    assert "\n" not in str(info.value)
    assert not list(tmp_path.iterdir())


@API
def test_the_api_and_the_cli_say_the_same_words(tmp_path, capsys):
    with pytest.raises(gg.ConfigError) as info:
        gg.generate_layout("assembly_line", seed=-1)
    assert main(["layout", "assembly_line", "--seed", "-1", "--out", str(tmp_path)]) == 2
    api = str(info.value).split("seed: ", 1)[1]
    assert api in capsys.readouterr().err


@WRONG
def test_a_strategy_given_as_a_dict_is_the_same_as_its_file():
    import json

    from genie_gl.resources import data_dir

    data = json.loads((data_dir("layouts") / "assembly_line.json").read_text())
    a = gg.generate_layout(data, seed=3)
    b = gg.generate_layout("assembly_line", seed=3)
    assert a.to_dict()["nodes"] == b.to_dict()["nodes"]


@pytest.mark.gl
@API
def test_a_renderer_used_from_a_second_thread_says_so(world):
    got = []
    with gg.Renderer(world["scene"]) as r:
        frame = r.render(world["sensor"], world["pose"])
        assert (frame.depth > 0).all()  # the box and the floor fill the view

        def other():
            try:
                r.render(world["sensor"], world["pose"])
            except Exception as exc:  # noqa: BLE001  (what reaches the caller is the point)
                got.append(exc)

        t = threading.Thread(target=other)
        t.start()
        t.join(60)
        assert len(got) == 1 and isinstance(got[0], gg.RenderError), got
        assert "used from a thread other than the one that made it" in str(got[0])
        again = r.render(
            world["sensor"], world["pose"]
        )  # the renderer is unharmed in its own thread
        np.testing.assert_array_equal(again.depth, frame.depth)
