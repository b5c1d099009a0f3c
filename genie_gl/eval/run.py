"""``evaluate``: train a segmentation model on some datasets, test it on others, once per seed.

Each seed trains the model afresh (its sub-sample, validation scenes, bagging and, for the neural
model, initial weights and batches all come from ``numpy.random.default_rng(seed)``), predicts
every test point, writes the predictions as ``.label`` files (:mod:`.predictions`) and scores
them (:mod:`.metrics`). The figures over the seeds are reported with their spread. Output
folder::

    OUT/metrics.json        per seed and summarised (mean, std, min, max): mIoU, mAcc, OA, per
                            class IoU and Acc, confusion matrices; the same bytes for the same
                            inputs
    OUT/timings.json        seconds of each step, and a neural model's learning curves (not in
                            metrics.json: they vary run to run)
    OUT/report.md           the tables
    OUT/predictions/seed<S>/<test>/...   the .label files (class and instance id)
    OUT/<test>.confusion.png, OUT/<test>.iou.png
"""

from __future__ import annotations

import json
import logging
import os
import re
import time
from importlib.metadata import PackageNotFoundError, version
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import labels as label_names
from ..outputs import atomic_write_text, claim_folder
from ..errors import ConfigError, did_you_mean
from . import instances, metrics, panoptic, predictions
from .classical import BoostParams, ClassicalModel, HeightModel, MajorityModel
from .data import EvalSet, read_set
from .features import PointTable
from .labelmap import check_same_classes
from .randla import RandLAModel, RandLAParams
from .plots import confusion_png, iou_bars_png
from .report import result_markdown

log = logging.getLogger(__name__)
MODELS = ("classical", "height", "majority", "randla")


def make_model(name: str, n_classes: int, params: Any = None) -> Any:
    """A fresh, untrained model by name."""
    if name == "classical":
        return ClassicalModel(n_classes, params or BoostParams())
    if name == "height":
        return HeightModel(n_classes, params or BoostParams())
    if name == "majority":
        return MajorityModel(n_classes)
    if name == "randla":
        return RandLAModel(n_classes, params or RandLAParams())
    raise ConfigError(
        f"--model {name!r}: unknown{did_you_mean(name, MODELS)}; expected one of "
        f"{', '.join(MODELS)}"
    )


@dataclass(frozen=True)
class TestResult:
    """One test set's scores: one :class:`~.metrics.Scores` per seed and their summary."""

    spec: str
    name: str
    runs: tuple[metrics.Scores, ...]
    summary: dict
    unseen: tuple[int, ...]  # test classes no training point had
    n_points: int
    panoptic: dict = field(
        default_factory=dict
    )  # {"model" | "one per class": summary, "true classes": summary}


@dataclass(frozen=True)
class EvalResult:
    """What :func:`evaluate` measured."""

    model: str
    seeds: tuple[int, ...]
    train: tuple[str, ...]
    tests: tuple[TestResult, ...]
    names: dict[int, str]
    n_train_points: int
    rounds: tuple[int, ...] = ()
    cluster: Any = None  # the instance model's settings (instances.ClusterParams)
    timings: dict = field(default_factory=dict)
    out: Path | None = None

    def test(self, name_or_spec: str) -> TestResult:
        for t in self.tests:
            if name_or_spec in (t.name, t.spec):
                return t
        raise KeyError(name_or_spec)

    def as_dict(self) -> dict:
        def spread_dict(summary: dict) -> dict:
            return {
                "miou": summary["miou"].as_dict(),
                "macc": summary["macc"].as_dict(),
                "oa": summary["oa"].as_dict(),
                "iou": {
                    self.names.get(c, f"class_{c}"): s.as_dict() for c, s in summary["iou"].items()
                },
                "acc": {
                    self.names.get(c, f"class_{c}"): s.as_dict() for c, s in summary["acc"].items()
                },
                "confusion_summed": summary["confusion"].tolist(),
            }

        return {
            "model": self.model,
            "seeds": list(self.seeds),
            "train": list(self.train),
            "n_train_points": self.n_train_points,
            "rounds": list(self.rounds),
            "cluster": None
            if self.cluster is None
            else {
                "min_samples": self.cluster.min_samples,
                "eps_m": self.cluster.eps_m,
                "eps_m_by_class": {
                    self.names.get(c, f"class_{c}"): e for c, e in self.cluster.eps_by_class
                },
            },
            "classes": {str(k): v for k, v in sorted(self.names.items())},
            "tests": [
                {
                    "spec": t.spec,
                    "name": t.name,
                    "points": t.n_points,
                    "unseen_classes": [self.names.get(c, f"class_{c}") for c in t.unseen],
                    "summary": spread_dict(t.summary),
                    "panoptic": {
                        k: panoptic.spread_dict(v, self.names) for k, v in t.panoptic.items()
                    },
                    "runs": [
                        dict(seed=s, **r.as_dict(self.names)) for s, r in zip(self.seeds, t.runs)
                    ],
                }
                for t in self.tests
            ],
        }


