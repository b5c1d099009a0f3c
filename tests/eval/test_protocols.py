"""The paper's protocols on toy sets: the synthetic share each ratio reaches, the mix curve,
fine-tuning from synthetic weights, and the scarce preset's three classes."""

import numpy as np
import pytest

from genie_gl.eval import protocols, read_set
from genie_gl.eval.classical import BoostParams
from genie_gl.studies.report import preset_markdown
from tests.eval.toy import make_set

FAST = BoostParams(max_points=10_000, rounds=20, early_stop=5)


@pytest.fixture(scope="module")
def sets(tmp_path_factory):
    root = tmp_path_factory.mktemp("proto")
    return {
        "real": make_set(root / "real", scenes=2, seed=10, points=3000),
        "test": make_set(root / "test", scenes=1, seed=11, points=3000),
        "syn": make_set(root / "syn", scenes=6, seed=12, points=3000, scans_per_scene=2),
    }


@pytest.mark.parametrize("ratio", [0.1, 0.5, 0.8])
def test_synthetic_share_reaches_the_ratio_within_one_scan(sets, ratio):
    real, syn = read_set(sets["real"]), read_set(sets["syn"])
    chosen = protocols.synthetic_share(real, [syn], ratio, rng=np.random.default_rng(0))
    n = sum(len(s) for s in chosen)
    scan = max(len(s) for s in syn.scans)
    assert abs(n / (n + real.n_points) - ratio) <= scan / (n + real.n_points)
    assert len({s.key for s in chosen}) == len(chosen)
    assert protocols.synthetic_share(real, [syn], 0.0, rng=np.random.default_rng(0)) == []


def test_mix_writes_its_curve_with_a_spread(sets, tmp_path):
    res = protocols.mix(
        sets["real"],
        sets["test"],
        [sets["syn"]],
        out=tmp_path,
        seeds=[0, 1],
        ratios=(0.0, 0.5),
        params=FAST,
    )
    assert res["ratios"] == [0.0, 0.5]
    assert [len(v) for v in res["results"].values()] == [2, 2]
    assert res["results"][0.5][0].n_train_points > res["results"][0.0][0].n_train_points
    text = preset_markdown("mix", res, tmp_path)
    assert "| 50% |" in text and (tmp_path / "mix-curve.png").stat().st_size > 1000
    assert all(0.3 < s.mean <= 1.0 for s in res["summary"]["mIoU"])


def test_finetune_goes_on_from_the_synthetic_model(sets, tmp_path):
    # early stopping as long as the training: every booster trained from scratch holds at most
    # ``rounds`` rounds, and the synthetic model handed to fine-tuning holds all of them
    params = BoostParams(max_points=10_000, rounds=20, early_stop=20)
    res = protocols.finetune(
        sets["real"], sets["test"], [sets["syn"]], out=tmp_path, seeds=[0, 1], params=params
    )
    assert set(res) == {"target only", "synthetic only", "synthetic then target"}
    tuned, alone, syn = res["synthetic then target"], res["target only"], res["synthetic only"]
    assert all(1 <= r <= params.rounds for r in alone.rounds + syn.rounds)
    # the fine-tuned booster holds the synthetic model's rounds and at least one of its own
    assert all(r > params.rounds for r in tuned.rounds)
    assert tuned.n_train_points == alone.n_train_points


def test_scarce_scores_only_its_three_classes(sets, tmp_path):
    res = protocols.mix(
        sets["real"],
        sets["test"],
        [sets["syn"]],
        out=tmp_path,
        seeds=[0],
        ratios=(0.0,),
        scarce=True,
        params=FAST,
    )
    run = res["results"][0.0][0].tests[0].runs[0]
    assert run.classes.tolist() == [1, 2, 9]
    assert run.confusion.shape == (10, 10) and run.confusion[3:9].sum() == 0
