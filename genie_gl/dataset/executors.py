"""Where scenes are made: in this process, in worker processes, or on a Ray cluster. Each
scene depends only on (seed, index), so every executor writes the same bytes.

Every process warms up once, before the first scene it makes (:mod:`.warmup`); each result
says which process made it (``worker``), its place among that process's scenes (``nth``, 0 for
the first) and, on the first, the warm-up's seconds (``warmup_s``)."""

from __future__ import annotations

import gc
import multiprocessing as mp
import os
from contextlib import nullcontext
from typing import Any

from tqdm import tqdm

from ..cloud.tally import spare_core
from ..processes import die_with_parent, say_when_compiling
from ..render.gl.context import default_backend, set_default_backend
from ..render.threads import limit_threads
from ..scene.assets.catalogue import ASSETS
from .ahead import Ahead
from .config import DatasetConfig
from .modes.base import get_mode
from .recipe import RunInputs
from .scene import needs_making, run_scene
from .warmup import warm_up

_PROCESS: dict[str, Any] = {}  # this process: warmed up?, scenes made, warm-up seconds to report


def _prepare(cfg: DatasetConfig, inputs: RunInputs) -> None:
    """The process's warm-up, the first time one of its scenes needs making."""
    if not _PROCESS.get("warm"):
        _PROCESS["warmup_s"] = warm_up(cfg, inputs)
        _PROCESS["warm"] = True
    if not _PROCESS.get("frozen"):
        # what the imports and the warm-up made lives as long as the process: out of the
        # collector's sight, a full collection walks only what the scenes make (each walk of the
        # ~200 000 objects took 80-190 ms, every second or two of scenes)
        gc.freeze()
        _PROCESS["frozen"] = True


def _made(r: dict) -> dict:
    """``r`` with the process's id, the scene's place among its scenes and (first) its warm-up."""
    if r.get("skipped"):
        return r
    r = r | {"worker": os.getpid(), "nth": _PROCESS.get("made", 0)}
    _PROCESS["made"] = r["nth"] + 1
    if "warmup_s" in _PROCESS:
        r["warmup_s"] = _PROCESS.pop("warmup_s")
    return r


def make_scene(
    cfg: DatasetConfig,
    inputs: RunInputs,
    index: int,
    *,
    verify: bool = False,
    stage=None,
    ahead: Ahead | None = None,
) -> dict[str, Any]:
    """:func:`~genie_gl.dataset.scene.run_scene` with this process's warm-up and bookkeeping
    (``ahead``: a helper process making scenes' first stages, :mod:`.ahead`)."""

    def prepare() -> None:
        if stage is not None and not _PROCESS.get("warm"):
            stage("warm-up")  # the bar shows the worker's warm-up as a stage of its first scene
        _prepare(cfg, inputs)

    return _made(
        run_scene(
            cfg, index, inputs=inputs, verify=verify, stage=stage, prepare=prepare, ahead=ahead
        )
    )


def _worker(job: tuple) -> dict:
    cfg, inputs, index, verify, backend, status = job if len(job) == 6 else (*job, None)
    set_default_backend(backend)  # the parent's choice (a spawned worker starts without it)
    say_when_compiling(f"genie dataset (worker {os.getpid()})")
    limit_threads((os.cpu_count() or 1) // max(1, int(cfg.workers)))

    def stage(name: str) -> None:
        if status is not None:
            status[index] = name

    try:
        return make_scene(cfg, inputs, index, verify=verify, stage=stage)
    finally:
        if status is not None:
            status.pop(index, None)


def _ahead(cfg: DatasetConfig, inputs: RunInputs) -> Ahead | None:
    """A helper process making the layout, scene and placement of this process's scenes one
    scene ahead (:mod:`.ahead`; forked now, before the warm-up, it makes the second scene to
    make while this process makes the first), where it can gain: a mode that allows it (standing
    cameras), two scenes
    or more to make, a core to spare, no asset registered in this process only. None
    otherwise."""
    if not get_mode(cfg.capture).made_ahead or not spare_core() or ASSETS.registered():
        return None
    first = next((i for i in range(cfg.scenes) if needs_making(cfg, i)), None)
    if first is None or not any(needs_making(cfg, j) for j in range(first + 1, cfg.scenes)):
        return None

    def upcoming(index: int) -> int | None:
        return next((j for j in range(index + 1, cfg.scenes) if needs_making(cfg, j)), None)

    return Ahead(inputs, cfg.seed, cfg.cameras, upcoming)


def _describe(status) -> str:
    try:
        items = sorted(dict(status).items())
    except Exception:  # the manager went away: nothing to show
        return ""
    return ", ".join(f"scene {i}: {name}" for i, name in items)


def map_scenes(
    cfg: DatasetConfig, inputs: RunInputs, *, progress: bool = True, verify: bool = False
) -> list[dict[str, Any]]:
    """Run every scene of ``cfg`` with the run's ``inputs`` (finished ones are checked and
    skipped); returns their stats.
    The progress bar names the scene and stage being worked on (this process) or the scenes
    under way (workers)."""
    bar = tqdm(total=cfg.scenes, unit="scene", disable=not progress, desc="scenes", mininterval=0.5)
    results: list[dict] = []

    def done(r: dict) -> None:
        results.append(r)
        bar.update(1)

    try:
        if cfg.executor == "ray":
            import ray

            ray.init(address=cfg.address, ignore_reinit_error=True, log_to_driver=False)
            remote = ray.remote(_worker)  # stages are not reported back from the cluster
            pending = [
                remote.remote((cfg, inputs, i, verify, default_backend()))
                for i in range(cfg.scenes)
            ]
            bar.set_postfix_str(f"{len(pending)} scenes on Ray")
            while pending:
                ready, pending = ray.wait(pending, num_returns=1)
                done(ray.get(ready[0]))
        elif cfg.workers <= 1 or cfg.scenes <= 1:
            try:
                with _ahead(cfg, inputs) or nullcontext() as ahead:
                    for i in range(cfg.scenes):
                        done(
                            make_scene(
                                cfg,
                                inputs,
                                i,
                                verify=verify,
                                ahead=ahead,
                                stage=lambda name, i=i: bar.set_postfix_str(
                                    f"scene {i}: {name}", refresh=True
                                ),
                            )
                        )
            # this process goes on (the Python API): its objects back in the collector's sight
            finally:
                if _PROCESS.pop("frozen", False):
                    gc.unfreeze()
        else:
            n = min(cfg.workers, cfg.scenes)
            ctx = mp.get_context("spawn")
            # the stages under way are shown through a manager's dict: a server process of its
            # own, started only when there is a bar to show them on
            with (
                ctx.Manager() if progress else nullcontext() as manager,
                ctx.Pool(n, initializer=die_with_parent, initargs=(os.getpid(),)) as pool,
            ):
                status = (
                    manager.dict() if manager is not None else None
                )  # scene -> its worker's stage
                it = pool.imap_unordered(
                    _worker,
                    [
                        (cfg, inputs, i, verify, default_backend(), status)
                        for i in range(cfg.scenes)
                    ],
                )
                left = cfg.scenes
                while left:
                    try:
                        r = it.next(timeout=0.5)
                    except mp.TimeoutError:
                        if status is not None:
                            bar.set_postfix_str(_describe(status), refresh=True)
                        continue
                    done(r)
                    left -= 1
    finally:
        bar.close()
    return results
