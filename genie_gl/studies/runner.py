"""The studies behind ``genie eval --study NAME``: each one a set of datasets (made once, cached,
:mod:`.datasets`), a set of trainings (each :func:`genie_gl.eval.evaluate` over the seeds, kept in
``OUT/runs/<name>/`` and reused when its ``metrics.json`` is there), a table and a picture.

- ``strategy``: train on two layout strategies, test on held-out scenes of the third, all three
  ways round, beside training on the third itself; with the height-only and majority baselines.
- ``sensor``: train on ideal / RealSense D435 / Azure Kinect (ToF) data, test on each (3 x 3).
- ``accuracy``: for each effect of the D435 profile, train with it off and on, test on data with
  the full profile: ΔmIoU with its spread beside the effect's ms per frame (the dataset's
  manifest, ``cost.capture``).
- ``balance``: ``--class-balance paper`` against the natural distribution.
- ``models``: RandLA-Net against the classical model on the same split.
- ``costs``: each D435 effect timed alone on the frames of one scene (:mod:`.costs`), the cost
  column the ``accuracy`` study then shows (from ``OUT/costs.json``).
- ``mix``: the ``mix`` preset on the stand-in target (storage area seen by an Azure Kinect).
"""

from __future__ import annotations

import json
import logging
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from ..errors import ConfigError
from ..eval import evaluate
from ..outputs import atomic_write_text, claim_folder
from . import datasets as ds
from . import report
from .costs import costs_markdown, time_effects
from .datasets import PROFILE, SENSORS, STRATEGIES, TARGET, DataSpec

log = logging.getLogger(__name__)

SECONDS_PER_TRAINING = {
    "classical": 120.0,
    "height": 30.0,
    "majority": 5.0,
    "randla": 900.0,
}


@dataclass(frozen=True)
class Training:
    """One :func:`evaluate` call of a study: a name (its folder under ``OUT/runs``), datasets, a
    model."""

    name: str
    train: tuple[DataSpec, ...]
    test: tuple[DataSpec, ...]
    model: str = "classical"


@dataclass
class Context:
    out: Path
    cache: Path
    seeds: tuple[int, ...]
    scenes: int
    test_scenes: int
    cameras: int
    workers: int
    progress: bool

    def train(self, strategy: str, sensor: str, balance: str | None = None) -> DataSpec:
        return ds.train_spec(strategy, sensor, self.scenes, self.cameras, balance)

    def test(self, strategy: str, sensor: str) -> DataSpec:
        return ds.test_spec(strategy, sensor, self.test_scenes, self.cameras)

    def target_train(self) -> DataSpec:
        return DataSpec(
            TARGET[0], TARGET[1], ds.TARGET_SEED, max(2, self.test_scenes - 1), self.cameras
        )


def _plan(study: str, c: Context) -> list[Training]:
    d435 = PROFILE
    if study == "strategy":
        out = []
        for held in STRATEGIES:
            others = tuple(c.train(s, d435) for s in STRATEGIES if s != held)
            test = (c.test(held, d435),)
            for model in ("classical", "height", "majority"):
                out.append(Training(f"strategy-{model}-to-{held}", others, test, model))
            out.append(Training(f"strategy-classical-in-{held}", (c.train(held, d435),), test))
        return out
    if study == "sensor":
        tests = tuple(c.test("assembly_line", s) for s in SENSORS)
        return [Training(f"sensor-{s}", (c.train("assembly_line", s),), tests) for s in SENSORS]
    if study == "accuracy":
        test = (c.test("assembly_line", d435),)
        runs = [
            Training(f"accuracy-no-{e}", (c.train("assembly_line", f"{d435}-no-{e}"),), test)
            for e in ds.profile_effects(d435)
        ]
        # the full profile and the ideal sensor: the sensor study's trainings (shared)
        runs += [
            Training(
                f"sensor-{s}",
                (c.train("assembly_line", s),),
                tuple(c.test("assembly_line", x) for x in SENSORS),
            )
            for s in (d435, "ideal_pinhole")
        ]
        return runs
    if study == "balance":
        test = (c.test("assembly_line", d435),)
        return [
            Training(
                f"sensor-{d435}",
                (c.train("assembly_line", d435),),
                tuple(c.test("assembly_line", s) for s in SENSORS),
            ),
            Training("balance-paper", (c.train("assembly_line", d435, "paper"),), test),
        ]
    if study == "models":
        return [
            Training(
                f"sensor-{d435}",
                (c.train("assembly_line", d435),),
                tuple(c.test("assembly_line", s) for s in SENSORS),
            ),
            Training(
                "models-randla",
                (c.train("assembly_line", d435),),
                (c.test("assembly_line", d435),),
                "randla",
            ),
        ]
    raise ConfigError(f"--study {study!r}: unknown")


