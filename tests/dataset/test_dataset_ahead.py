"""One worker on two cores: the next scene's layout, scene and placement made in a helper
process (genie_gl/dataset/ahead.py) change no byte, are recorded as made there, skip the
scenes already made, and a helper that dies leaves the worker to make the rest."""

import json
import logging
import os
import shutil

import pytest

from genie_gl.cli import main
from genie_gl.dataset import ahead, executors
from genie_gl.dataset.recipe import PARTS

from .test_dataset import ARGS, digest

pytestmark = pytest.mark.gl


def _die(index: int):
    """Stands in for the helper's job: the helper process ends at once."""
    os._exit(3)


def _run(out, monkeypatch, *, helper: bool, scenes: int = 3) -> list[dict]:
    """``genie dataset`` of ARGS, one worker, with or without a helper; its scene records."""
    monkeypatch.setattr(executors, "spare_core", lambda: helper)
    assert (
        main(["dataset", *ARGS, "--scenes", str(scenes), "--workers", "1", "--out", str(out)]) == 0
    )
    return json.loads((out / "manifest.json").read_text())["runs"][-1]["scene_s"]


@pytest.fixture(scope="module")
def alone(tmp_path_factory):
    """Three scenes made by the worker alone."""
    out = tmp_path_factory.mktemp("alone")
    with pytest.MonkeyPatch.context() as mp:
        records = _run(out, mp, helper=False)
    assert not any("ahead_s" in r for r in records)
    return out


def test_scenes_made_ahead_are_the_same_bytes_and_say_where_their_parts_were_made(
    alone, tmp_path, monkeypatch
):
    records = _run(tmp_path, monkeypatch, helper=True)
    assert digest(tmp_path) == digest(alone)
    first, *later = sorted(records, key=lambda r: r["scene"])
    assert "ahead_s" not in first  # made by the worker while the helper warmed up
    assert later and all(
        set(r["ahead_s"]) == set(PARTS) and min(r["ahead_s"].values()) > 0 for r in later
    )
    assert {r["worker"] for r in records} == {
        first["worker"]
    }  # one worker: the helper makes no scene


def test_the_helper_skips_scenes_already_made(alone, tmp_path, monkeypatch):
    out = tmp_path / "d"
    shutil.copytree(alone, out)
    for gone in ("0000", "0002"):
        shutil.rmtree(out / "scenes" / gone)
    records = _run(out, monkeypatch, helper=True)
    assert [r["scene"] for r in records] == [0, 2]
    assert "ahead_s" not in records[0] and set(records[1]["ahead_s"]) == set(
        PARTS
    )  # scene 1 was not made again
    assert digest(out) == digest(alone)


def test_a_helper_that_dies_leaves_the_worker_to_make_the_rest(
    alone, tmp_path, monkeypatch, caplog
):
    monkeypatch.setattr(ahead, "_make", _die)
    with caplog.at_level(logging.WARNING):
        records = _run(tmp_path, monkeypatch, helper=True)
    assert digest(tmp_path) == digest(alone)
    assert not any("ahead_s" in r for r in records)
    said = [r.getMessage() for r in caplog.records if "helper process" in r.getMessage()]
    assert len(said) == 1 and "this worker makes the rest itself" in said[0]


def test_a_run_in_this_process_hides_what_its_warm_up_made_from_the_collector_and_shows_it_again(
    tmp_path, monkeypatch
):
    import gc

    from genie_gl.dataset.modes import standing

    frozen, real = [], standing.make
    monkeypatch.setattr(
        standing, "make", lambda *a, **k: frozen.append(gc.get_freeze_count()) or real(*a, **k)
    )
    before = gc.get_freeze_count()
    _run(tmp_path, monkeypatch, helper=False, scenes=2)
    assert (
        len(frozen) == 2 and min(frozen) > before + 10_000
    )  # the imports' and the warm-up's objects
    assert gc.get_freeze_count() == before


def test_a_process_forked_from_a_run_does_not_hold_its_output_lock(tmp_path):
    """The holder killed outright while a process it forked lives on: the folder is free at
    once (the helper goes with its worker, but a moment later)."""
    import signal
    import subprocess
    import sys

    from genie_gl.dataset.manifest import OutputLock

    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            f"""
import os, sys, time
from pathlib import Path
from genie_gl.dataset.manifest import OutputLock
with OutputLock(Path({str(tmp_path)!r})):
    child = os.fork()
    if child == 0:
        time.sleep(60)
        os._exit(0)
    print(child, flush=True)
    time.sleep(60)
""",
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    child = int(holder.stdout.readline())
    try:
        with pytest.raises(Exception, match="another genie dataset run"):
            with OutputLock(tmp_path):
                pass
        holder.send_signal(signal.SIGKILL)
        holder.wait()
        os.kill(child, 0)  # the forked process still lives
        with OutputLock(tmp_path):
            pass
    finally:
        holder.kill()
        try:
            os.kill(child, signal.SIGKILL)
        except ProcessLookupError:
            pass


