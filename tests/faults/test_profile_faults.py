"""Sensor profiles with numbers no sensor has, or a key an effect does not take: one line naming
the profile file and the field, at load, before any work (not a ValueError from a kernel
later); messages that name the sensor's own range and what a stopped command keeps."""

import json

import numpy as np
import pytest
import trimesh
import yaml

import genie_gl as gg
from genie_gl.cli import interrupted, stopped_message

from .common import cli, fault, refused, write_calibration

BAD = fault("bad file", "traceback")


def profile(tmp_path, effects=None, **fields):
    write_calibration(tmp_path / "c.yml", 64, 48)
    data = {"name": "p", "calibration": "c.yml", "effects": effects or [], **fields}
    (tmp_path / "p.yaml").write_text(yaml.safe_dump(data))
    return tmp_path / "p.yaml"


STEREO = {"type": "depth_noise", "model": "stereo", "baseline_m": 0.05}


@BAD
@pytest.mark.parametrize(
    "effect, field, needle",
    [
        ({**STEREO, "subpixel": 1e300}, "subpixel", "expected a value of at most 10 px"),
        ({**STEREO, "subpixel_step": 1e9}, "subpixel_step", "at most 10 px"),
        ({**STEREO, "baseline_m": 1e300}, "baseline_m", "at most 100000 m"),
        ({"type": "range", "min_m": 0.2, "max_m": 1e300}, "max_m", "at most 100000 m"),
        ({"type": "range", "min_m": float("inf")}, "min_m", "at most 100000 m"),
        ({"type": "lateral_noise", "sigma_px": 1e200}, "sigma_px", "at most 10000 px"),
        ({"type": "tof_multipath", "frequency_mhz": 1e12}, "frequency_mhz", "at most 10000 MHz"),
        ({"type": "tof_multipath", "samples": 10**12}, "samples", r"at most 1e\+06"),
    ],
)
def test_a_number_beyond_any_sensor_is_refused_at_load(tmp_path, effect, field, needle):
    p = profile(tmp_path, [effect])
    with pytest.raises(
        gg.ConfigError, match=rf"p\.yaml: effects\[0\] \({effect['type']}\)\.{field}: .*{needle}"
    ) as e:
        gg.load_sensor(p)
    assert "\n" not in str(e.value)


@BAD
@pytest.mark.parametrize(
    "fields, needle",
    [
        ({"far_m": 1e300}, r"far_m \(m\): expected a finite number in \(0, 100000\], got 1e\+300"),
        ({"near_m": -1}, r"near_m \(m\): expected a finite number in \(0, 1000\]"),
        ({"baseline_m": 1e300}, r"baseline_m \(m\): expected a finite number in \(0, 100\]"),
        ({"baseline_m": "wide"}, r"baseline_m \(m\): expected a finite number"),
    ],
)
def test_a_profile_range_or_baseline_beyond_any_sensor_is_refused(tmp_path, fields, needle):
    with pytest.raises(gg.ConfigError, match=r"p\.yaml: " + needle):
        gg.load_sensor(profile(tmp_path, **fields))


@BAD
def test_the_stereo_profile_of_1e300_subpixel_is_refused_by_the_command(tmp_path):
    """It used to end in a ValueError from frame_chunks (tiles too small for 5.5e19 m)."""
    p = profile(tmp_path, [{**STEREO, "subpixel": 1e300}])
    s = gg.Scene()
    s.add(trimesh.creation.box((4, 4, 1)), [0, 0, 0.5], semantic=2)
    usd = gg.write_usd(s, tmp_path / "s.usda")
    refused(
        cli(
            "capture",
            usd,
            "--sensor",
            p,
            "--cameras",
            "1",
            "--out",
            tmp_path / "o",
            "--no-progress",
        ),
        "p.yaml: effects[0] (depth_noise).subpixel",
    )
    assert not (tmp_path / "o").exists()


@BAD
@pytest.mark.parametrize(
    "effect, key, near",
    [
        ({"type": "range", "min_m": 0.2, "max": 8.0}, "max", "max_m"),
        ({**STEREO, "subpixle": 0.1}, "subpixle", "subpixel"),
        ({"type": "incidence_dropout", "max_angle": 70}, "max_angle", "max_angle_deg"),
    ],
)
def test_an_unknown_key_in_an_effect_is_a_did_you_mean(tmp_path, effect, key, near):
    with pytest.raises(gg.ConfigError) as e:
        gg.load_sensor(profile(tmp_path, [effect]))
    msg = str(e.value)
    assert msg.startswith(
        f"{tmp_path / 'p.yaml'}: effects[0] ({effect['type']}).{key}: not a parameter of the "
        f"'{effect['type']}' effect; did you mean '{near}'?"
    ), msg
    assert "__init__" not in msg and "unexpected keyword" not in msg


def test_the_shipped_profiles_are_within_the_bounds():
    for name in (
        "kinect_v2",
        "realsense_d435",
        "azure_kinect_nfov",
        "zivid2_m70",
        "ideal_pinhole",
        "cube_face",
    ):
        assert gg.load_sensor(name).width > 0


@pytest.mark.gl
@fault("bad option", "wrong")
def test_a_capture_that_sees_nothing_quotes_the_profiles_range(tmp_path):
    """The range effect's 0.2-8 m, not the clip range 0.05-10000 m the renderer keeps."""
    p = profile(tmp_path, [{"type": "range", "min_m": 0.2, "max_m": 8.0}])
    s = gg.Scene()
    s.add(trimesh.creation.box((1, 1, 1)), [0, 0, 0.5], semantic=2)
    usd = gg.write_usd(s, tmp_path / "s.usda")
    pose = np.eye(4)
    pose[:3, 3] = [0, 0, 50.0]  # looking up, away from the box
    poses = tmp_path / "poses.json"
    poses.write_text(json.dumps([pose.tolist()]))
    run = cli(
        "capture", usd, "--sensor", p, "--poses", poses, "--out", tmp_path / "o", "--no-progress"
    )
    assert run.rc == 2 and "Traceback" not in run.err, run.err
    err = run.err.strip().splitlines()[-1]  # after the plan's warning of an empty frame
    assert "no point captured" in err and "range 0.2-8 m" in err and "10000" not in err, err


@fault("signal", "wrong")
@pytest.mark.parametrize(
    "command, resumes, workers",
    [
        ("layout", False, False),
        ("scene", False, False),
        ("capture", False, True),
        ("dataset", True, True),
    ],
)
def test_a_stopped_command_says_what_it_keeps_and_only_a_dataset_resumes(command, resumes, workers):
    for sigterm in (False, True):
        line = stopped_message(command, sigterm)
        assert line.startswith("stopped by SIGTERM" if sigterm else "interrupted")
        assert ("resumes" in line) == resumes and ("workers" in line) == workers
        assert "what was written whole is kept" in line


@fault("signal", "traceback")
def test_an_interrupt_a_library_turned_into_its_own_error_is_still_an_interrupt():
    """numba interrupted while it compiles raises RuntimeError("no compiled object yet ...")
    from the KeyboardInterrupt: the CLI says "interrupted", not a traceback."""

    def compile_kernel():
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise RuntimeError(
                "no compiled object yet for <Library 'evolve'>"
            )  # as numba's cache does

    with pytest.raises(RuntimeError) as e:
        compile_kernel()
    assert (
        interrupted(e.value)
        and not interrupted(RuntimeError("a bug"))
        and not interrupted(ValueError())
    )