def _mix_specs(c: Context) -> tuple[DataSpec, DataSpec, list[DataSpec]]:
    return (
        c.target_train(),
        DataSpec(TARGET[0], TARGET[1], ds.TEST_SEED, c.test_scenes, c.cameras),
        [c.train(s, PROFILE) for s in STRATEGIES if s != TARGET[0]],
    )


def estimate(
    trainings: Sequence[Training], data: Sequence[DataSpec], c: Context, extra_trainings: int = 0
) -> str:
    """A time estimate before a study starts: datasets to make, trainings to run."""
    todo = [d for d in dict.fromkeys(data) if not ds.is_complete(d, c.cache)]
    data_s = sum(d.estimate_s() for d in todo)
    runs = [t for t in trainings if not _done(t, c)]
    train_s = sum(SECONDS_PER_TRAINING.get(t.model, 120.0) * len(c.seeds) for t in runs)
    train_s += extra_trainings * SECONDS_PER_TRAINING["classical"]
    return (
        f"{len(todo)} datasets to make ({sum(d.scenes for d in todo)} scenes, ~{data_s / 60:.0f} "
        "min), "
        f"{len(runs) * len(c.seeds) + extra_trainings} trainings (~{train_s / 60:.0f} min): "
        f"~{(data_s + train_s) / 60:.0f} min on 2 cores"
    )


def _done(t: Training, c: Context) -> bool:
    """Whether ``OUT/runs/<name>`` holds this training: its seeds, model and datasets (a run of
    another size, ``--scenes``, ``--test-scenes`` or ``--cameras``, is not reused)."""
    m = c.out / "runs" / t.name / "metrics.json"
    if not m.exists():
        return False
    data = json.loads(m.read_text())
    tests = [Path(x.get("spec", "")).name for x in data.get("tests", [])]
    return (
        data.get("seeds") == list(c.seeds)
        and data.get("model") == t.model
        and [Path(x).name for x in data.get("train", [])] == [d.name for d in t.train]
        and tests == [d.name for d in t.test]
    )


def _wait_for_other(path: Path) -> None:
    """Two studies that share a training (another process of this machine running it now):
    wait for it rather than train it twice."""
    pid_file = path / ".training-pid"
    while pid_file.exists() and not (path / "metrics.json").exists():
        try:
            pid = int(pid_file.read_text())
            if pid == os.getpid():
                return
            os.kill(pid, 0)
        except (ValueError, ProcessLookupError, PermissionError, OSError):
            return
        time.sleep(10)


def run_training(t: Training, c: Context) -> dict:
    """The training's metrics (``metrics.json``'s content), run now unless already there."""
    path = c.out / "runs" / t.name
    _wait_for_other(path)
    if _done(t, c):
        return json.loads((path / "metrics.json").read_text())
    made = not path.exists()
    path.mkdir(parents=True, exist_ok=True)
    pid = path / ".training-pid"
    pid.write_text(str(os.getpid()))
    try:
        folders = [
            str(ds.ensure(d, c.cache, workers=c.workers, progress=c.progress))
            for d in t.train + t.test
        ]
        log.info("training %s (%s) on %s", t.name, t.model, ", ".join(folders[: len(t.train)]))
        t0 = time.perf_counter()
        evaluate(  # a failed evaluation removes what it wrote itself
            folders[: len(t.train)],
            folders[len(t.train) :],
            model=t.model,
            seeds=c.seeds,
            out=path,
            workers=c.workers,
            cache=c.cache / "features",
            progress=c.progress,
        )
    except BaseException:  # no unfinished training left: its mark, and its folder if made now
        pid.unlink(missing_ok=True)
        if made and not any(path.iterdir()):
            path.rmdir()
        raise
    log.info("%s: %.0f s", t.name, time.perf_counter() - t0)
    return json.loads((path / "metrics.json").read_text())


