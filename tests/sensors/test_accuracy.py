"""The accuracy settings and their ``accuracy:`` block: round trips, named errors, profiles."""

import dataclasses

import numpy as np
import pytest

from genie_gl.capture import apply_to_sensor, frame_costs
from genie_gl.dataset.report import dataset_cost
from genie_gl.sensors.accuracy import AccuracySettings, from_dict, load_accuracy, write_accuracy
from genie_gl.errors import ConfigError


def test_a_written_block_reads_back_equal_through_yaml_and_json(tmp_path):
    s = AccuracySettings(
        supersample=2,
        resample="bilinear",
        depth_precision="reversed_z",
        shadow_scale=0.25,
        tessellation=48,
        multipath_samples=8,
        oversample=1.5,
        shadow="render",
    )
    path = write_accuracy(tmp_path / "acc.yaml", s, comment="two\nlines")
    assert path.read_text().startswith("# two\n# lines\n# written by genie-gl\naccuracy:\n")
    assert load_accuracy(path) == s
    import json

    (tmp_path / "acc.json").write_text(json.dumps({"accuracy": s.to_dict()}))
    assert load_accuracy(tmp_path / "acc.json") == s
    (tmp_path / "bare.yaml").write_text("supersample: 4\n")  # the bare mapping also reads
    assert load_accuracy(tmp_path / "bare.yaml") == AccuracySettings(supersample=4)
    assert s.changed()["supersample"] == 2 and AccuracySettings().label() == "default"


@pytest.mark.parametrize(
    "block, message",
    [
        ({"supersample": 3}, "accuracy.supersample: expected 1, 2 or 4, got 3"),
        ({"supersample": True}, "accuracy.supersample: expected 1, 2 or 4"),
        ({"resample": "bilinaer"}, "did you mean 'bilinear'"),
        (
            {"depth_precision": "half"},
            "accuracy.depth_precision: expected float32 | depth24 | reversed_z",
        ),
        ({"shadow_scale": 0}, "accuracy.shadow_scale: expected a number in (0, 4]"),
        (
            {"shadow": "scanlines"},
            "accuracy.shadow: expected scanline | render or null; did you mean 'scanline'?",
        ),
        ({"tessellation": 2}, "accuracy.tessellation: expected an integer >= 3"),
        ({"oversample": "big"}, "accuracy.oversample"),
        ({"supersampel": 2}, "accuracy.supersampel: unknown setting; did you mean 'supersample'?"),
    ],
)
def test_bad_settings_name_the_file_and_the_field(block, message, tmp_path):
    import yaml

    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump({"accuracy": block}))
    with pytest.raises(ConfigError) as exc:
        load_accuracy(path)
    assert message in str(exc.value) and str(path) in str(exc.value)
    assert len(str(exc.value).splitlines()) == 1


def test_a_profile_carries_its_accuracy_block_and_capture_settings_apply_to_effects(tmp_path):
    from genie_gl.resources import resolve
    from genie_gl.effects.profile import load_sensor

    src = resolve("realsense_d435", "sensors", (".yaml",))
    text = src.read_text().replace(
        "calibration: realsense_d435.calib.yml",
        f"calibration: {src.parent / 'realsense_d435.calib.yml'}",
    )
    (tmp_path / "d435.yaml").write_text(
        text + "accuracy:\n  supersample: 2\n  shadow_scale: 0.25\n"
    )
    sensor = load_sensor(tmp_path / "d435.yaml")
    acc = sensor.accuracy
    assert acc == AccuracySettings(supersample=2, shadow_scale=0.25)
    shadow = [e for e in apply_to_sensor(sensor, acc).effects if e.name == "stereo_shadow"]
    assert shadow[0].scale == 0.25
    # null keeps the profile's own scale
    own = [
        e for e in apply_to_sensor(sensor, AccuracySettings()).effects if e.name == "stereo_shadow"
    ]
    assert own[0].scale == [e for e in sensor.effects if e.name == "stereo_shadow"][0].scale
    # the method: the profile's (scanline for the D435's rectified pair) unless the block says
    assert own[0].resolved_method(sensor) == "scanline"
    rendered = [
        e
        for e in apply_to_sensor(sensor, AccuracySettings(shadow="render")).effects
        if e.name == "stereo_shadow"
    ]
    assert rendered[0].method == "render" and rendered[0].resolved_method(sensor) == "render"
    (tmp_path / "bad.yaml").write_text(text + "accuracy:\n  supersample: 5\n")
    with pytest.raises(ConfigError, match="bad.yaml: accuracy.supersample"):
        load_sensor(tmp_path / "bad.yaml")


def test_costs_sum_per_part_and_divide_by_the_frames():
    @dataclasses.dataclass
    class F:
        meta: dict

    frames = [F({"cost_ms": {"render": 10.0, "effect:depth_noise": 2.0}}), F({"render_ms": 6.0})]
    assert frame_costs(frames) == {"render": 16.0, "effect:depth_noise": 2.0}
    stats = [
        {"cameras": 2, "timings_s": {"capture": 0.5}, "frame_cost_ms": {"render": 16.0}},
        {"cameras": 2, "timings_s": {"capture": 0.3}, "frame_cost_ms": {"render": 4.0}},
    ]
    cost = dataset_cost(stats)
    assert cost["frames"] == 4
    assert cost["stages"]["capture"]["total_ms"] == pytest.approx(800.0)
    assert cost["stages"]["capture"]["per_frame_ms"] == pytest.approx(200.0)
    assert cost["capture"]["render"] == {"total_ms": 20.0, "per_frame_ms": 5.0}
    assert from_dict(None, "x") == AccuracySettings() and np.isfinite(
        cost["stages"]["capture"]["total_ms"]
    )


def test_genie_dataset_refuses_a_bad_accuracy_file_in_one_line_before_making_anything(
    tmp_path, capsys
):
    from genie_gl.cli import main

    (tmp_path / "acc.yaml").write_text("accuracy:\n  depth_precision: half\n")
    assert (
        main(
            [
                "dataset",
                "assembly_line",
                "--out",
                str(tmp_path / "o"),
                "--accuracy",
                str(tmp_path / "acc.yaml"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert "acc.yaml: accuracy.depth_precision: expected float32 | depth24 | reversed_z" in err
    assert len(err.splitlines()) == 1 and not (tmp_path / "o").exists()
