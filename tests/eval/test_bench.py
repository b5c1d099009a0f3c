"""``genie eval --bench`` times features, training and prediction on the points asked for."""

import pytest

from genie_gl.errors import ConfigError
from genie_gl.eval.bench import bench_training
from genie_gl.eval.classical import BoostParams
from tests.eval.toy import make_set


def test_bench_reports_each_step_on_the_points_asked_for(tmp_path):
    root = make_set(tmp_path / "s", scenes=3, seed=0, points=3000)
    text = bench_training(
        [str(root)],
        out=tmp_path / "o",
        workers=1,
        points=5000,
        params=BoostParams(max_points=5000, rounds=10),
    )
    assert "classical model on 5,996 points (2 scans" in text
    for step in ("features", "training (", "prediction of the 5,996 points"):
        assert step in text
    assert (tmp_path / "o" / "bench.md").read_text() == text
    with pytest.raises(ConfigError, match="fewer than the 100,000"):
        bench_training([str(root)], workers=1, points=100_000)
