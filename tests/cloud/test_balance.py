"""Class-balanced curation (cloud/balance.py): exact quotas, short classes, budget, seeding."""

import json

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.cloud import PointCloud
from genie_gl.cloud.balance import PAPER, balance_chunks, load_target, plan, sample

NAMES = {0: "background", 1: "pallet", 2: "rack", 6: "storage cabinet"}
RNG = lambda: np.random.default_rng(0)  # noqa: E731


def _cloud(counts: dict[int, int], seed: int = 0) -> PointCloud:
    sem = np.concatenate([np.full(n, c, np.uint16) for c, n in counts.items()])
    sem = np.random.default_rng(seed).permutation(sem)
    n = len(sem)
    return PointCloud(
        np.random.default_rng(seed).random((n, 3)).astype(np.float32),
        sem,
        np.arange(n, dtype=np.uint32),
    )


def test_plan_reaches_the_target_exactly_when_every_class_has_enough():
    counts = np.array([[800, 100, 100], [400, 300, 300]])  # background, pallet, rack
    p = plan(counts, np.array([0.5, 0.25, 0.25]), rng=RNG())
    # rack and pallet hold 400 each: N = 1600, background 800 of its 1200
    assert p.quota.sum(0).tolist() == [800, 400, 400]
    assert not p.short and p.keep.all()
    # background spread in proportion to what each chunk holds: 800 * (800/1200, 400/1200)
    assert p.quota[:, 0].tolist() == [533, 267]


def test_a_rare_class_is_short_within_the_tolerance_and_named():
    counts = np.array([[5000, 3000, 10]])
    p = plan(counts, np.array([0.6, 0.39, 0.01]), rng=RNG(), rare=0.02)
    got = p.quota.sum(0)
    assert got[2] == 10  # all it has
    share = got / got.sum()
    assert abs(share[0] - 0.6) < 0.02 and abs(share[1] - 0.39) < 0.02
    assert list(p.short) == [2] and "10 points in the data" in p.short[2]
    # a class with no points at all is named too
    p = plan(np.array([[100, 100, 0]]), np.array([0.5, 0.49, 0.01]), rng=RNG())
    assert p.short[2] == "no points in the chunks kept"


def test_a_plan_that_keeps_nothing_names_the_class_that_limits_it():
    # rack holds 30 points: N = 30 / 0.25 = 120, 60 per chunk, below min_points 100 in both
    counts = np.array([[900, 15, 15], [900, 15, 15]])  # background, pallet, rack
    p = plan(counts, np.array([0.5, 0.25, 0.25]), rng=RNG(), min_points=100)
    assert not p.keep.any() and p.quota.sum() == 0
    assert (
        list(p.short) == [1]
        and "30 points in the data limit the balanced total to 120" in p.short[1]
    )
    assert "min_points 100" in p.short[1]


def test_budget_caps_and_small_or_background_only_chunks_are_dropped():
    counts = np.array([[1000, 1000], [50, 0], [10, 10]])
    p = plan(counts, None, rng=RNG(), budget=1000, min_points=100)
    assert p.quota.sum() <= 1000 and p.keep.tolist() == [True, False, False]
    assert p.quota.sum() >= 990


def test_a_budget_keeps_whole_chunks_rather_than_thinning_them_all():
    counts = np.tile([1000, 2000], (12, 1))  # 12 chunks of 3000 points
    target = np.array([0.25, 0.75])
    p = plan(counts, target, rng=RNG(), budget=10_000, min_points=2000)
    assert p.keep.sum() == 4  # 4 x 3000 is the fewest that reach 10 000
    assert 9990 <= p.quota.sum() <= 10_000 and p.quota[p.keep].sum(1).min() >= 2000
    np.testing.assert_allclose(p.quota.sum(0) / p.quota.sum(), target, atol=1e-3)
    # the chunks kept are drawn: another seed keeps others, the same seed the same
    other = plan(counts, target, rng=np.random.default_rng(1), budget=10_000, min_points=2000)
    again = plan(counts, target, rng=RNG(), budget=10_000, min_points=2000)
    assert np.array_equal(again.keep, p.keep) and not np.array_equal(other.keep, p.keep)


def test_sample_takes_the_quota_of_each_class_without_repeats():
    sem = np.array([0, 1, 1, 0, 2, 1, 0, 0], np.uint16)
    idx = sample(sem, np.array([2, 3, 0]), rng=np.random.default_rng(0))
    assert np.bincount(sem[idx], minlength=3).tolist() == [2, 3, 0]
    assert np.all(np.diff(idx) > 0)


def test_balance_chunks_is_seeded_and_hits_the_counts():
    chunks = [
        ((0, 0), _cloud({0: 3000, 1: 500, 2: 800}, 1)),
        ((0, 1), _cloud({0: 1000, 2: 900}, 2)),
    ]
    target = {0: 0.5, 1: 0.2, 2: 0.3}
    a, pa = balance_chunks(chunks, target, rng=np.random.default_rng(7))
    b, _ = balance_chunks(chunks, target, rng=np.random.default_rng(7))
    assert all(np.array_equal(x.instance, y.instance) for (_, x), (_, y) in zip(a, b))
    got = np.bincount(np.concatenate([t.semantic for _, t in a]), minlength=3)
    assert got.tolist() == [1250, 500, 750]  # pallet's 500 sets N = 2500


def test_targets_from_paper_and_from_a_file(tmp_path):
    t = load_target("paper", NAMES)
    assert t[0] == pytest.approx(PAPER[0] / sum(PAPER.values()))
    (tmp_path / "t.json").write_text(json.dumps({"background": 2, "Storage Cabinet": 1, "2": 1}))
    assert load_target(str(tmp_path / "t.json"), NAMES) == {0: 0.5, 2: 0.25, 6: 0.25}
    (tmp_path / "bad.json").write_text(json.dumps({"backgrund": 1}))
    with pytest.raises(gg.ConfigError, match="did you mean 'background'"):
        load_target(str(tmp_path / "bad.json"), NAMES)
    with pytest.raises(gg.ConfigError, match="cannot read"):
        load_target(str(tmp_path / "missing.json"), NAMES)
