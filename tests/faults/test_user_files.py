"""A user's own files inside a dataset genie-gl wrote: a model's ``sequences/NN/predictions/``
(where semantic-kitti-api's ``evaluate_semantics.py`` reads them), notes in a scene folder, a
draft named ``*.tmp``. genie-gl replaces or removes only the files it wrote: a re-run that
makes nothing, a scene made again (a damaged scan, a ``--verify`` mismatch, a balanced scene),
a regrouping of the sequences leave every one of the user's files as it was. And what a run
says is true: no preview folder named that is not there, no limit message whose two figures
read the same."""

import hashlib
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from genie_gl.export import semantickitti

from .common import cli, fault, intact

RERUN = fault("re-run", "loss")
DAMAGED = fault("bad file", "loss")
ARGS = [
    "dataset",
    "assembly_line",
    "--cameras",
    "2",
    "--sensor",
    "ideal_pinhole",
    "--points",
    "3000",
    "--min-points",
    "500",
    "--no-progress",
    "--previews",
    "0",
    "--scenes",
    "2",
    "--workers",
    "1",
]
USER = {
    "sequences/01/predictions/000000.label": b"\x01\x00\x00\x00" * 4,
    "sequences/00/notes.txt": b"which model ran on this\n",
    "sequences/01/predictions/draft.tmp": b"a draft of mine\n",
    "scenes/0001/NOTES.md": b"# scene 1: the forklift is odd\n",
    "scenes/0000/analysis/x.tmp": b"mine\n",
}


def digest(root: Path, skip=("manifest.json",)) -> dict[str, str]:
    return {
        p.relative_to(root).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file() and p.name not in skip
    }


def plant(root: Path) -> dict[str, str]:
    for rel, data in USER.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_bytes(data)
    return {rel: hashlib.sha256(data).hexdigest() for rel, data in USER.items()}


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """A finished two-scene SemanticKITTI dataset and the hashes of its files."""
    out = tmp_path_factory.mktemp("made") / "ds"
    run = cli(*ARGS, "--out", out, timeout=900)
    assert run.rc == 0, run.err[-2000:]
    return out, digest(out)


@pytest.fixture
def dataset(made, tmp_path):
    """A copy of the finished dataset with the user's files in it: (folder, its files' hashes, the
    user's)."""
    out = tmp_path / "ds"
    shutil.copytree(made[0], out)
    return out, made[1], plant(out)


def ours(root: Path, user: dict[str, str]) -> dict[str, str]:
    return {k: v for k, v in digest(root).items() if k not in user}


@pytest.mark.gl
@RERUN
def test_a_rerun_that_makes_nothing_keeps_the_users_files(dataset):
    """It rebuilt ``sequences/NN`` and deleted ``predictions/`` with it."""
    out, before, user = dataset
    run = cli(*ARGS, "--out", out, timeout=600)
    assert run.rc == 0, run.err[-2000:]
    assert "0 scenes made, 2 already there" in run.out
    intact(out, user)
    assert ours(out, user) == before


@pytest.mark.gl
@DAMAGED
def test_a_scene_made_again_for_a_damaged_scan_keeps_the_users_notes(dataset):
    """A short scan makes scene 1 again: it removed the whole ``scenes/0001`` with the notes."""
    out, before, user = dataset
    scan = out / "scenes" / "0001" / "velodyne" / "000000.bin"
    scan.write_bytes(scan.read_bytes()[:-16])
    run = cli(*ARGS, "--out", out, timeout=600)
    assert run.rc == 0, run.err[-2000:]
    assert "1 scenes made, 1 already there" in run.out
    intact(out, user)
    assert ours(out, user) == before  # the scene as it was, the sequences rebuilt around the notes


@pytest.mark.gl
@DAMAGED
def test_a_scene_made_again_for_a_hash_mismatch_keeps_the_users_notes(dataset):
    """``--verify`` finds a scan of the right size and the wrong bytes."""
    out, before, user = dataset
    label = out / "scenes" / "0001" / "labels" / "000000.label"
    data = bytearray(label.read_bytes())
    data[0] ^= 0xFF
    label.write_bytes(bytes(data))
    run = cli(*ARGS, "--verify", "--out", out, timeout=600)
    assert run.rc == 0, run.err[-2000:]
    assert "1 scenes made, 1 already there" in run.out
    intact(out, user)
    assert ours(out, user) == before


@pytest.mark.gl
@DAMAGED
def test_a_balanced_scene_made_again_keeps_the_users_notes(tmp_path):
    """``--class-balance``: a scene is written from its cached chunks once every scene is there;
    written again, it replaced the scene folder whole."""
    out = tmp_path / "ds"
    args = [*ARGS, "--class-balance", "paper", "--out", out]
    assert cli(*args, timeout=900).rc == 0
    before = digest(out)
    user = plant(out)
    scan = out / "scenes" / "0001" / "velodyne" / "000000.bin"
    scan.unlink()
    run = cli(*args, timeout=600)
    assert run.rc == 0, run.err[-2000:]
    intact(out, user)
    assert ours(out, user) == before


