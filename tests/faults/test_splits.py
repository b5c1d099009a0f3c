"""Splits of a SemanticKITTI dataset: every sequence in exactly one split, the sizes as close to
the asked shares as whole sequences allow, and too few sequences for the shares said (the
remainder in train), never a sequence in two splits. Built by the dataset's own assembly
(scenes' scans hard-linked into sequences, past 100 scenes several to a sequence) and read
back from genie-gl.yaml with the semantic-kitti-api's YAML reader."""

import itertools

import numpy as np
import pytest
import yaml

import genie_gl as gg
from genie_gl.export import semantickitti

from .common import fault

WRONG = fault("bad option", "wrong")


def assemble(tmp_path, n_scenes: int, split=(0.8, 0.1, 0.1)) -> dict:
    dirs = []
    for i in range(n_scenes):
        c = gg.PointCloud(
            np.full((3, 3), i, np.float32), np.ones(3, np.uint16), np.arange(3, dtype=np.uint32)
        )
        semantickitti.write_scans([c], tmp_path / "scenes" / f"{i:04d}")
        dirs.append(tmp_path / "scenes" / f"{i:04d}")
    groups = semantickitti.assemble_sequences(tmp_path, dirs, counts={1: 3 * n_scenes}, split=split)
    return groups, yaml.safe_load((tmp_path / "genie-gl.yaml").read_text())["split"]


@WRONG
@pytest.mark.parametrize(
    "n_scenes, sizes, said",
    [
        (1, (1, 0, 0), True),
        (2, (2, 0, 0), True),
        (3, (3, 0, 0), True),
        (10, (8, 1, 1), False),
        (101, (41, 5, 5), False),
    ],
)  # 101 scenes: two to a sequence, 51 sequences
def test_no_sequence_is_in_two_splits(tmp_path, n_scenes, sizes, said):
    groups, split = assemble(tmp_path, n_scenes)
    seqs = sorted(groups)
    parts = [split[s] for s in ("train", "valid", "test")]
    for a, b in itertools.combinations(parts, 2):
        assert not set(a) & set(b), split
    assert sorted(sum(parts, [])) == seqs  # every sequence in a split
    assert tuple(len(p) for p in parts) == sizes
    scenes = sorted(i for g in groups.values() for i in g)
    assert scenes == list(range(n_scenes))  # every scene in one sequence
    note = semantickitti.split_note(len(seqs), (0.8, 0.1, 0.1))
    assert (note is not None) == said
    if said:
        assert (
            "valid and test get none, the rest is in train" in note
            and "7 sequences would give" in note
        )


@WRONG
@pytest.mark.parametrize(
    "ratios", [(0.8, 0.1, 0.1), (0.6, 0.2, 0.2), (0.5, 0.5, 0.0), (1, 1, 1), (0.7, 0.0, 0.3)]
)
def test_the_sizes_are_as_close_as_whole_sequences_allow(ratios):
    """Nearest: for 1..100 sequences, no other split into whole sequences is closer to the
    shares (total absolute deviation); a share of 0 gets none."""
    for n in range(1, 101):
        sizes = semantickitti.split_sizes(n, ratios)
        exact = [n * r / sum(ratios) for r in ratios]
        best = min(
            sum(abs(a - e) for a, e in zip(c, exact))
            for c in ((a, b, n - a - b) for a in range(n + 1) for b in range(n + 1 - a))
        )
        assert sum(sizes) == n and sum(abs(s - e) for s, e in zip(sizes, exact)) == pytest.approx(
            best
        ), (n, sizes)
        assert all(s == 0 for s, r in zip(sizes, ratios) if r == 0)


@WRONG
def test_one_exported_cloud_is_in_train_only(tmp_path):
    c = gg.PointCloud(np.zeros((2, 3), np.float32), np.ones(2, np.uint16), np.ones(2, np.uint32))
    gg.export(c, tmp_path, format="semantickitti", sequence=7)
    split = yaml.safe_load((tmp_path / "genie-gl.yaml").read_text())["split"]
    assert split == {"train": [7], "valid": [], "test": []}


@WRONG
def test_a_dataset_says_its_split_is_short_before_any_work():
    from genie_gl.dataset.config import DatasetConfig
    from genie_gl.export import get_format

    notes = get_format("semantickitti").notes
    short = DatasetConfig.parse({"strategy": "assembly_line", "out": "o", "scenes": 3})
    assert notes(short) == [f"--scenes 3: {semantickitti.split_note(3)}"]
    assert notes(DatasetConfig.parse({"strategy": "assembly_line", "out": "o", "scenes": 10})) == []
    assert (
        notes(
            DatasetConfig.parse(
                {"strategy": "assembly_line", "out": "o", "scenes": 3, "split": (1.0, 0.0, 0.0)}
            )
        )
        == []
    )