def _per_scan(values: np.ndarray, test: EvalSet) -> list[np.ndarray]:
    """A test table's per-point array cut into its scans (in scan order)."""
    ends = np.cumsum([len(s) for s in test.scans])
    return np.split(np.asarray(values), ends[:-1])


def set_name(spec: str) -> str:
    """A file-name-safe short name of a dataset spec (``out/x/storage:test`` ->
    ``storage-test``)."""
    root, _, part = (
        str(spec).rstrip("/").partition(":")
        if not Path(str(spec)).exists()
        else (str(spec), "", "")
    )
    name = Path(root).name + (f"-{part}" if part else "")
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name) or "set"


def _as_set(x: str | os.PathLike | EvalSet, label_map: str | os.PathLike | None) -> EvalSet:
    return x if isinstance(x, EvalSet) else read_set(x, label_map=label_map)


def _write_json(path: Path, data: Any) -> None:
    atomic_write_text(path, json.dumps(data, indent=1, sort_keys=False) + "\n")


def _versions() -> dict[str, str]:
    out = {}
    for pkg in ("genie-gl", "numpy", "pgeof", "lightgbm", "torch"):
        try:
            out[pkg] = version(pkg)
        except PackageNotFoundError:
            pass
    return out


def evaluate(
    train: Sequence[str | os.PathLike | EvalSet],
    test: Sequence[str | os.PathLike | EvalSet],
    *,
    model: str = "classical",
    seeds: Sequence[int] = (0, 1, 2),
    out: str | os.PathLike | None = None,
    workers: int = 1,
    label_map: str | os.PathLike | None = None,
    cache: str | os.PathLike | None = None,
    progress: bool = False,
    class_map: dict[int, int] | None = None,
    eval_classes: Sequence[int] | None = None,
    params: Any = None,
    init: Any = None,
    write_predictions: bool = True,
    pictures: bool = True,
    allow_overlap: bool = False,
    cluster: instances.ClusterParams | None = None,
) -> EvalResult:
    """Train ``model`` on ``train`` and test it on each of ``test``, once per seed.

    Parameters
    ----------
    train, test : sequences of dataset specs (``DIR``, ``DIR:test``, ...) or read sets
    model : ``classical`` | ``height`` | ``majority`` | ``randla``
    seeds : at least one; three or more give a spread
    out : folder for metrics, predictions and pictures (None: nothing written)
    workers : processes for features, threads for the classifier; the results do not depend on it
    label_map : a label-map file for foreign SemanticKITTI sets (their classes -> ours)
    cache : folder for per-scan features (reused across runs)
    class_map : {our class: class the protocol trains on} (e.g. the ``scarce`` preset's 3 classes
        plus "other"); classes not listed keep their id
    eval_classes : classes to average over (default: those present in each test set)
    params : model parameters (``BoostParams`` or ``RandLAParams``)
    init : a function ``seed -> trained model`` to go on training from (fine-tuning)
    allow_overlap : test on scans that are training scans too (refused by default: the same
        file, or the same points read from another file)
    cluster : the instance model's DBSCAN settings (:mod:`.instances`; None: tuned on the
        training scans' true classes and instances, :func:`.instances.tune`); the panoptic figures
        (:mod:`.panoptic`) of the model, of one instance per class, and of the true classes
        clustered, are in each test's ``panoptic``

    Returns
    -------
    EvalResult

    Raises
    ------
    ConfigError
        Bad or overlapping inputs; the output folder is then left as it was (nothing written, or
        its last finished run's files and a manifest listing them).
    """
    seeds = tuple(int(s) for s in seeds)
    if not seeds:
        raise ConfigError("--seeds: at least one seed")
    if not train:
        raise ConfigError("--train: at least one dataset")
    if not test:
        raise ConfigError("--test: at least one dataset")
    if model not in MODELS:
        make_model(model, 10)  # the one-line refusal, before anything is read
    t0 = time.perf_counter()
    folder = None
    writes = ["metrics.json", "timings.json", "report.md", "predictions"]
    if out is not None and cache is not None and _inside(cache, out):
        writes.append(Path(os.path.relpath(Path(cache).resolve(), Path(out).resolve())).parts[0])
    if out is not None:  # claimed before any work: only what genie eval writes is ever replaced
        folder = claim_folder(out, "eval", writes)
    train_sets = [_as_set(x, label_map) for x in train]
    test_sets = [_as_set(x, label_map) for x in test]
    if not allow_overlap:
        check_disjoint(train_sets, test_sets)
    if folder is not None:  # the inputs are read and sound: from here on this run writes
        folder.reserve()
    begun: list[str] = []
    try:
        return _evaluate(
            train_sets,
            test_sets,
            model=model,
            seeds=seeds,
            out=out,
            workers=workers,
            label_map=label_map,
            cache=cache,
            progress=progress,
            class_map=class_map,
            eval_classes=eval_classes,
            params=params,
            init=init,
            write_predictions=write_predictions,
            pictures=pictures,
            cluster=cluster,
            folder=folder,
            begun=begun,
            t0=t0,
        )
    except BaseException:
        if (
            folder is not None
        ):  # a failed run leaves no partial output and a manifest of what exists
            folder.abandon(begun)
        raise


