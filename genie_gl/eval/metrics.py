"""Segmentation metrics as the paper defines them (§4.4.1), and their spread over seeds.

Per class: accuracy ``Acc_c = TP_c / (TP_c + FN_c)`` (the share of the class's points predicted
as it) and ``IoU_c = TP_c / (TP_c + FP_c + FN_c)``; ``mAcc`` and ``mIoU`` are their means over
the *evaluated* classes, and the overall accuracy ``OA`` is the diagonal of the confusion matrix
over its sum. The evaluated classes are those present in the test set's ground truth (a class no
test point has cannot be scored; semantic-kitti-api's ``iouEval`` gives the same means when
those classes are passed as its ``ignore`` list, and a test checks that on written ``.label``
files). Points whose ground truth is unlabelled (-1) are left out of everything.

A figure over several seeds is a :class:`Spread` (mean, sample standard deviation, min, max).
Two figures are compared by :func:`compare`: a difference of means no larger than the sum of
their standard deviations is "within spread", never a gain or a loss.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError


def confusion(truth: np.ndarray, pred: np.ndarray, n_classes: int) -> np.ndarray:
    """Confusion matrix ``C[t, p]`` = points of true class t predicted as p.

    Parameters
    ----------
    truth, pred : (N,) int
        Class ids in ``0..n_classes-1``; ``truth`` < 0 marks unlabelled points, left out.
    n_classes : int

    Returns
    -------
    (n_classes, n_classes) int64
    """
    truth = np.asarray(truth).astype(np.int64).ravel()
    pred = np.asarray(pred).astype(np.int64).ravel()
    if truth.shape != pred.shape:
        raise ConfigError(f"confusion: {truth.size} labels against {pred.size} predictions")
    keep = truth >= 0
    truth, pred = truth[keep], pred[keep]
    if truth.size and (truth.max() >= n_classes or pred.min() < 0 or pred.max() >= n_classes):
        raise ConfigError(
            f"confusion: class ids must lie in 0..{n_classes - 1} "
            f"(got truth {int(truth.max())}, predictions {int(pred.min())}..{int(pred.max())})"
        )
    return np.bincount(truth * n_classes + pred, minlength=n_classes * n_classes).reshape(
        n_classes, n_classes
    )


@dataclass(frozen=True)
class Scores:
    """The paper's metrics of one run.

    Attributes
    ----------
    confusion : (C, C) int64
        ``confusion[t, p]``: points of true class t predicted as p.
    classes : (K,) int
        The evaluated classes: present in the ground truth (or given).
    iou, acc : (C,) float64
        Per class; NaN for a class that is not evaluated.
    miou, macc, oa : float
        Means of ``iou`` and ``acc`` over ``classes``; overall accuracy over every labelled point.
    """

    confusion: np.ndarray
    classes: np.ndarray
    iou: np.ndarray
    acc: np.ndarray
    miou: float
    macc: float
    oa: float

    def as_dict(self, names: dict[int, str] | None = None) -> dict:
        name = (lambda c: names.get(c, f"class_{c}")) if names else (lambda c: f"class_{c}")
        return {
            "miou": self.miou,
            "macc": self.macc,
            "oa": self.oa,
            "classes": [int(c) for c in self.classes],
            "iou": {name(int(c)): float(self.iou[c]) for c in self.classes},
            "acc": {name(int(c)): float(self.acc[c]) for c in self.classes},
            "confusion": self.confusion.tolist(),
        }


def scores(conf: np.ndarray, classes: Sequence[int] | None = None) -> Scores:
    """The paper's metrics from a confusion matrix.

    Parameters
    ----------
    conf : (C, C) int
        ``conf[t, p]`` as :func:`confusion` makes it.
    classes : sequence of int, optional
        Classes to average over; default: those with at least one true point.
    """
    conf = np.asarray(conf, dtype=np.int64)
    if conf.ndim != 2 or conf.shape[0] != conf.shape[1]:
        raise ConfigError(f"scores: a square confusion matrix expected, got shape {conf.shape}")
    tp = np.diag(conf).astype(np.float64)
    true_n = conf.sum(1).astype(np.float64)
    pred_n = conf.sum(0).astype(np.float64)
    if classes is None:
        classes = np.flatnonzero(true_n > 0)
    classes = np.asarray(sorted(int(c) for c in classes), dtype=np.int64)
    if classes.size == 0:
        raise ConfigError("scores: no labelled test point: nothing to evaluate")
    iou = np.full(len(conf), np.nan)
    acc = np.full(len(conf), np.nan)
    union = true_n + pred_n - tp
    iou[classes] = np.divide(
        tp[classes], union[classes], out=np.zeros(len(classes)), where=union[classes] > 0
    )
    acc[classes] = np.divide(
        tp[classes], true_n[classes], out=np.zeros(len(classes)), where=true_n[classes] > 0
    )
    total = conf.sum()
    return Scores(
        confusion=conf,
        classes=classes,
        iou=iou,
        acc=acc,
        miou=float(iou[classes].mean()),
        macc=float(acc[classes].mean()),
        oa=float(tp.sum() / total) if total else 0.0,
    )


@dataclass(frozen=True)
class Spread:
    """One figure over several seeds: mean, sample standard deviation (ddof 1; 0 for one
    value), min, max and the values themselves."""

    mean: float
    std: float
    lo: float
    hi: float
    values: tuple[float, ...] = field(default=())

    @classmethod
    def of(cls, values: Sequence[float]) -> "Spread":
        v = np.asarray([float(x) for x in values], dtype=np.float64)
        if v.size == 0:
            raise ConfigError("a spread needs at least one value")
        finite = v[np.isfinite(v)]
        if finite.size == 0:
            return cls(math.nan, math.nan, math.nan, math.nan, tuple(v.tolist()))
        std = float(finite.std(ddof=1)) if finite.size > 1 else 0.0
        return cls(
            float(finite.mean()), std, float(finite.min()), float(finite.max()), tuple(v.tolist())
        )

    def text(self, digits: int = 3) -> str:
        """``0.441 ± 0.012``."""
        if not math.isfinite(self.mean):
            return "—"
        return f"{self.mean:.{digits}f} ± {self.std:.{digits}f}"

    def as_dict(self) -> dict:
        return {
            "mean": self.mean,
            "std": self.std,
            "min": self.lo,
            "max": self.hi,
            "values": list(self.values),
        }


def compare(a: Spread, b: Spread) -> tuple[float, float, str]:
    """``a`` against ``b``: (difference of means, its spread = std a + std b, verdict) where the
    verdict is ``"gain"`` or ``"loss"`` only when the difference exceeds its spread, else
    ``"within spread"``."""
    d = a.mean - b.mean
    s = a.std + b.std
    if not (math.isfinite(d) and math.isfinite(s)):
        return d, s, "not comparable"
    if abs(d) <= s:
        return d, s, "within spread"
    return d, s, "gain" if d > 0 else "loss"


def delta_text(a: Spread, b: Spread, digits: int = 3) -> str:
    """``+0.052 ± 0.010 (gain)`` or ``+0.004 ± 0.012 (within spread)``."""
    d, s, verdict = compare(a, b)
    if not math.isfinite(d):
        return "—"
    return f"{d:+.{digits}f} ± {s:.{digits}f} ({verdict})"


def summarise(runs: Sequence[Scores]) -> dict:
    """Per-seed scores into spreads: ``{"miou": Spread, "macc", "oa", "iou": {c: Spread}, "acc":
    {...},
    "confusion": (C, C) summed over the runs}``; the classes are those evaluated in any run."""
    if not runs:
        raise ConfigError("no run to summarise")
    classes = sorted({int(c) for r in runs for c in r.classes})
    return {
        "miou": Spread.of([r.miou for r in runs]),
        "macc": Spread.of([r.macc for r in runs]),
        "oa": Spread.of([r.oa for r in runs]),
        "classes": classes,
        "iou": {c: Spread.of([r.iou[c] for r in runs]) for c in classes},
        "acc": {c: Spread.of([r.acc[c] for r in runs]) for c in classes},
        "confusion": np.sum([r.confusion for r in runs], axis=0),
    }