def _costs_study(c: Context, confirm: bool) -> str:
    head = (
        f"study costs: each {PROFILE} effect timed alone on {c.cameras} frames, 5 times "
        f"(~{c.cameras * 6 * 5 * 0.1 / 60:.0f}-{c.cameras * 6 * 5 * 0.5 / 60:.0f} min on 2 cores)"
    )
    print(head, flush=True)
    if not confirm:
        return head + "\n(run again with --yes to start)"
    # a name of the user's is refused before anything is written
    folder = claim_folder(c.out, "eval-study", ("costs.md", "costs.json"), reserve=True)
    with folder.abandoning():  # a failed run leaves nothing it wrote
        result = time_effects(
            PROFILE, "assembly_line", frames=c.cameras, repeats=5, seed=ds.TRAIN_SEED
        )
        text = costs_markdown(
            result, f"genie eval --study costs --cameras {c.cameras} --out {c.out} --yes"
        )
        atomic_write_text(c.out / "costs.json", json.dumps(result, indent=1) + "\n")
        atomic_write_text(c.out / "costs.md", text)
        folder.finish({"study": "costs", "cameras": c.cameras})
    return text


def run_study(
    study: str,
    *,
    out: Path,
    cache: Path,
    seeds: Sequence[int] = (0, 1, 2),
    scenes: int = ds.SCENES,
    test_scenes: int = ds.TEST_SCENES,
    cameras: int = ds.CAMERAS,
    workers: int = 1,
    progress: bool = True,
    confirm: bool = True,
) -> str:
    """Run ``study`` (or ``all``); returns the markdown it wrote to ``out/<study>.md``."""
    if scenes < 1 or test_scenes < 1 or cameras < 1:
        raise ConfigError("--scenes, --test-scenes and --cameras must be >= 1")
    c = Context(
        Path(out), Path(cache), tuple(seeds), scenes, test_scenes, cameras, workers, progress
    )
    if study == "costs":
        return _costs_study(c, confirm)
    names = (
        ["strategy", "sensor", "accuracy", "balance", "models", "mix"]
        if study == "all"
        else [study]
    )
    trainings: list[Training] = []
    data: list[DataSpec] = []
    extra = 0
    for n in names:
        if n == "mix":
            tt, te, syn = _mix_specs(c)
            data += [tt, te, *syn]
            extra += 10 * len(c.seeds)
        else:
            for t in _plan(n, c):
                trainings.append(t)
                data += [*t.train, *t.test]
    text = estimate(trainings, data, c, extra)
    log.info("study %s: %s", study, text)
    print(f"study {study}: {text}", flush=True)
    if not confirm:
        return f"study {study}: {text}\n(run again with --yes to start)"
    # a name of the user's is refused before anything is written
    claim_folder(c.out, "eval-study", [f"{n}.md" for n in names])
    parts = []
    for n in names:  # each study claims the folder anew: a failed one removes what it wrote,
        # finished studies, trainings (runs/) and datasets (cache/) stay for the next run
        folder = claim_folder(c.out, "eval-study", [f"{n}.md"], reserve=True)
        with folder.abandoning(keep=("runs", "cache")):
            if n == "mix":
                parts.append(report.mix_study(c, *_mix_specs(c)))
            else:
                results = {t.name: (t, run_training(t, c)) for t in _plan(n, c)}
                parts.append(getattr(report, f"{n}_study")(c, results))
            atomic_write_text(c.out / f"{n}.md", parts[-1])
            folder.finish(
                {
                    "study": n,
                    "seeds": list(c.seeds),
                    "scenes": c.scenes,
                    "test_scenes": c.test_scenes,
                    "cameras": c.cameras,
                    "cache": str(c.cache),
                }
            )
    return "\n".join(parts)
