"""Panoptic quality: our figures equal semantic-kitti-api's ``PanopticEval`` (and the summary
``evaluate_panoptic.py`` makes of it) on the written ``.label`` files; the worked example of
Kirillov et al. that the API ships; the instance model and its baselines."""

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from genie_gl.eval import evaluate
from genie_gl.eval.classical import BoostParams
from genie_gl.eval.instances import ClusterParams, cluster, one_per_class
from genie_gl.eval.panoptic import MIN_POINTS, STUFF, PanopticCounts, panoptic_scores
from tests.eval.toy import make_set

FAST = BoostParams(max_points=20_000, rounds=40, early_stop=10)


def _he_example():
    """The API's own example (eval_np.py's __main__, after He et al.): classes ignore, grass,
    sky, person, dog; (pred class, pred id, true class, true id, points)."""
    parts = [
        (0, 0, 0, 0, 50),
        (1, 0, 1, 0, 40),
        (2, 0, 1, 0, 10),
        (2, 0, 2, 0, 40),
        (1, 0, 2, 0, 10),
        (3, 35, 4, 22, 50),
        (3, 8, 3, 33, 150),
        (3, 8, 3, 42, 50),
        (3, 95, 3, 11, 100),
    ]
    cols = [np.concatenate([np.full(n, p[i]) for *p, n in parts]) for i in range(4)]
    return cols  # pred_sem, pred_inst, truth_sem, truth_inst


def test_the_apis_worked_example():
    ps, pi, ts, ti = _he_example()
    counts = PanopticCounts(5, min_points=1)
    counts.add(ts, ti, ps, pi, classes=[1, 2, 3, 4])
    s = panoptic_scores(counts, [1, 2, 3, 4], np.zeros(5), stuff=())
    # the figures eval_np.py prints for this example
    assert s.PQ == pytest.approx(0.47916666666666663, abs=1e-15)
    assert s.SQ == pytest.approx(0.5520833333333333, abs=1e-15)
    assert s.RQ == pytest.approx(0.6666666666666666, abs=1e-15)
    assert_allclose(s.pq[1:], [2 / 3, 2 / 3, 0.5833333333333333, 0.0])
    assert_allclose(s.rq[1:], [1.0, 1.0, 2 / 3, 0.0])


def test_small_segments_are_no_false_positive_but_still_a_match():
    # truth: one 40-point thing; prediction: the same 40 points plus a stray 10-point segment
    ts = np.ones(50, int)
    ti = np.r_[np.full(40, 3), np.zeros(10, int)]
    ps = np.ones(50, int)
    pi = np.r_[np.full(40, 1), np.full(10, 2)]
    c = PanopticCounts(2, min_points=30)
    c.add(ts, ti, ps, pi, [1])
    # the 10 points' true id 0 is a segment of its own (10 points): unmatched but below min_points
    assert (c.tp[1], c.fp[1], c.fn[1]) == (2, 0, 0)
    c2 = PanopticCounts(2, min_points=5)
    c2.add(
        ts, np.full(50, 3), ps, pi, [1]
    )  # one 50-point truth: 40/50 matched, 10-point segment a FP
    assert (c2.tp[1], c2.fp[1], c2.fn[1]) == (1, 1, 0)
    assert c2.iou[1] == pytest.approx(0.8)


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    root = tmp_path_factory.mktemp("toyp")
    return {
        "train": make_set(root / "train", scenes=4, seed=0),
        "test": make_set(root / "test", scenes=2, seed=1),
    }


def _api(res, toy, pred_root, *, zero_stuff: bool, floor_ids=None):
    """PanopticEval run as evaluate_panoptic.py runs it, on the files, and its summary."""
    from auxiliary.eval_np import PanopticEval
    from auxiliary.laserscan import SemLaserScan

    run = res.tests[0].runs[0]
    n_classes = run.confusion.shape[0]
    present = run.classes.tolist()
    ev = PanopticEval(
        n_classes, None, [c for c in range(n_classes) if c not in present], min_points=MIN_POINTS
    )
    colors = {k: [0, 0, 0] for k in range(20)}
    scans = sorted(Path(toy).glob("sequences/*/velodyne/*.bin"))
    assert scans
    for b in scans:
        gt, pr = SemLaserScan(colors), SemLaserScan(colors)
        gt.open_scan(str(b))
        gt.open_label(str(b.parent.parent / "labels" / (b.stem + ".label")))
        pr.open_scan(str(b))
        pr.open_label(
            str(
                pred_root / "sequences" / b.parent.parent.name / "predictions" / (b.stem + ".label")
            )
        )
        gi = gt.inst_label.astype(np.int64)
        if zero_stuff:
            gi[np.isin(gt.sem_label, STUFF)] = 0
        ev.addBatch(
            pr.sem_label.astype(np.int64),
            pr.inst_label.astype(np.int64),
            gt.sem_label.astype(np.int64),
            gi,
        )
    PQ, SQ, RQ, pq, sq, rq = ev.getPQ()
    _, iou = ev.getSemIoU()
    things = [c for c in present if c not in STUFF]
    stuff = [c for c in present if c in STUFF]
    return {
        "PQ": PQ,
        "SQ": SQ,
        "RQ": RQ,
        "pq": pq,
        "sq": sq,
        "rq": rq,
        "present": present,
        # evaluate_panoptic.py's summary over its things and stuff lists
        "PQ_dagger": np.mean([pq[c] for c in things] + [iou[c] for c in stuff]),
        "PQ_th": np.mean([pq[c] for c in things]),
        "SQ_th": np.mean([sq[c] for c in things]),
        "RQ_th": np.mean([rq[c] for c in things]),
        "PQ_st": np.mean([pq[c] for c in stuff]),
    }