@pytest.mark.gl
@RERUN
def test_a_rerun_of_recordings_keeps_the_users_predictions(tmp_path):
    """``--capture trajectory --format semantickitti``: each recording is a sequence of its own,
    assembled by the sequence writer; it removed and rebuilt them whole."""
    out = tmp_path / "ds"
    args = [
        "dataset",
        "assembly_line",
        "--capture",
        "trajectory",
        "--sensor",
        "ideal_pinhole",
        "--duration-s",
        "0.3",
        "--scenes",
        "2",
        "--workers",
        "1",
        "--previews",
        "0",
        "--no-progress",
        "--out",
        out,
    ]
    assert cli(*args, timeout=900).rc == 0
    before = digest(out)
    user = plant(out)
    run = cli(*args, timeout=600)
    assert run.rc == 0, run.err[-2000:]
    intact(out, user)
    assert ours(out, user) == before


def _scene(folder: Path, scans: int) -> Path:
    """A scene folder of ``scans`` one-point scans, as the SemanticKITTI writer leaves it."""
    clouds = []
    for k in range(scans):
        from genie_gl import PointCloud

        clouds.append(
            PointCloud(np.full((1, 3), k, np.float32), np.ones(1, np.uint16), np.ones(1, np.uint32))
        )
    semantickitti.write_scans(clouds, folder)
    return folder


@RERUN
def test_sequences_of_an_earlier_grouping_keep_the_users_files(tmp_path):
    """Sequences that a new grouping no longer makes lose genie-gl's files, never the user's
    (they were removed whole)."""
    scenes = [_scene(tmp_path / "scenes" / f"{i:04d}", 2) for i in range(3)]
    semantickitti.assemble_sequences(tmp_path, scenes)
    user = {"sequences/02/predictions/000000.label": b"p", "sequences/01/mine.txt": b"m"}
    for rel, data in user.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes(data)
    groups = semantickitti.assemble_sequences(tmp_path, scenes[:1])
    assert groups == {0: [0]}
    for rel, data in user.items():
        assert (tmp_path / rel).read_bytes() == data, rel
    left = sorted(
        p.relative_to(tmp_path / "sequences").as_posix()
        for p in (tmp_path / "sequences").rglob("*")
        if p.is_file()
    )
    assert left == [
        "00/calib.txt",
        "00/labels/000000.label",
        "00/labels/000001.label",
        "00/poses.txt",
        "00/times.txt",
        "00/velodyne/000000.bin",
        "00/velodyne/000001.bin",
        "01/mine.txt",
        "02/predictions/000000.label",
    ]


@pytest.mark.gl
@fault("bad option", "wrong")
def test_no_previews_names_no_preview_folder(made, tmp_path):
    """``--previews 0`` printed "previews in DIR/previews" for a folder that is not there."""
    out = tmp_path / "ds"
    shutil.copytree(made[0], out)
    run = cli(*ARGS, "--out", out, timeout=600)
    assert run.rc == 0, run.err[-2000:]
    assert not (out / "previews").exists()
    assert "previews in" not in run.out, run.out


@fault("huge input", "wrong")
@pytest.mark.parametrize(
    "need, limit", [(10.249e9, 10.241e9), (10.2400001e9, 10.24e9), (999.96e9, 999.95e9)]
)
def test_a_need_over_its_limit_reads_larger(tmp_path, need, limit):
    """ "estimated 10.2 GB exceeds 10.2 GB": the two figures are told apart, the first the
    larger."""
    from genie_gl.errors import LimitError
    from genie_gl.limits import check_disk, check_memory

    with pytest.raises(LimitError) as memory:
        check_memory(need, limit, "the frames", "use fewer")
    with pytest.raises(LimitError) as disk:
        check_disk(need, tmp_path, "--out o", max_disk_gb=limit / 1e9)
    for text, pattern in (
        (str(memory.value), r"estimated memory ([\d.e+]+) GB .* exceeds ([\d.e+]+) GB"),
        (str(disk.value), r"about ([\d.e+]+) GB, more than ([\d.e+]+) GB"),
    ):
        shown, allowed = (float(x) for x in re.search(pattern, text).groups())
        assert shown > allowed, text


@pytest.mark.gl
@RERUN
def test_a_bop_scene_written_again_keeps_the_users_files(tmp_path):
    """``bop.write_scene`` (``genie capture --format bop``) into a folder that holds the scene
    already: the user's notes in it stay, its frames of an earlier, longer capture go."""
    import genie_gl as gg
    from genie_gl.export import bop
    from genie_gl.render import Renderer
    from genie_gl.sensors.pose import look_at
    from tests.export.test_bop import two_box_scene

    scene = two_box_scene()
    sensor = gg.Sensor(160, 120, np.array([[150.0, 0, 80.0], [0, 150.0, 60.0], [0, 0, 1]]))
    poses = [look_at([0.5, -3.0, 1.6], [0.1, 0.6, 0.4]), look_at([2.5, -2.0, 2.0], [0.0, 0.5, 0.4])]
    with Renderer(scene) as r:
        frames = [r.render(sensor, p) for p in poses]
    folder = bop.write_scene(scene, frames, tmp_path, scene_id=0)
    mine = {"NOTES.md": b"mine\n", "rgb/000001_edited.png": b"my edit", "depth/draft.tmp": b"x"}
    for rel, data in mine.items():
        (folder / rel).write_bytes(data)
    bop.write_scene(scene, frames[:1], tmp_path, scene_id=0)
    for rel, data in mine.items():
        assert (folder / rel).read_bytes() == data, rel
    assert (
        not (folder / "rgb" / "000001.png").exists() and (folder / "rgb" / "000000.png").is_file()
    )