def _inside(path: str | os.PathLike, folder: str | os.PathLike) -> bool:
    p, f = Path(path).resolve(), Path(folder).resolve()
    return p != f and f in p.parents


def check_disjoint(train_sets: Sequence[EvalSet], test_sets: Sequence[EvalSet]) -> None:
    """Refuse test scans that are training scans too (the same file, or the same points read
    from another file): a score on data the model was trained on says nothing of new data."""
    seen: dict[str, tuple[str, str]] = {}
    for ts in train_sets:
        for s in ts.scans:
            seen.setdefault(os.path.realpath(s.path), (ts.spec, s.path))
            seen.setdefault(s.digest, (ts.spec, s.path))
    for ts in test_sets:
        both = [(s, seen.get(os.path.realpath(s.path)) or seen.get(s.digest)) for s in ts.scans]
        both = [(s, b) for s, b in both if b is not None]
        if both:
            s, (spec, path) = both[0]
            how = (
                "the same file"
                if os.path.realpath(path) == os.path.realpath(s.path)
                else f"the same points as {path}"
            )
            raise ConfigError(
                f"--test {ts.spec}: {len(both)} of its {len(ts.scans)} scans are training scans "
                "too "
                f"(--train {spec}; e.g. {s.path}: {how}); a score on training data says nothing of "
                "new "
                "data: test on other scans (DIR:test, another set), or allow it with "
                "--allow-overlap"
            )


