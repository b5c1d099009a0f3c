"""One real-render test per metric family: the standard test scenes rendered by the real
renderer (llvmpipe through EGL) through real profiles, measured by the card, against values
computed here from the profiles' published parameters."""

import numpy as np
import pytest
from scipy import stats

import genie_gl as gg
from genie_gl.card.report import CardSettings
from genie_gl.card.measurements import measure

pytestmark = pytest.mark.gl

TRIM_A = stats.norm.ppf(1 - 0.005)
TRIM_RMS = float(np.sqrt(stats.truncnorm.var(-TRIM_A, TRIM_A)))  # RMS left after the 0.5 % trims
NONE = dict(
    distances_m=(),
    angles_deg=(),
    angle_distances_m=(),
    step_distances_m=(),
    bars_distances_m=(),
    panels_distances_m=(),
)


def run(sensor, frames=4, seed=0, **kw):
    settings = CardSettings(**{**NONE, **kw}, frames=frames, seed=seed)
    return {
        (m.metric, m.distance_m, m.angle_deg, m.part): m.value
        for m in measure(gg.load_sensor(sensor), settings)
    }


def test_wall_metrics_of_the_d435_profile_equal_its_stereo_model():
    """realsense_d435: f = 426.2 px, B = 0.05 m, sigma_d = 0.08 px, disparity in 1/32 px steps.
    sigma_Z = Z^2 / (f B) * sqrt(sigma_d^2 + step^2 / 12) (quantisation as uniform noise)."""
    out = run("realsense_d435", distances_m=(1.0,))
    sd = np.sqrt(0.08**2 + (1 / 32) ** 2 / 12)
    sigma_z_mm = 1000 * 1.0**2 / (426.2 * 0.05) * sd
    assert out[("fill_rate_pct", 1.0, 0.0, None)] == 100.0
    assert out[("temporal_noise_mm", 1.0, 0.0, None)] == pytest.approx(sigma_z_mm, rel=0.01)
    assert out[("plane_fit_rms_mm", 1.0, 0.0, None)] == pytest.approx(
        sigma_z_mm * TRIM_RMS, rel=0.015
    )
    assert out[("subpixel_rms_px", 1.0, 0.0, None)] == pytest.approx(sd * TRIM_RMS, rel=0.015)
    assert abs(out[("z_accuracy_pct", 1.0, 0.0, None)]) < 0.05  # no bias in the model
    assert abs(out[("bias_mm", 1.0, 0.0, None)]) < 0.5


def test_temporal_noise_of_the_azure_profile_through_its_lens():
    """azure_kinect_nfov: sigma = 0.5 mm + 1 mm/m beyond 0.5 m, so 2.0 mm on a wall at 2 m. The
    rational lens bends every ray: deprojecting with the wrong rays would bend the plane."""
    out = run("azure_kinect_nfov", distances_m=(2.0,))
    assert out[("temporal_noise_mm", 2.0, 0.0, None)] == pytest.approx(2.0, rel=0.01)
    assert out[("plane_fit_rms_mm", 2.0, 0.0, None)] == pytest.approx(2.0 * TRIM_RMS, rel=0.015)
    assert abs(out[("bias_mm", 2.0, 0.0, None)]) < 0.1
    assert abs(out[("z_accuracy_pct", 2.0, 0.0, None)]) < 0.01


def test_edge_metrics_ideal_step_is_clean_and_tof_mixed_pixels_fly():
    ideal = run("ideal_pinhole", step_distances_m=(1.0,))
    assert ideal[("flying_pixel_pct", 1.0, 0.0, None)] == 0.0
    assert ideal[("edge_fill_pct", 1.0, 0.0, None)] == 100.0
    assert ideal[("lateral_noise_px", 1.0, 0.0, None)] == 0.0
    kinect = run("kinect_v2", step_distances_m=(1.0,))  # mixed_pixels: edge pixels mix both phases
    assert kinect[("flying_pixel_pct", 1.0, 0.0, None)] > 3.0


def test_disparity_banding_of_the_d435_profile_has_its_32_levels():
    out = run("realsense_d435", angles_deg=(30.0,), angle_distances_m=(1.0,))
    assert out[("banding_occupied", 1.0, 30.0, None)] == 32  # 1/32 px steps in 64 bins