def _ours(res) -> dict:
    return res.tests[0].panoptic["model"]


def test_panoptic_equals_semantic_kitti_api_on_the_written_label_files(toy, tmp_path):
    res = evaluate(
        [toy["train"]], [toy["test"]], seeds=[0], out=tmp_path / "out", params=FAST, pictures=False
    )
    pred_root = tmp_path / "out" / "predictions" / "seed0" / "test"
    api = _api(res, toy["test"], pred_root, zero_stuff=False)  # the toy's floor carries instance 0
    ours = _ours(res)
    for k in ("PQ", "SQ", "RQ", "PQ_dagger", "PQ_th", "SQ_th", "RQ_th", "PQ_st"):
        assert ours[k].mean == pytest.approx(float(api[k]), abs=1e-6), k
    for c in api["present"]:
        for k in ("pq", "sq", "rq"):
            assert ours[k][c].mean == pytest.approx(float(api[k][c]), abs=1e-6), (k, c)
    # instances were written (the upper half of the prediction files) and found things
    raw = np.concatenate([np.fromfile(f, "<u4") for f in sorted(pred_root.rglob("*.label"))])
    assert (raw >> 16).max() > 3
    assert 0.2 < ours["PQ_th"].mean < 1.0 and ours["PQ_st"].mean > 0.9
    # the baselines: one instance per class is the floor; the true classes clustered show what the
    # clustering alone loses (a near-perfect model on the toy: close to it, not a strict bound)
    floor, upper = res.tests[0].panoptic["one per class"], res.tests[0].panoptic["true classes"]
    assert floor["PQ_th"].mean < ours["PQ_th"].mean - 0.5
    assert abs(upper["PQ_th"].mean - ours["PQ_th"].mean) < 0.1
    assert res.cluster is not None and res.cluster.eps_by_class  # tuned on the training scans


def test_stuff_ids_in_the_truth_are_not_scored(toy, tmp_path):
    """A floor split into two instance ids in the truth (as genie-gl's exports give floor and walls
    ids of their own): our figures equal the API's with stuff ids taken as 0, and the API on the
    raw files counts the split (a false negative) where ours does not."""
    import shutil

    split = tmp_path / "split"
    shutil.copytree(toy["test"], split)
    for f in sorted(split.glob("sequences/*/labels/*.label")):
        raw = np.fromfile(f, dtype="<u4")
        floor = np.flatnonzero((raw & 0xFFFF) == 0)
        ids = np.where(np.arange(len(floor)) % 2 == 0, 500, 501).astype("<u4")
        raw[floor] = (ids << 16) | (raw[floor] & 0xFFFF)
        raw.tofile(f)
    res = evaluate(
        [toy["train"]], [split], seeds=[0], out=tmp_path / "out", params=FAST, pictures=False
    )
    pred_root = tmp_path / "out" / "predictions" / "seed0" / "split"
    api = _api(res, split, pred_root, zero_stuff=True)
    assert _ours(res)["PQ"].mean == pytest.approx(float(api["PQ"]), abs=1e-6)
    assert _ours(res)["pq"][0].mean == pytest.approx(float(api["pq"][0]), abs=1e-6)
    raw_api = _api(res, split, pred_root, zero_stuff=False)
    assert raw_api["pq"][0] < api["pq"][0] - 0.3  # two 50 %-segments: no match at all


def test_cluster_separates_boxes_and_leaves_stuff_at_zero():
    rng = np.random.default_rng(0)
    a = rng.random((300, 3)) * 0.3
    b = rng.random((300, 3)) * 0.3 + [2.0, 0, 0]
    floor = np.column_stack([rng.random((400, 2)) * 4, np.zeros(400)])
    xyz = np.concatenate([a, b, floor])
    sem = np.r_[np.full(600, 5), np.zeros(400, int)]
    inst = cluster(xyz, sem, ClusterParams(eps_m=0.1, min_samples=4))
    assert (inst[600:] == 0).all()
    assert len(np.unique(inst[:300])) == 1 and len(np.unique(inst[300:600])) == 1
    assert inst[0] != inst[300] and inst[0] > 0
    one = one_per_class(sem)
    assert (one[:600] == 6).all() and (one[600:] == 0).all()


def test_report_names_the_classes_left_out_and_the_points_predicted_as_them(toy, tmp_path):
    """A test set without small load carriers: the report names the class as left out of the
    means, with the number of points predicted as it, counted from the written prediction files."""
    import shutil

    no_klt = tmp_path / "no_klt"
    shutil.copytree(toy["test"], no_klt)
    for f in sorted(no_klt.glob("sequences/*/labels/*.label")):
        raw = np.fromfile(f, dtype="<u4")
        raw[(raw & 0xFFFF) == 9] = 1  # the small load carriers' points become pallet
        raw.tofile(f)
    res = evaluate(
        [toy["train"]], [no_klt], seeds=[0, 1], out=tmp_path / "out", params=FAST, pictures=False
    )
    report = (tmp_path / "out" / "report.md").read_text()
    counted = []
    for seed in (0, 1):
        files = sorted((tmp_path / "out" / "predictions" / f"seed{seed}").rglob("*.label"))
        counted.append(int(sum(((np.fromfile(f, "<u4") & 0xFFFF) == 9).sum() for f in files)))
    assert counted[0] > 100  # the model still finds its boxes: predicted as a class the test lacks
    line = next(x for x in report.splitlines() if x.startswith("Left out of the means"))
    assert (
        f"small load carrier ({counted[0]:,}, {counted[1]:,} points predicted as it, seeds 0, 1)"
        in line
    )
    assert "car (0, 0 points predicted as it" in line
    assert "pallet" not in line and 9 not in res.tests[0].summary["classes"]
