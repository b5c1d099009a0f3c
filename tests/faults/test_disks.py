"""Full and read-only disks, names too long: one line naming the file and what happened,
found before the expensive work where it can be (an unwritable --out before anything runs, a
capture larger than the free space before rendering); nothing half-written left, the user's
files untouched. Each disk is a tmpfs of the command's own (a user and mount namespace)."""

import hashlib
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

import genie_gl as gg

from .common import ROOT, _env, cli, fault, namespaces_work, refused

needs_namespaces = pytest.mark.skipif(
    not namespaces_work(), reason="no user and mount namespaces (unshare -rm) here"
)
FULL = fault("full disk", "loss")
READ_ONLY = fault("read-only disk", "traceback")
PLANTED = {"notes.txt": "my notes\n", "draft.tmp": "not yours\n", "work/x.tmp": "mine"}


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("disk-inputs")
    s = gg.Scene()
    s.add(trimesh.creation.box((4, 4, 1)), [0, 0, 0.5], semantic=2)
    s.add(trimesh.creation.box((20, 20, 0.02)), np.eye(4), semantic=0)
    gg.generate_layout("assembly_line", seed=0).to_json(d / "layout.json")
    return {"usd": gg.write_usd(s, d / "s.usda"), "layout": d / "layout.json"}


def on_disk(
    tmp_path: Path, opts: str, *, argv=None, python=None, out: str = "out", timeout: float = 300
) -> dict:
    """Run on a tmpfs (``opts``) mounted at tmp_path/disk with the user's files planted in
    disk/out; returns the driver's report (rc, stderr, seconds, files under disk/out)."""
    disk = tmp_path / "disk"
    disk.mkdir()
    spec = {
        "mounts": {str(disk): opts},
        "plant": {str(disk / out / k): v for k, v in PLANTED.items()},
        "timeout": timeout,
        "inspect": str(disk / out),
    }
    if argv is not None:
        spec["argv"] = [str(a).replace("{out}", str(disk / out)) for a in argv]
    else:
        spec["python"] = python.replace("{out}", str(disk / out))
    (tmp_path / "spec.json").write_text(json.dumps(spec))
    r = subprocess.run(
        [
            "unshare",
            "-rm",
            sys.executable,
            str(Path(__file__).parent / "disk_driver.py"),
            str(tmp_path / "spec.json"),
        ],
        capture_output=True,
        text=True,
        timeout=timeout + 60,
        env=_env(),
        cwd=ROOT,
    )
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def check(report: dict, *needles: str) -> None:
    """One line naming what happened; the user's files as they were; no temporary file left."""
    err = report["stderr"].strip()
    assert report["rc"] == 2 and "Traceback" not in err, err[-3000:]
    assert len(err.splitlines()) == 1, err[-3000:]
    for n in needles:
        assert n in err, (n, err)
    for rel, text in PLANTED.items():
        assert report["files"].get(rel) == hashlib.sha256(text.encode()).hexdigest(), (
            f"{rel} lost or changed"
        )
    left = [
        f for f in report["files"] if (Path(f).name.startswith(".") and ".tmp" in f) or ".tmp-" in f
    ]
    assert not left, left


COMMANDS = {
    "layout": ["layout", "assembly_line", "--out", "{out}"],
    "scene": ["scene", "{layout}", "--out", "{out}/s.usda", "--no-progress"],
    "capture": ["capture", "{usd}", "--cameras", "2", "--out", "{out}", "--no-progress"],
    "dataset": [
        "dataset",
        "assembly_line",
        "--scenes",
        "1",
        "--cameras",
        "2",
        "--sensor",
        "ideal_pinhole",
        "--workers",
        "1",
        "--split",
        "1,0,0",
        "--no-progress",
        "--out",
        "{out}",
    ],
    "bench": ["bench", "layout", "--repeats", "1", "--out", "{out}"],
}
# the API: a GenieError for what it refuses, an OSError naming the file for what the disk refuses
EXPORT = (
    "import sys, numpy as np, genie_gl as gg\n"
    "c = gg.PointCloud(np.zeros((200000, 3), np.float32), np.ones(200000, np.uint16), "
    "np.ones(200000, np.uint32))\n"
    "try:\n    gg.export(c, '{out}', format='ply')\n"
    "except gg.GenieError as e:\n    print(f'export: error: {e}', file=sys.stderr); raise "
    "SystemExit(2)\n"
    "except OSError as e:\n    print(f'export: {e.filename}: {e.strerror}', file=sys.stderr); "
    "raise SystemExit(2)\n"
)


def _argv(name: str, inputs) -> list[str]:
    return [
        a.replace("{usd}", str(inputs["usd"])).replace("{layout}", str(inputs["layout"]))
        for a in COMMANDS[name]
    ]


@needs_namespaces
@READ_ONLY
@pytest.mark.parametrize("name", list(COMMANDS))
def test_a_read_only_out_is_refused_before_any_work(name, inputs, tmp_path):
    report = on_disk(tmp_path, "size=1m,ro", argv=_argv(name, inputs))
    check(report, "Read-only file system")
    assert report["seconds"] < 60


@needs_namespaces
@READ_ONLY
def test_the_api_refuses_a_read_only_folder(tmp_path):
    check(on_disk(tmp_path, "size=1m,ro", python=EXPORT), "out_dir", "Read-only file system")


@needs_namespaces
@FULL
@pytest.mark.parametrize("name", ["layout", "scene"])
def test_a_full_disk_is_one_line_and_leaves_nothing_half_written(name, inputs, tmp_path):
    check(on_disk(tmp_path, "size=48k", argv=_argv(name, inputs)), "No space left on device")


@needs_namespaces
@FULL
@pytest.mark.parametrize("name", ["capture", "dataset"])
def test_a_disk_too_small_is_found_before_rendering(name, inputs, tmp_path):
    report = on_disk(tmp_path, "size=48k", argv=_argv(name, inputs))
    check(report, "the run would write about")
    assert report["seconds"] < 60


@needs_namespaces
@FULL
def test_the_api_fills_a_disk_and_leaves_nothing_half_written(tmp_path):
    check(on_disk(tmp_path, "size=400k", python=EXPORT), "cloud.ply", "No space left on device")


LONG = "n" * 300


@fault("bad option", "traceback")
@pytest.mark.parametrize("name", list(COMMANDS))
def test_a_name_too_long_is_one_line(name, inputs, tmp_path):
    argv = [a.replace("{out}", str(tmp_path / LONG)) for a in _argv(name, inputs)]
    refused(cli(*argv, timeout=60), "File name too long")


@fault("bad API call", "traceback")
def test_the_api_refuses_a_name_too_long(tmp_path):
    c = gg.PointCloud(np.zeros((2, 3), np.float32), np.ones(2, np.uint16), np.ones(2, np.uint32))
    with pytest.raises(gg.ConfigError, match="File name too long"):
        gg.export(c, tmp_path / LONG)
    with pytest.raises(gg.ConfigError, match="File name too long"):
        gg.generate_layout("assembly_line").to_json(tmp_path / (LONG + ".json"))
