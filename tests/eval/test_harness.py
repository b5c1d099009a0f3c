"""The harness end to end on tiny toy sets (seconds): scores equal semantic-kitti-api's
``iouEval`` on the written ``.label`` files, and planted bugs move the scores as they must."""

from pathlib import Path

import numpy as np
import pytest
import yaml
from numpy.testing import assert_allclose

from genie_gl.eval import evaluate, read_set
from genie_gl.eval.classical import BoostParams
from tests.eval.toy import make_set, relabel

FAST = BoostParams(max_points=20_000, rounds=40, early_stop=10)


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    root = tmp_path_factory.mktemp("toy")
    return {
        "train": make_set(root / "train", scenes=4, seed=0),
        "test": make_set(root / "test", scenes=2, seed=1),
    }


def _run(toy, tmp_path, **kw):
    args = dict(model="classical", seeds=[0], out=tmp_path / "out", params=FAST, pictures=False)
    args.update(kw)
    return evaluate([args.pop("train", toy["train"])], [args.pop("test", toy["test"])], **args)


def test_scores_equal_semantic_kitti_api_on_the_written_label_files(toy, tmp_path):
    from auxiliary.laserscan import SemLaserScan
    from auxiliary.np_ioueval import iouEval

    res = _run(toy, tmp_path, seeds=[0, 1, 2])
    colors = {k: [0, 0, 0] for k in range(20)}
    for k, seed in enumerate(res.seeds):
        ours = res.tests[0].runs[k]
        pred_root = tmp_path / "out" / "predictions" / f"seed{seed}" / "test"
        n_classes = ours.confusion.shape[0]
        present = ours.classes.tolist()
        ev = iouEval(n_classes, [c for c in range(n_classes) if c not in present])
        scans = sorted(Path(toy["test"]).glob("sequences/*/velodyne/*.bin"))
        assert scans
        for b in scans:
            gt, pr = SemLaserScan(colors), SemLaserScan(colors)
            gt.open_scan(str(b))
            gt.open_label(str(b.parent.parent / "labels" / (b.stem + ".label")))
            pr.open_scan(str(b))
            pr.open_label(
                str(
                    pred_root
                    / "sequences"
                    / b.parent.parent.name
                    / "predictions"
                    / (b.stem + ".label")
                )
            )
            ev.addBatch(pr.sem_label.astype(np.int64), gt.sem_label.astype(np.int64))
        miou, iou = ev.getIoU()
        assert_allclose(ours.miou, miou, rtol=1e-12)
        assert_allclose(ours.iou[present], iou[present], rtol=1e-12)
        assert (ev.get_confusion().T == ours.confusion).all()  # the API's rows are predictions
        assert 0.5 < ours.miou < 1.0


def test_a_good_model_beats_the_baselines_on_the_toy(toy, tmp_path):
    good = _run(toy, tmp_path / "a").tests[0].runs[0].miou
    height = _run(toy, tmp_path / "b", model="height").tests[0].runs[0].miou
    majority = _run(toy, tmp_path / "c", model="majority").tests[0].runs[0]
    assert good > 0.85
    assert majority.miou == pytest.approx(
        majority.iou[0] / len(majority.classes)
    )  # background everywhere
    assert good > height > majority.miou


def test_planted_label_permutation_in_the_test_set_is_caught(toy, tmp_path):
    import shutil

    bad = tmp_path / "permuted"
    shutil.copytree(toy["test"], bad)
    relabel(bad, {1: 2, 2: 1})  # pallet <-> rack
    good = _run(toy, tmp_path / "a").tests[0].runs[0]
    planted = _run(toy, tmp_path / "b", test=bad).tests[0].runs[0]
    assert planted.iou[1] < 0.1 and planted.iou[2] < 0.1
    assert planted.miou < good.miou - 0.35


def test_planted_off_by_one_class_is_caught_and_the_unseen_class_reported(toy, tmp_path):
    import shutil

    bad = tmp_path / "shifted"
    shutil.copytree(toy["test"], bad)
    relabel(bad, {9: 10, 2: 3, 1: 2, 0: 1})  # every class id one up (applied in this order)
    cfg = yaml.safe_load((bad / "genie-gl.yaml").read_text())
    cfg["labels"][10] = "shifted"  # a set's yaml names its ids: an id it does not name is refused
    (bad / "genie-gl.yaml").write_text(yaml.safe_dump(cfg))
    res = _run(toy, tmp_path / "b", test=bad)
    run = res.tests[0].runs[0]
    assert run.miou < 0.1
    assert 10 in res.tests[0].unseen and 3 in res.tests[0].unseen


def test_shuffled_training_labels_fall_to_chance(toy, tmp_path):
    import shutil

    shuffled = tmp_path / "shuffled"
    shutil.copytree(toy["train"], shuffled)
    rng = np.random.default_rng(0)
    for f in sorted(shuffled.glob("sequences/*/labels/*.label")):
        raw = np.fromfile(f, dtype="<u4")
        rng.permutation(raw).astype("<u4").tofile(f)
    chance = _run(toy, tmp_path / "b", train=shuffled).tests[0].runs[0]
    good = _run(toy, tmp_path / "a").tests[0].runs[0]
    # a model that learnt nothing: each class's IoU at most its share of the points (~0.3 here)
    shares = chance.confusion.sum(1) / chance.confusion.sum()
    assert chance.miou < 0.3 and good.miou > chance.miou + 0.5
    assert (chance.iou[chance.classes] <= shares[chance.classes] + 0.1).all()


def test_same_seed_same_bytes_and_one_or_two_workers_agree(toy, tmp_path):
    outs = []
    for i, workers in enumerate((1, 2, 2)):
        _run(toy, tmp_path / f"r{i}", seeds=[3], workers=workers)
        outs.append(tmp_path / f"r{i}" / "out")
    for o in outs[1:]:
        assert (o / "metrics.json").read_bytes() == (outs[0] / "metrics.json").read_bytes()
        files = sorted((outs[0] / "predictions").rglob("*.label"))
        assert files
        for f in files:
            assert (o / f.relative_to(outs[0])).read_bytes() == f.read_bytes()
    _run(
        toy, tmp_path / "r9", seeds=[4]
    )  # another seed: another sub-sample and bagging, other trees
    other = tmp_path / "r9" / "out" / "predictions" / "seed4"
    first = outs[0] / "predictions" / "seed3"
    assert any(
        (other / f.relative_to(first)).read_bytes() != f.read_bytes()
        for f in first.rglob("*.label")
    )


@pytest.mark.parametrize("fmt", ["ply", "npz"])
def test_ply_and_npz_sets_read_as_the_same_points(tmp_path, fmt):
    a = read_set(make_set(tmp_path / "sk", scenes=2, seed=5))
    b = read_set(make_set(tmp_path / fmt, scenes=2, seed=5, fmt=fmt))
    assert b.format == fmt and a.n_points == b.n_points
    for sa, sb in zip(a.scans, b.scans):
        assert_allclose(sa.xyz + sa.origin, sb.xyz + sb.origin, atol=1e-6)
        assert (sa.label == sb.label).all()


def test_parts_of_a_set(tmp_path):
    root = make_set(tmp_path / "sk", scenes=3, seed=5)
    assert len(read_set(f"{root}:00,02").scans) == 2
    assert len(read_set(f"{root}:test").scans) == 3
