"""The neural model (PyTorch, CPU) on the toy: it learns (beats the majority class), the same
seed gives the same predictions, and its predictions go through the same metrics and files."""

import numpy as np
import pytest

from genie_gl.eval import evaluate
from genie_gl.eval.neural import NeuralParams, tiles
from tests.eval.toy import make_set

SMALL = NeuralParams(steps=160, validate_every=80, batch_tiles=2, width=16, learning_rate=5e-3)


def test_tiles_cover_every_point_once_and_respect_the_size():
    rng = np.random.default_rng(0)
    xy = rng.random((5000, 2)) * [9.0, 5.0]
    parts = tiles(xy, 4.0, 700, rng=rng)
    idx = np.concatenate(parts)
    assert np.array_equal(np.sort(idx), np.arange(5000))
    assert max(len(p) for p in parts) <= 700
    for p in parts:  # each part inside one 4 m square
        cell = np.floor((xy[p] - xy.min(0)) / 4.0)
        assert (cell == cell[0]).all()


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    root = tmp_path_factory.mktemp("toyn")
    return make_set(root / "train", scenes=3, seed=0, points=3000), make_set(
        root / "test", scenes=1, seed=1, points=3000
    )


def test_the_neural_model_learns_and_is_reproducible(toy, tmp_path):
    train, test = toy
    runs = [
        evaluate(
            [train],
            [test],
            model="neural",
            seeds=[0],
            params=SMALL,
            workers=1,
            out=tmp_path / f"n{i}",
            pictures=False,
        )
        for i in range(2)
    ]
    majority = evaluate([train], [test], model="majority", seeds=[0]).tests[0].runs[0]
    s = runs[0].tests[0].runs[0]
    assert s.miou > majority.miou + 0.15
    assert s.oa > 0.6
    a = sorted((tmp_path / "n0" / "predictions").rglob("*.label"))
    assert a and all(
        (tmp_path / "n1" / f.relative_to(tmp_path / "n0")).read_bytes() == f.read_bytes() for f in a
    )
    assert (tmp_path / "n0" / "metrics.json").read_bytes() == (
        tmp_path / "n1" / "metrics.json"
    ).read_bytes()
