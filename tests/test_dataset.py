"""The dataset pipeline end to end: determinism across workers, resuming, bad input."""
import hashlib
import time
from pathlib import Path

import pytest

from genie_gl.cli import main

pytestmark = pytest.mark.gl
ARGS = ["assembly_line", "--cameras", "2", "--sensor", "ideal_pinhole", "--points", "4000",
        "--min-points", "500", "--no-progress", "--previews", "1"]


def digest(root: Path) -> dict[str, str]:
    """Hash of every data file (manifest.json holds timings, so it is left out)."""
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file() and p.name != "manifest.json"}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref")
    assert main(["dataset", *ARGS, "--scenes", "2", "--workers", "1", "--out", str(out)]) == 0
    return out


def test_one_and_two_workers_give_the_same_bytes(reference, tmp_path):
    assert main(["dataset", *ARGS, "--scenes", "2", "--workers", "2", "--out", str(tmp_path)]) == 0
    a, b = digest(reference), digest(tmp_path)
    assert a == b
    assert any(k.startswith("sequences/01/velodyne/") for k in a)
    for name in ("histogram.txt", "histogram.png", "previews/scene_0000_layout.png",
                 "previews/scene_0000_cam00.png", "previews/scene_0000_cloud_top.png"):
        assert name in a
    import json
    m = json.loads((tmp_path / "manifest.json").read_text())
    assert m["inputs"]["seed"] == 0 and m["scenes_made"] == 2 and "genie_gl" in m


@pytest.mark.parametrize("argv, message", [
    (["dataset", "layouts/missing.json", "--out", "OUT"], "missing.json: no such file"),
    (["dataset", "assembly_line", "--format", "las", "--out", "OUT"], "--format 'las': unknown"),
    (["dataset", "assembly_line", "--out", "/proc/genie-out"], "not writable"),
    (["dataset", "assembly_line", "--sensor", "nope", "--out", "OUT"], "no shipped sensor"),
])
def test_bad_input_fails_fast_with_one_line(argv, message, tmp_path, capsys):
    argv = [a.replace("OUT", str(tmp_path / "o")) for a in argv]
    t = time.perf_counter()
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1
    assert time.perf_counter() - t < 10


def test_ray_executor_gives_the_same_bytes(reference, tmp_path):
    pytest.importorskip("ray")
    assert main(["dataset", *ARGS, "--scenes", "2", "--executor", "ray", "--out", str(tmp_path)]) == 0
    assert digest(tmp_path) == digest(reference)


def test_bop_format_writes_scenes_that_bop_readers_load(tmp_path):
    import json

    import cv2
    import numpy as np

    assert main(["dataset", *ARGS, "--scenes", "1", "--workers", "1", "--format", "bop", "--out", str(tmp_path)]) == 0
    scene = tmp_path / "train_pbr" / "000000"
    gt = json.loads((scene / "scene_gt.json").read_text())
    info = json.loads((scene / "scene_gt_info.json").read_text())
    cams = json.loads((scene / "scene_camera.json").read_text())
    assert sorted(gt) == sorted(cams) == ["0", "1"]
    models = json.loads((tmp_path / "models" / "models_info.json").read_text())
    assert gt["0"] and all(str(g["obj_id"]) in models for im in gt.values() for g in im)
    for im, objs in gt.items():
        assert len(objs) == len(info[im])
        d = cv2.imread(str(scene / "depth" / f"{int(im):06d}.png"), cv2.IMREAD_UNCHANGED)
        rgb = cv2.imread(str(scene / "rgb" / f"{int(im):06d}.png"), cv2.IMREAD_UNCHANGED)
        assert d.dtype == np.uint16 and d.max() > 0 and rgb.shape == d.shape + (3,)
        for k, inf in enumerate(info[im]):
            full = cv2.imread(str(scene / "mask" / f"{int(im):06d}_{k:06d}.png"), cv2.IMREAD_UNCHANGED)
            vis = cv2.imread(str(scene / "mask_visib" / f"{int(im):06d}_{k:06d}.png"), cv2.IMREAD_UNCHANGED)
            assert ((vis == 255) <= (full == 255)).all() and 0 < inf["visib_fract"] <= 1
    assert (scene / "stats.json").exists() and (tmp_path / "camera.json").exists()
