"""``genie eval``: train a segmentation model on datasets and test it on others; the paper's
protocols; the project's studies.

::

    genie eval --train DIR [DIR ...] --test DIR [DIR ...] [--model
    classical|height|majority|randla]
               [--seeds 0,1,2] [--label-map FILE] --out OUT
    genie eval --preset mix|finetune|scarce --target-train DIR --target-test DIR --train SYNTHETIC
    ... --out OUT
    genie eval --study strategy|sensor|accuracy|balance|models|mix|costs|all --out OUT [--scenes 10
    --test-scenes 4]
    genie eval --bench [--train DIR]      # training time of the classical model on ~1 M points

A dataset is ``DIR`` or ``DIR:train|valid|test|00,03`` (sequences or scenes of it).
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from pathlib import Path

from ..validation.bounds import MAX_SEED
from ..errors import ConfigError
from ..limits import MAX_CAMERAS
from . import count, counts

log = logging.getLogger(__name__)
STUDY_NAMES = ("strategy", "sensor", "accuracy", "balance", "models", "mix", "costs", "all")
# the names of genie_gl.eval.run.MODELS and genie_gl.eval.protocols.PRESETS, spelt here so that
# `genie eval --help` imports no model (tests/eval/test_inputs.py checks they agree)
MODELS = ("classical", "height", "majority", "randla")
PRESETS = ("mix", "finetune", "scarce")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--train", nargs="+", metavar="DIR", help="training datasets (DIR or DIR:PART)")
    p.add_argument("--test", nargs="+", metavar="DIR", help="test datasets (DIR or DIR:PART)")
    p.add_argument("--model", default=None, help=f"one of {', '.join(MODELS)} (default classical)")
    p.add_argument(
        "--seeds",
        type=counts(0, MAX_SEED),
        default=None,
        help="comma-separated seeds, each once, one training each (default 0,1,2; >= 3 for a "
        "spread)",
    )
    p.add_argument(
        "--label-map",
        default=None,
        metavar="FILE",
        help="YAML/JSON {map: {their class: our class}} for a foreign SemanticKITTI set",
    )
    p.add_argument("--out", required=False, help="output folder")
    p.add_argument(
        "--workers",
        type=count(1, 1024),
        default=2,
        help="processes/threads (results do not depend on it)",
    )
    p.add_argument(
        "--cache",
        default=None,
        help="feature and dataset cache (default: OUT/cache, inside the output folder)",
    )
    p.add_argument(
        "--allow-overlap",
        action="store_true",
        help="test on scans that are training scans too (refused by default: the score would be on "
        "training data)",
    )
    p.add_argument(
        "--preset",
        choices=PRESETS,
        default=None,
        help="a paper protocol (with --target-train/--target-test)",
    )
    p.add_argument(
        "--target-train",
        default=None,
        metavar="DIR",
        help="the target's training set (your real scans)",
    )
    p.add_argument("--target-test", default=None, metavar="DIR", help="the target's test set")
    p.add_argument(
        "--study",
        choices=STUDY_NAMES,
        default=None,
        help="run a study (makes its datasets once, cached)",
    )
    p.add_argument(
        "--scenes",
        type=count(1, 100_000),
        default=None,
        help="study: training scenes per condition (default 10)",
    )
    p.add_argument(
        "--test-scenes",
        type=count(1, 100_000),
        default=None,
        help="study: held-out test scenes per condition (default 4)",
    )
    p.add_argument(
        "--cameras",
        type=count(1, MAX_CAMERAS),
        default=None,
        help="study: cameras per scene (default 16)",
    )
    p.add_argument(
        "--yes", action="store_true", help="study: do not stop after printing the time estimate"
    )
    p.add_argument(
        "--steps",
        type=count(1, 10_000_000),
        default=None,
        help="training steps of RandLA-Net (1500 by default)",
    )
    p.add_argument(
        "--bench", action="store_true", help="time the classical model's training on ~1 M points"
    )
    p.add_argument("--no-progress", action="store_true")


def _seeds(value) -> list[int]:
    """The trainings' seeds: each once (a seed given twice would train the same model twice and
    show a spread of 0)."""
    if value is None:
        return [0, 1, 2]
    if isinstance(value, str):  # a caller's "0,1,2"
        try:
            value = [int(s) for s in value.split(",") if s.strip()]
        except ValueError:
            value = []
    if not value or min(value) < 0:
        raise ConfigError(
            f"--seeds {value!r}: expected comma-separated integers >= 0, such as 0,1,2"
        )
    twice = sorted({s for s in value if list(value).count(s) > 1})
    if twice:
        raise ConfigError(
            f"--seeds {','.join(map(str, value))}: seed {', '.join(map(str, twice))} given more "
            "than once; "
            "each seed trains one model, so give each once (0,1,2)"
        )
    return list(value)


# the options of one way of running genie eval (given to another, they are refused, never ignored)
MODES = {
    "study": ("scenes", "test_scenes", "cameras", "yes"),
    "preset": ("target_train", "target_test"),
    "train/test": ("test", "label_map", "model", "seeds", "allow_overlap", "steps"),
}
USED = {
    "bench": {"train", "workers", "out", "cache"},
    "study": {"scenes", "test_scenes", "cameras", "yes", "seeds", "workers", "out", "cache"},
    "preset": {
        "preset",
        "target_train",
        "target_test",
        "train",
        "model",
        "seeds",
        "workers",
        "label_map",
        "out",
        "cache",
        "steps",
    },
    "train/test": {
        "train",
        "test",
        "model",
        "seeds",
        "label_map",
        "workers",
        "out",
        "cache",
        "allow_overlap",
        "steps",
    },
}
FLAG = {
    "test_scenes": "--test-scenes",
    "target_train": "--target-train",
    "target_test": "--target-test",
    "label_map": "--label-map",
    "allow_overlap": "--allow-overlap",
}


def check_mode(args: argparse.Namespace) -> str:
    """Which way genie eval runs (--bench, --study, --preset or train/test); an option that way
    does not use is refused in one line naming the way it belongs to."""
    mode = (
        "bench"
        if args.bench
        else "study"
        if args.study
        else "preset"
        if args.preset
        else "train/test"
    )
    for key in (
        "train",
        "test",
        "model",
        "seeds",
        "label_map",
        "scenes",
        "test_scenes",
        "cameras",
        "target_train",
        "target_test",
        "cache",
        "preset",
        "allow_overlap",
        "steps",
    ):
        value = getattr(args, key, None)
        if value is None or value is False or key in USED[mode]:
            continue
        flag = FLAG.get(key, f"--{key.replace('_', '-')}")
        owner = next((m for m, keys in MODES.items() if key in keys), None)
        way = {"study": "--study", "preset": "--preset", "train/test": "--train/--test"}.get(
            owner or "", ""
        )
        raise ConfigError(
            f"{flag}: not used by genie eval "
            f"{'--' + mode if mode != 'train/test' else '--train/--test'}"
            + (f"; it is for {way}" if way else "")
            + "; drop it"
        )
    if args.yes and mode != "study":
        raise ConfigError("--yes: not used here; it is for --study; drop it")
    if args.label_map is not None and not Path(args.label_map).is_file():
        raise ConfigError(f"--label-map {args.label_map}: no such file (a YAML/JSON label map)")
    return mode


def _params(model: str, steps: int | None):
    """The model's parameters with ``--steps`` (None: the model's defaults)."""
    if steps is None:
        return None
    if model == "randla":
        from ..eval.randla import RandLAParams

        return RandLAParams(steps=steps)
    raise ConfigError(f"--steps: the {model} model has no training steps; it is for --model randla")


def _cache(args: argparse.Namespace) -> Path:
    """The cache: the user's ``--cache`` folder, or ``OUT/cache``, inside the output folder (a run
    writes nowhere it was not told to)."""
    if args.cache:
        return Path(args.cache)
    return Path(args.out) / "cache"


def run(args: argparse.Namespace) -> int:
    # LightGBM's OpenMP threads spin while they wait; on a shared machine that burns the other
    # thread's core (measured: 8x the CPU per boosting round at load 10). Passive waiting,
    # set before the OpenMP runtime loads, unless the user chose otherwise.
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    if args.workers < 1:
        raise ConfigError("--workers must be >= 1")
    check_mode(args)
    model = args.model or "classical"
    progress = not args.no_progress
    if args.bench:
        from ..eval.bench import bench_training

        print(bench_training(args.train, out=args.out, workers=args.workers, cache=args.cache))
        return 0
    if not args.out:
        raise ConfigError("--out: required (the folder for metrics, predictions and pictures)")
    seeds = _seeds(args.seeds)
    params = _params(model, getattr(args, "steps", None))
    if args.study:
        from ..studies.runner import run_study

        text = run_study(
            args.study,
            out=Path(args.out),
            cache=_cache(args),
            seeds=seeds,
            scenes=args.scenes or 10,
            test_scenes=args.test_scenes or 4,
            cameras=args.cameras or 16,
            workers=args.workers,
            progress=progress,
            confirm=args.yes,
        )
        print(text)
        return 0
    if args.preset:
        if not (args.target_train and args.target_test and args.train):
            raise ConfigError(
                f"--preset {args.preset}: needs --target-train DIR, --target-test DIR and "
                "--train SYNTHETIC [...] (the synthetic data)"
            )
        from ..eval import protocols
        from ..outputs import claim_folder
        from ..studies.report import preset_markdown

        folder = claim_folder(args.out, "eval-preset", reserve=True)
        # a failed run leaves nothing it wrote but its cache of features
        with folder.abandoning(keep=("cache",)):
            if args.preset == "finetune":
                res = protocols.finetune(
                    args.target_train,
                    args.target_test,
                    args.train,
                    out=args.out,
                    model=model,
                    seeds=seeds,
                    workers=args.workers,
                    label_map=args.label_map,
                    cache=_cache(args) / "features",
                    progress=progress,
                    params=params,
                )
            else:
                res = protocols.mix(
                    args.target_train,
                    args.target_test,
                    args.train,
                    out=args.out,
                    model=model,
                    seeds=seeds,
                    scarce=args.preset == "scarce",
                    workers=args.workers,
                    label_map=args.label_map,
                    cache=_cache(args) / "features",
                    progress=progress,
                    params=params,
                )
            text = preset_markdown(args.preset, res, Path(args.out))
            folder.finish(
                {
                    "inputs": {
                        "preset": args.preset,
                        "target_train": args.target_train,
                        "target_test": args.target_test,
                        "train": list(args.train),
                        "model": model,
                        "seeds": seeds,
                        "label_map": args.label_map,
                    }
                }
            )
        print(text)
        return 0
    if not args.train or not args.test:
        raise ConfigError("give --train DIR ... and --test DIR ... (or --preset, --study, --bench)")
    from ..eval import evaluate

    result = evaluate(
        args.train,
        args.test,
        model=model,
        seeds=seeds,
        out=args.out,
        workers=args.workers,
        label_map=args.label_map,
        cache=_cache(args) / "features",
        progress=progress,
        allow_overlap=args.allow_overlap,
        params=params,
    )
    for t in result.tests:
        s = t.summary
        extra = (
            f"; never seen in training: {', '.join(result.names[c] for c in t.unseen)}"
            if t.unseen
            else ""
        )
        print(
            f"{t.name}: mIoU {s['miou'].text()}  mAcc {s['macc'].text()}  OA {s['oa'].text()} "
            f"({len(seeds)} seeds){extra}"
        )
    print(f"-> {args.out}/report.md, metrics.json, predictions/")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(0)