def _evaluate(
    train_sets: list[EvalSet],
    test_sets: list[EvalSet],
    *,
    model: str,
    seeds: tuple[int, ...],
    out: str | os.PathLike | None,
    workers: int,
    label_map: str | os.PathLike | None,
    cache: str | os.PathLike | None,
    progress: bool,
    class_map: dict[int, int] | None,
    eval_classes: Sequence[int] | None,
    params: Any,
    init: Any,
    write_predictions: bool,
    pictures: bool,
    cluster: instances.ClusterParams | None,
    folder: Any,
    begun: list[str],
    t0: float,
) -> EvalResult:
    """:func:`evaluate` once its inputs are read; ``begun`` collects the outputs it starts
    writing."""
    everything = train_sets + test_sets
    names = dict(label_names.CLASSES)
    named_by: dict[int, str] = {}
    for s in everything:  # every set against the names the sets before it gave
        for k in set(names) & set(s.names):
            check_same_classes(
                {k: names[k]}, named_by.get(k, "genie-gl's classes"), {k: s.names[k]}, s.spec
            )
        for k, v in s.names.items():
            named_by.setdefault(k, s.spec)
            names[k] = v
    lut = None
    n_classes = max(10, max(s.max_class() for s in everything) + 1)
    if class_map is not None:
        lut = np.arange(n_classes, dtype=np.int16)
        for a, b in class_map.items():
            lut[int(a)] = int(b)
        n_classes = int(lut.max()) + 1
    opts = {"workers": workers, "cache": cache, "progress": progress}
    train_pts = PointTable([s for ts in train_sets for s in ts.scans], class_map=lut, **opts)
    if not (train_pts.labels >= 0).any():
        raise ConfigError(f"--train {', '.join(s.spec for s in train_sets)}: no labelled point")
    seen = set(np.unique(train_pts.labels[train_pts.labels >= 0]).tolist())
    test_pts = [PointTable(list(s.scans), class_map=lut, **opts) for s in test_sets]
    for labels in [train_pts.labels] + [
        tp.labels for tp in test_pts
    ]:  # a class no map names (a PLY
        for c in np.unique(labels[labels >= 0]).tolist():  # set's own id): named by its id
            names.setdefault(int(c), f"class {c}")
    t_read = time.perf_counter() - t0
    needs_features = model not in ("majority", "randla")
    t1 = time.perf_counter()
    if needs_features:
        _ = train_pts.features
        for tp in test_pts:
            _ = tp.features
    t_features = time.perf_counter() - t1
    out_p = Path(out) if out is not None else None
    runs: list[list[metrics.Scores]] = [[] for _ in test_sets]
    # panoptic: the truth per scan, and the true classes clustered (what the clustering alone loses)
    t_pan = time.perf_counter()
    if cluster is None:
        train_scans = [sc for ts in train_sets for sc in ts.scans]
        cluster = instances.tune(
            [sc.xyz for sc in train_scans],
            np.split(train_pts.labels, np.cumsum([len(sc) for sc in train_scans])[:-1]),
            [i for ts in train_sets for i in panoptic.truth_instances(ts)],
            n_classes,
        )
    truth = [_per_scan(tp.labels, ts) for ts, tp in zip(test_sets, test_pts)]
    truth_inst = [panoptic.truth_instances(ts) for ts in test_sets]
    xyz = [[s.xyz for s in ts.scans] for ts in test_sets]
    upper_inst = [instances.scan_instances(x, t, params=cluster) for x, t in zip(xyz, truth)]
    pan_runs: list[dict[str, list]] = [
        {"model": [], "one per class": [], "true classes": []} for _ in test_sets
    ]
    t_panoptic = time.perf_counter() - t_pan
    rounds, t_train, t_pred, curves = [], [], [], []
    for seed in seeds:
        m = make_model(model, n_classes, params)
        t2 = time.perf_counter()
        m.fit(
            train_pts,
            rng=np.random.default_rng(seed),
            threads=workers,
            init=init(seed) if init is not None else None,
            progress=progress,
        )
        t_train.append(time.perf_counter() - t2)
        rounds.append(int(getattr(m, "rounds_used", 0)))
        curves.append(list(getattr(m, "curve", [])))
        for j, (ts, tp) in enumerate(zip(test_sets, test_pts)):
            t3 = time.perf_counter()
            pred = m.predict(tp, threads=workers)
            t_pred.append(time.perf_counter() - t3)
            conf = metrics.confusion(tp.labels, pred, n_classes)
            sc = metrics.scores(conf, eval_classes)
            runs[j].append(sc)
            t4 = time.perf_counter()
            pred_scans = _per_scan(pred, ts)
            inst = instances.scan_instances(xyz[j], pred_scans, params=cluster)
            for key, (ps, pi) in {
                "model": (pred_scans, inst),
                "one per class": (
                    pred_scans,
                    instances.scan_instances(xyz[j], pred_scans, "one_per_class"),
                ),
                "true classes": (truth[j], upper_inst[j]),
            }.items():
                pan_runs[j][key].append(
                    panoptic.evaluate_scans(
                        truth[j],
                        truth_inst[j],
                        ps,
                        pi,
                        sc.classes,
                        sc.iou
                        if key != "true classes"
                        else np.where(np.isnan(sc.iou), np.nan, 1.0),
                        n_classes,
                    )
                )
            t_panoptic += time.perf_counter() - t4
            if out_p is not None and write_predictions:
                if "predictions" not in begun:  # a previous run's predictions go as a whole
                    begun.append("predictions")
                    if folder is not None:
                        folder.remove("predictions")
                predictions.write(
                    ts, pred, out_p / "predictions" / f"seed{seed}" / set_name(ts.spec), inst
                )
    tests = []
    for ts, tp, r, pr in zip(test_sets, test_pts, runs, pan_runs):
        present = set(np.unique(tp.labels[tp.labels >= 0]).tolist())
        unseen = tuple(sorted(present - seen))
        if unseen:
            log.warning(
                "%s: test classes never seen in training: %s (scored, IoU 0 unless predicted)",
                ts.spec,
                ", ".join(names.get(c, str(c)) for c in unseen),
            )
        tests.append(
            TestResult(
                spec=ts.spec,
                name=set_name(ts.spec),
                runs=tuple(r),
                summary=metrics.summarise(r),
                unseen=unseen,
                n_points=len(tp),
                panoptic={k: panoptic.summarise(v) for k, v in pr.items()},
            )
        )
    result = EvalResult(
        model=model,
        seeds=seeds,
        train=tuple(s.spec for s in train_sets),
        tests=tuple(tests),
        names=names,
        n_train_points=len(train_pts),
        rounds=tuple(rounds),
        cluster=cluster,
        timings={
            "read_s": t_read,
            "features_s": t_features,
            "train_s": t_train,
            "predict_s": t_pred,
            "panoptic_s": t_panoptic,
            "total_s": time.perf_counter() - t0,
            **({"learning_curves": curves} if any(curves) else {}),
        },
        out=out_p,
    )
    if out_p is not None and folder is not None:
        begun.extend(["metrics.json", "timings.json", "report.md"])
        _write_json(out_p / "metrics.json", result.as_dict())
        _write_json(out_p / "timings.json", result.timings)
        atomic_write_text(out_p / "report.md", result_markdown(result))
        if pictures:
            for t in result.tests:
                confusion_png(
                    t.summary["confusion"],
                    names,
                    out_p / f"{t.name}.confusion.png",
                    title=f"{model} on {t.name} (summed over {len(seeds)} seeds)",
                )
                iou_bars_png(
                    {model: t.summary},
                    names,
                    out_p / f"{t.name}.iou.png",
                    title=f"IoU per class, {t.name}",
                )
        folder.finish(
            {
                "inputs": {
                    "train": list(result.train),
                    "test": [t.spec for t in result.tests],
                    "model": model,
                    "seeds": list(seeds),
                    "label_map": str(label_map) if label_map else None,
                    "params": repr(params) if params is not None else "defaults",
                },
                "versions": _versions(),
            }
        )
    return result