def test_material_panels_and_bars_through_the_azure_profile():
    """low_albedo at the specification's operating point (15 % returns to 3.86 m): at 3 m a 15 %
    panel returns everywhere (its pixels lie within 3.3 m), a 5 % one (range 2.2 m) nowhere."""
    out = run("azure_kinect_nfov", panels_distances_m=(3.0,), bars_distances_m=(1.0,))
    assert out[("panel_fill_pct", 3.0, 0.0, "white")] == 100.0
    assert out[("panel_fill_pct", 3.0, 0.0, "dark_15")] == 100.0
    assert out[("panel_fill_pct", 3.0, 0.0, "dark_05")] == 0.0
    assert out[("bar_fill_pct", 1.0, 0.0, "bar_40mm")] == 100.0


def test_same_seed_same_card_other_seed_other_noise():
    a = run("azure_kinect_nfov", frames=2, distances_m=(1.0,))
    assert a == run("azure_kinect_nfov", frames=2, distances_m=(1.0,))
    b = run("azure_kinect_nfov", frames=2, seed=1, distances_m=(1.0,))
    assert b[("temporal_noise_mm", 1.0, 0.0, None)] != a[("temporal_noise_mm", 1.0, 0.0, None)]


def test_command_puts_your_captures_beside_the_profile_and_writes_pages(tmp_path, capsys):
    """genie report-card end to end: the ideal profile (no noise) and a user's noisy captures
    (sigma 3 mm) judged by one figure (temporal noise <= 2 mm at 1.2 m): the profile passes,
    the captures differ; JSON, Markdown, manifest, page, curves and index are written."""
    import json

    from PIL import Image

    from genie_gl import cli
    from genie_gl.resources import data_dir
    from genie_gl.sensors.calibration import read_calibration, write_calibration

    rng = np.random.default_rng(2)
    cap = tmp_path / "cap"
    cap.mkdir()
    for i in range(3):
        Image.fromarray(
            np.round(1200 + 3 * rng.standard_normal((480, 640))).astype(np.uint16)
        ).save(cap / f"{i}.png")
    write_calibration(
        read_calibration(data_dir("sensors") / "ideal_pinhole.calib.yml"), tmp_path / "c.yml"
    )
    ref = tmp_path / "ref.yaml"
    ref.write_text("""sensor: ideal_pinhole
sources:
  test: {citation: "a test's own figure, 2024", where: here, verification: read}
figures:
  - {metric: temporal_noise_mm, distance_m: 1.2, bound: max, value: 2.0, source: test,
     quote: "<= 2 mm"}
""")
    args = [
        "report-card",
        "--sensor",
        "ideal_pinhole",
        "--references",
        str(ref),
        "--frames",
        "2",
        "--quick",
        "--captures",
        str(cap),
        "--calibration",
        str(tmp_path / "c.yml"),
        "--wall-distance",
        "1.2",
        "--out",
        str(tmp_path / "out"),
        "--pages",
        str(tmp_path / "pages"),
    ]
    assert cli.main(args) == 0
    printed = capsys.readouterr().out
    assert (
        "| temporal_noise_mm | 1.2 m | ≤ 2 mm | test (read) | 0 mm (at 1.2 m) | **pass** |"
        in printed
    )
    card = json.loads((tmp_path / "out" / "ideal_pinhole.card.json").read_text())
    (c,) = card["comparisons"]
    assert c["sim"]["verdict"] == "pass" and c["captures"]["verdict"] == "differs"
    assert c["captures"]["ours"] == pytest.approx(np.sqrt(9 + 1 / 12), rel=0.02)
    assert json.loads((tmp_path / "out" / "manifest.json").read_text())["sensors"] == [
        "ideal_pinhole"
    ]
    pages = sorted(p.name for p in (tmp_path / "pages").iterdir())
    assert pages == [
        "ideal_pinhole.md",
        "ideal_pinhole_bias.png",
        "ideal_pinhole_edges.png",
        "ideal_pinhole_fill.png",
        "ideal_pinhole_sigma.png",
        "index.md",
        "manifest.json",
    ]
    manifest = json.loads((tmp_path / "pages" / "manifest.json").read_text())
    assert manifest["command"] == "report-card" and "index.md" in manifest["outputs"]
    assert "[ideal_pinhole.md](ideal_pinhole.md)" in (tmp_path / "pages" / "index.md").read_text()
