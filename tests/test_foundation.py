"""The shared data contracts: Scene, Sensor, Frame, resources, CLI wiring."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.resources import data_dir


def test_scene_stores_repeated_meshes_once_and_assigns_ids():
    scene = gg.Scene()
    box = trimesh.creation.box((1.0, 2.0, 3.0))
    a = scene.add(box, np.eye(4), semantic=1)
    b = scene.add(trimesh.creation.box((1.0, 2.0, 3.0)), [5.0, 0.0, 0.0], semantic=1)
    assert (a, b) == (1, 2)
    assert len(scene.meshes) == 1
    assert scene.meshes[scene.instances[0].mesh].closed
    np.testing.assert_allclose(scene.bounds(), [[-0.5, -1, -1.5], [5.5, 1, 1.5]])
    with pytest.raises(gg.ConfigError, match="already used"):
        scene.add(box, instance=2)
    with pytest.raises(gg.ConfigError, match="out of range"):
        gg.Mesh(np.zeros((3, 3)), np.array([[0, 1, 3]]))


def test_sensor_validation_names_the_field():
    s = gg.Sensor.pinhole(640, 480, 525.0)
    assert (s.cx, s.cy) == (319.5, 239.5) and s.is_pinhole
    with pytest.raises(gg.ConfigError, match="fx and fy"):
        gg.Sensor(640, 480, np.diag([0.0, 1.0, 1.0]))
    with pytest.raises(gg.ConfigError, match="distortion"):
        gg.Sensor(640, 480, np.eye(3), dist=np.zeros(6))


def test_frame_checks_buffer_shapes():
    s = gg.Sensor.pinhole(4, 3, 10.0)
    z = np.zeros((3, 4), np.float32)
    f = gg.Frame(z, np.zeros((3, 4), np.uint32), np.zeros((3, 4), np.uint16), None, s, np.eye(4))
    assert not f.valid.any()
    with pytest.raises(ValueError, match="depth"):
        gg.Frame(z.T.copy(), f.instance, f.semantic, None, s, np.eye(4))


def test_shipped_data_folders_are_found():
    for kind in ("shaders", "layouts", "sensors"):
        assert data_dir(kind).is_dir()


def test_cli_help_lists_every_stage(capsys):
    from genie_gl.cli import main

    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    for name in ("layout", "scene", "capture", "dataset", "bench"):
        assert name in out
