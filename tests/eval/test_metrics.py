"""The paper's metrics on hand-made confusion matrices (values worked out by hand), the
spread over seeds and the rule that a difference within its spread is no gain."""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from genie_gl.errors import ConfigError
from genie_gl.eval.metrics import Spread, compare, confusion, delta_text, scores, summarise


def test_confusion_counts_pairs_and_leaves_out_unlabelled():
    truth = np.array([0, 0, 1, 1, 1, 2, -1, -1])
    pred = np.array([0, 1, 1, 1, 0, 2, 2, 0])
    c = confusion(truth, pred, 3)
    assert c.tolist() == [[1, 1, 0], [1, 2, 0], [0, 0, 1]]
    assert c.sum() == 6


def test_scores_of_a_hand_made_matrix():
    # rows = truth, columns = prediction
    conf = np.array([[50, 10, 0], [5, 20, 5], [0, 0, 10]])
    s = scores(conf)
    # class 0: TP 50, FN 10, FP 5 -> IoU 50/65, Acc 50/60
    # class 1: TP 20, FN 10, FP 10 -> IoU 20/40, Acc 20/30
    # class 2: TP 10, FN 0, FP 5 -> IoU 10/15, Acc 1
    assert_allclose(s.iou, [50 / 65, 0.5, 10 / 15])
    assert_allclose(s.acc, [50 / 60, 20 / 30, 1.0])
    assert_allclose(s.miou, (50 / 65 + 0.5 + 10 / 15) / 3)
    assert_allclose(s.macc, (50 / 60 + 20 / 30 + 1.0) / 3)
    assert_allclose(s.oa, 80 / 100)


def test_absent_class_is_not_averaged_but_its_false_positives_count():
    conf = np.array(
        [
            [8, 0, 2],  # class 2 has no true point: 2 false positives
            [0, 10, 0],
            [0, 0, 0],
        ]
    )
    s = scores(conf)
    assert s.classes.tolist() == [0, 1]
    assert math.isnan(s.iou[2])
    assert_allclose(s.iou[0], 8 / 10)  # the 2 points predicted as class 2 are class 0's misses
    assert_allclose(s.miou, (0.8 + 1.0) / 2)
    assert_allclose(s.oa, 18 / 20)


def test_perfect_and_all_wrong():
    assert scores(np.diag([3, 4, 5])).miou == 1.0
    s = scores(np.array([[0, 7], [9, 0]]))
    assert s.miou == 0.0 and s.oa == 0.0 and s.macc == 0.0


def test_given_classes_restrict_the_means():
    conf = np.array([[90, 10, 0], [0, 5, 5], [0, 0, 10]])
    s = scores(conf, classes=[1, 2])
    assert s.classes.tolist() == [1, 2]
    assert_allclose(s.miou, (5 / 20 + 10 / 15) / 2)


def test_bad_inputs_are_one_line_errors():
    with pytest.raises(ConfigError, match="square"):
        scores(np.zeros((2, 3)))
    with pytest.raises(ConfigError, match="no labelled test point"):
        scores(np.zeros((3, 3), np.int64))
    with pytest.raises(ConfigError, match="class ids must lie"):
        confusion(np.array([0, 3]), np.array([0, 1]), 3)


def test_spread_is_mean_and_sample_std():
    s = Spread.of([0.40, 0.44, 0.48])
    assert_allclose([s.mean, s.std, s.lo, s.hi], [0.44, 0.04, 0.40, 0.48])
    assert s.text() == "0.440 ± 0.040"
    assert Spread.of([0.5]).std == 0.0


def test_a_difference_within_its_spread_is_not_a_gain():
    a, b = Spread.of([0.50, 0.52, 0.54]), Spread.of([0.49, 0.50, 0.51])
    d, spread, verdict = compare(a, b)
    assert_allclose([d, spread], [0.02, 0.02 + 0.01])
    assert verdict == "within spread"
    assert "within spread" in delta_text(a, b)
    c = Spread.of([0.60, 0.61, 0.62])
    assert compare(c, b)[2] == "gain" and compare(b, c)[2] == "loss"


def test_summarise_sums_confusions_and_spreads_per_class():
    runs = [
        scores(np.array([[9, 1], [1, 9]])),
        scores(np.array([[8, 2], [2, 8]])),
        scores(np.array([[10, 0], [0, 10]])),
    ]
    s = summarise(runs)
    assert s["confusion"].tolist() == [[27, 3], [3, 27]]
    assert_allclose(s["iou"][0].values, [9 / 11, 8 / 12, 1.0])
    assert_allclose(s["miou"].mean, np.mean([9 / 11, 8 / 12, 1.0]))
