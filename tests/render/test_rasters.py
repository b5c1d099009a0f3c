"""Choosing the raster by name, and a dataset keeping the one it was made with."""

import json

import pytest

import genie_gl as gg
from genie_gl.dataset.config import DatasetConfig
from genie_gl.dataset.manifest import check_resume, fingerprint, recorded_raster
from genie_gl.dataset.recipe import load_inputs
from genie_gl.render.rasters import check_raster, default_raster, hardware_gpu, resolve_raster


def test_a_raster_is_named_and_the_default_follows_the_machine():
    assert check_raster(None, "x") is None and check_raster("gl", "x") == "gl"
    with pytest.raises(
        gg.ConfigError, match="x: raster 'gll' is unknown; expected cpu or gl; did you mean 'gl'"
    ):
        check_raster("gll", "x")
    assert resolve_raster("cpu") == "cpu" and resolve_raster(None) == default_raster()
    assert default_raster() == ("gl" if hardware_gpu() else "cpu")
    with pytest.raises(gg.ConfigError, match="accuracy.raster: expected cpu | gl or null"):
        gg.AccuracySettings(raster="vulkan")


def parts(tmp_path, **kw):
    cfg = DatasetConfig(strategy="assembly_line", out=str(tmp_path / "ds"), **kw)
    inputs = load_inputs(cfg)
    return fingerprint(cfg, inputs.strategy, inputs.sensor)


def test_a_gl_dataset_keeps_its_fingerprint_and_a_resume_never_changes_the_raster(tmp_path):
    """--raster gl fingerprints as a dataset made before the choice existed (so those resume
    and are made again byte for byte); cpu is a part of its own; a folder made with one
    raster refuses a resume with the other, naming it; a manifest without a raster was GL's."""
    before, gl, cpu = parts(tmp_path), parts(tmp_path, raster="gl"), parts(tmp_path, raster="cpu")
    assert gl == before and "raster" not in gl["parts"] and cpu["parts"]["raster"] == "cpu"
    out = tmp_path / "ds"
    out.mkdir()
    (out / "scenes").mkdir()
    (out / "manifest.json").write_text(
        json.dumps(
            {"fingerprint": cpu, "inputs": {"raster": "cpu"}, "runs": [{}], "outputs": ["scenes"]}
        )
    )
    assert recorded_raster(out) == "cpu"
    assert check_resume(out, cpu) is not None
    with pytest.raises(gg.ConfigError, match="raster 'cpu' -> None"):
        check_resume(out, gl)
    (out / "manifest.json").write_text(json.dumps({"fingerprint": before, "inputs": {}}))
    assert recorded_raster(out) == "gl"
    assert recorded_raster(tmp_path / "nothing") is None
