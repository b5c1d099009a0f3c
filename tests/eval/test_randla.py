"""RandLA-Net on the toy (PyTorch, CPU): the crop's random-sampling pyramid, learning (beats
the majority class), the same seed giving the same bytes, the learning curve recorded, and every
test point predicted."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from genie_gl.eval import evaluate
from genie_gl.eval.randla import RandLAParams, crop
from tests.eval.toy import make_set

SMALL = RandLAParams(
    points=512,
    widths=(8, 16, 32),
    steps=50,
    validate_every=25,
    batch=2,
    learning_rate=1e-2,
    val_crops=4,
)


def test_a_crop_is_the_nearest_points_in_a_random_order_with_each_levels_neighbours():
    rng = np.random.default_rng(0)
    xyz = (rng.random((3000, 3)) * [6, 6, 2]).astype(np.float32)
    tree = cKDTree(xyz)
    p = RandLAParams(points=1024, k=8, widths=(8, 16), ratio=4)
    c = crop(xyz, xyz[:, 2], np.zeros(3000, np.int64), tree, 7, p, rng=rng)
    nearest = np.sort(tree.query(xyz[7], k=1024)[1])
    assert np.array_equal(np.sort(c.index), nearest) and not np.array_equal(
        c.index, np.sort(c.index)
    )
    assert [len(x) for x in c.xyz] == [1024, 256, 64]  # random sampling: the first quarter
    assert np.array_equal(c.xyz[1], c.xyz[0][:256])
    for lvl in range(2):
        pts = c.xyz[lvl]
        d_nbr = np.linalg.norm(pts[c.nbr[lvl]] - pts[:, None], axis=-1).max(1)
        assert np.allclose(d_nbr, cKDTree(pts).query(pts, k=8)[0][:, -1])  # the k nearest
        up = c.xyz[lvl + 1][c.up[lvl]]
        assert np.allclose(np.linalg.norm(up - pts, axis=1), cKDTree(c.xyz[lvl + 1]).query(pts)[0])
    assert np.allclose(c.xyz[0], xyz[c.index] - xyz[7]) and np.allclose(c.x[:, 2], xyz[c.index, 2])


def test_a_small_scan_is_padded_with_its_own_points():
    rng = np.random.default_rng(1)
    xyz = rng.random((100, 3)).astype(np.float32)
    c = crop(
        xyz,
        xyz[:, 2],
        np.arange(100),
        cKDTree(xyz),
        0,
        RandLAParams(points=512, widths=(8, 16)),
        rng=rng,
    )
    assert len(c.index) == 512 and set(c.index.tolist()) == set(range(100))
    assert np.array_equal(c.y, c.index)


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    root = tmp_path_factory.mktemp("toyr")
    return make_set(root / "train", scenes=3, seed=0, points=2000), make_set(
        root / "test", scenes=1, seed=1, points=2000
    )


def test_randla_learns_is_reproducible_and_records_its_curve(toy, tmp_path):
    train, test = toy
    runs = [
        evaluate(
            [train],
            [test],
            model="randla",
            seeds=[0],
            params=SMALL,
            workers=1,
            out=tmp_path / f"r{i}",
            pictures=False,
        )
        for i in range(2)
    ]
    majority = evaluate([train], [test], model="majority", seeds=[0]).tests[0].runs[0]
    s = runs[0].tests[0].runs[0]
    assert s.miou > majority.miou + 0.15 and s.confusion.sum() == runs[0].tests[0].n_points
    a = sorted((tmp_path / "r0" / "predictions").rglob("*.label"))
    assert a and all(
        (tmp_path / "r1" / f.relative_to(tmp_path / "r0")).read_bytes() == f.read_bytes() for f in a
    )
    assert (tmp_path / "r0" / "metrics.json").read_bytes() == (
        tmp_path / "r1" / "metrics.json"
    ).read_bytes()
    curve = runs[0].timings["learning_curves"][0]
    assert [c["step"] for c in curve] == [25, 50]
    assert all(0 <= c["val_miou"] <= 1 and c["seconds"] > 0 and c["epoch"] > 0 for c in curve)


def test_steps_on_the_command_line(tmp_path, capsys):
    from genie_gl.cli import main
    from genie_gl.commands.eval import _params

    assert _params("randla", 7) == RandLAParams(steps=7)
    assert _params("classical", None) is None
    root = make_set(tmp_path / "s", scenes=1, seed=0, points=500)
    assert (
        main(
            [
                "eval",
                "--train",
                str(root),
                "--test",
                str(root),
                "--steps",
                "5",
                "--out",
                str(tmp_path / "o"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--steps: the classical model has no training steps" in err[0]
