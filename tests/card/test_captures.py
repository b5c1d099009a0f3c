"""A user's own captures: depth PNGs and a calibration file read, measured like the simulated
walls (recovering noise put into them), bad input refused in one line; the command's
argument errors; the RealSense recording script without its device package. No GL."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from genie_gl import cli
from genie_gl.card.captures import load_captures, measure_captures
from genie_gl.errors import ConfigError
from genie_gl.sensors.calibration import Calibration, write_calibration

W, H, F = 320, 240, 300.0
ROOT = Path(__file__).resolve().parents[2]


def write_frames(folder, frames_mm):
    folder.mkdir(parents=True, exist_ok=True)
    for i, f in enumerate(frames_mm):
        Image.fromarray(f.astype(np.uint16)).save(folder / f"depth_{i:04d}.png")


def calibration(path, T=None):
    K = np.array([[F, 0, (W - 1) / 2], [0, F, (H - 1) / 2], [0, 0, 1]])
    return write_calibration(
        Calibration(
            W,
            H,
            K,
            np.zeros(5),
            R=None if T is None else np.eye(3),
            T=None if T is None else np.array(T),
        ),
        path,
    )


def test_captures_of_a_noisy_wall_recover_its_noise_and_offset(tmp_path):
    """A wall at 1.2 m read 6 mm too far, sigma 3 mm, stored in whole millimetres: the
    rounding adds 1/12 mm^2 of variance (uniform on one unit)."""
    rng = np.random.default_rng(5)
    frames = [np.round(1206.0 + 3.0 * rng.standard_normal((H, W))) for _ in range(6)]
    frames[0][:10, :] = 0  # holes, outside the central ROI
    write_frames(tmp_path / "cap", frames)
    cap = load_captures(tmp_path / "cap", calibration(tmp_path / "c.yml", T=[-0.05, 0, 0]), 1.2)
    assert cap.depth.shape == (6, H, W) and cap.baseline_m == pytest.approx(0.05)
    out = {m.metric: m.value for m in measure_captures(cap, roi_fraction=0.4)}
    sigma = np.sqrt(9.0 + 1 / 12)
    p = 0.16 * W * H
    assert out["temporal_noise_mm"] == pytest.approx(sigma, rel=5 * np.sqrt(2 / 5 / p) / 2)
    assert out["bias_mm"] == pytest.approx(6.0, abs=5 * 1.2533 * sigma / np.sqrt(6 * p))
    assert out["z_accuracy_pct"] == pytest.approx(100 * 0.006 / 1.2, abs=0.02)
    assert out["fill_rate_pct"] == 100.0
    # the sub-pixel RMS from the calibration's baseline: sigma_d = sigma_z f B / z^2, trimmed
    assert 0.8 * 0.003 * F * 0.05 / 1.2**2 < out["subpixel_rms_px"] < 0.003 * F * 0.05 / 1.2**2


def test_bad_captures_are_one_line_naming_the_file(tmp_path):
    calib = calibration(tmp_path / "c.yml")
    write_frames(tmp_path / "one", [np.full((H, W), 1000.0)])
    with pytest.raises(ConfigError, match="found 1 depth PNG"):
        load_captures(tmp_path / "one", calib, 1.0)
    write_frames(tmp_path / "size", [np.full((H, W + 2), 1000.0)] * 2)
    with pytest.raises(
        ConfigError, match=r"depth_0000.png: image is 322x240, the calibration .* is 320x240"
    ):
        load_captures(tmp_path / "size", calib, 1.0)
    (tmp_path / "rgb").mkdir()
    for i in range(2):
        Image.fromarray(np.zeros((H, W, 3), np.uint8)).save(tmp_path / "rgb" / f"{i}.png")
    with pytest.raises(ConfigError, match="expected a single-channel 16-bit depth PNG"):
        load_captures(tmp_path / "rgb", calib, 1.0)
    write_frames(tmp_path / "zero", [np.zeros((H, W))] * 2)
    with pytest.raises(ConfigError, match="every depth pixel of every frame is 0"):
        load_captures(tmp_path / "zero", calib, 1.0)
    with pytest.raises(ConfigError, match="wall-distance"):
        load_captures(tmp_path / "size", calib, -1.0)
    with pytest.raises(ConfigError, match="not a folder"):
        load_captures(tmp_path / "nope", calib, 1.0)


def test_report_card_command_refuses_bad_arguments_in_one_line(tmp_path, capsys):
    assert cli.main(["report-card", "--sensor", "ideal_pinhole", "--captures", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "--captures, --calibration and --wall-distance go together" in err and "\n" not in err
    assert cli.main(["report-card", "--sensor", "ideal_pinhole", "--frames", "1"]) == 2
    assert "at least 2 frames" in capsys.readouterr().err
    assert cli.main(["report-card", "--sensor", "kinect_v3"]) == 2
    assert "did you mean 'kinect_v2'" in capsys.readouterr().err


def test_report_card_command_leaves_the_users_files_alone(tmp_path, capsys):
    """A page name taken by a file genie-gl did not write is refused before anything renders."""
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "index.md").write_text("my notes")
    assert (
        cli.main(["report-card", "--sensor", "ideal_pinhole", "--pages", str(tmp_path / "docs")])
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert "already holds 'index.md', which genie-gl did not write" in err and "\n" not in err
    assert (tmp_path / "docs" / "index.md").read_text() == "my notes"
    assert sorted(p.name for p in (tmp_path / "docs").iterdir()) == ["index.md"]
    assert (
        cli.main(
            [
                "report-card",
                "--sensor",
                "ideal_pinhole",
                "--out",
                str(tmp_path / "a"),
                "--pages",
                str(tmp_path / "a"),
            ]
        )
        == 2
    )
    assert "two different folders" in capsys.readouterr().err


def load_script():
    spec = importlib.util.spec_from_file_location(
        "record_captures", ROOT / "tools" / "record_captures.py"
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_recording_script_imports_without_its_device_package_and_says_so(
    tmp_path, monkeypatch, capsys
):
    monkeypatch.setitem(sys.modules, "pyrealsense2", None)  # as if not installed
    mod = load_script()  # the module imports cleanly
    assert mod.main(["--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == mod.MISSING and "pip install pyrealsense2" in err
    assert not (tmp_path / "x").exists()  # nothing half-written
    mod.write_png16(tmp_path / "d.png", np.array([[0, 1500], [65535, 7]], np.uint16))
    back = np.array(Image.open(tmp_path / "d.png"))
    assert back.dtype == np.uint16 and back.tolist() == [[0, 1500], [65535, 7]]