def test_a_helper_forked_while_another_thread_compiles_stops_and_the_worker_makes_the_scenes(
    caplog,
):
    """numba's compiler lock held by another thread at the fork stays held in the helper for
    good: it must stop at once, not wait on it, and the worker make the scenes itself."""
    import threading

    from numba.core.compiler_lock import global_compiler_lock

    from genie_gl.dataset.config import DatasetConfig
    from genie_gl.dataset.recipe import load_inputs

    inputs = load_inputs(
        DatasetConfig(strategy="assembly_line", out="unused", cameras=2, sensor="ideal_pinhole")
    )
    held, forked = threading.Event(), threading.Event()

    def compile_meanwhile():
        with global_compiler_lock:
            held.set()
            forked.wait(30)

    other = threading.Thread(target=compile_meanwhile)
    other.start()
    held.wait(30)
    taken = []
    try:
        with caplog.at_level(logging.WARNING):
            helper = ahead.Ahead(inputs, 0, 2, lambda i: i + 1 if i < 3 else None)
            forked.set()
            other.join()
            worker = threading.Thread(
                target=lambda: taken.extend([helper.take(0), helper.take(1)]), daemon=True
            )
            worker.start()
            worker.join(60)
            if worker.is_alive():  # waiting on a helper that can never answer: end it, and fail
                for proc in list((helper._pool._processes or {}).values()):
                    proc.kill()
                pytest.fail("the worker waited on a helper stuck on a lock held at the fork")
            helper.close()
    finally:
        forked.set()
        other.join()
    assert taken == [None, None]  # the first scene never asked for; the second made by the worker
    said = [r.getMessage() for r in caplog.records if "helper process" in r.getMessage()]
    assert len(said) == 1 and "this worker makes the rest itself" in said[0]


def test_a_scene_made_ahead_counts_the_helpers_cpu_time_as_its_own(tmp_path):
    """The helper's CPU seconds for a scene's parts are the scene's: ``cpu_s`` includes them
    (the helper stands in here, handing over real parts that say they took 100 s of CPU)."""
    from dataclasses import replace

    from genie_gl.dataset.config import DatasetConfig
    from genie_gl.dataset.recipe import load_inputs, make_parts
    from genie_gl.dataset.scene import run_scene
    from genie_gl.dataset.streams import SceneStreams

    cfg = DatasetConfig(
        strategy="assembly_line",
        out=str(tmp_path),
        scenes=1,
        cameras=2,
        sensor="ideal_pinhole",
        points=4000,
        min_points=500,
        previews=0,
    )
    inputs = load_inputs(cfg)

    class Helper:  # what Ahead.take hands over, made in this process
        def take(self, index):
            parts = make_parts(inputs, SceneStreams(cfg.seed, index), cfg.cameras)
            return replace(parts, cpu_s=100.0, stages_s={k: 7.0 for k in PARTS})

    stats = run_scene(cfg, 0, inputs=inputs, ahead=Helper())
    assert stats["cpu_s"] >= 100.0 and stats["ahead_s"] == {k: 7.0 for k in PARTS}
    assert (
        sum(stats["timings_s"][k] for k in PARTS) < 7.0
    )  # the worker's own: its wait, not the helper's time
    alone = run_scene(cfg.model_copy(update={"out": str(tmp_path / "b")}), 0, inputs=inputs)
    assert alone["cpu_s"] < 100.0 and "ahead_s" not in alone


def test_the_memory_estimate_counts_the_helpers_layout():
    from genie_gl.dataset.config import DatasetConfig
    from genie_gl.dataset.modes import get_mode
    from genie_gl.dataset.recipe import load_inputs
    from genie_gl.limits import BYTES_PER_NODE

    one = DatasetConfig(
        strategy="assembly_line", out="unused", scenes=1, cameras=4, sensor="ideal_pinhole"
    )
    inputs = load_inputs(one)
    estimate = get_mode(one.capture).estimate
    a = estimate(one, inputs.strategy, inputs.sensor)
    b = estimate(one.model_copy(update={"scenes": 2}), inputs.strategy, inputs.sensor)
    c = estimate(one.model_copy(update={"scenes": 2, "workers": 2}), inputs.strategy, inputs.sensor)
    assert (
        b.memory_bytes - a.memory_bytes == a.nodes * BYTES_PER_NODE > 0
    )  # one worker, a helper: one layout more
    assert c.memory_bytes == 2 * a.memory_bytes  # two workers: no helper


def test_meshes_handed_over_are_the_first_copy_of_their_content_the_worker_received():
    """What is cached per mesh in the worker (the planner's convexity check) holds across
    scenes made ahead: a mesh of the same content is the same object in every scene."""
    from genie_gl.dataset.config import DatasetConfig
    from genie_gl.dataset.recipe import load_inputs

    inputs = load_inputs(
        DatasetConfig(strategy="assembly_line", out="unused", cameras=2, sensor="ideal_pinhole")
    )
    with ahead.Ahead(inputs, 0, 2, lambda i: i + 1 if i < 2 else None) as helper:
        assert helper.take(0) is None
        a, b = helper.take(1), helper.take(2)
    assert a is not None and b is not None and a.index == 1 and b.index == 2
    by_digest = {m.digest(): m for m in a.scene.meshes.values()}
    shared = [m for m in b.scene.meshes.values() if m.digest() in by_digest]
    assert shared and all(m is by_digest[m.digest()] for m in shared)
