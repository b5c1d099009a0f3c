"""Panoptic quality (Kirillov et al. 2019) as semantic-kitti-api computes it
(``auxiliary/eval_np.py``: ``PanopticEval``; ``evaluate_panoptic.py``), from per-point
classes and instance ids.

A *segment* is the set of a scan's points of one class and one instance id (the prediction's
segments from its classes and ids, the ground truth's from its own). Per scan and per evaluated
class, a predicted and a true segment match when their IoU exceeds 0.5 (at most one match each,
as the 0.5 threshold guarantees); each match is a true positive adding its IoU, an unmatched
true segment of at least ``min_points`` points a false negative, an unmatched predicted one of at
least ``min_points`` a false positive. Summed over the scans, per class:
``SQ = sum IoU / TP``, ``RQ = TP / (TP + FP/2 + FN/2)``, ``PQ = SQ * RQ`` (0 where there is no
TP). The means are over the evaluated classes (those present in the test's ground truth, as the
mIoU's are: the API's ``ignore`` list holds the others); ``PQ†`` takes each stuff class's
semantic IoU in place of its PQ; PQ, SQ and RQ are also given over things and over stuff.

Things and stuff: every labelled object class is a thing (pallet, rack, car, jack, stillage,
storage cabinet, dolly, forklift, small load carrier, and a strategy's own classes above 9). A
rack is a countable object with an instance id of its own, and a robot tells one rack from the
next, so it is a thing, although racks standing side by side in a row touch and are hard to
separate. Background (floor, walls, columns, line fixtures) is stuff: an amorphous region, as
SemanticKITTI's road and building are. Stuff carries no instance: its segments are the class as
a whole in each scan, so its instance ids are taken as 0 in the prediction and in the truth
(SemanticKITTI's own labels carry instance 0 on stuff; genie-gl's exports give the floor and
each wall an id of their own, which this evaluation does not score).

Points whose ground truth is unlabelled (class -1) are left out, as the API leaves out its
ignored classes' points.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from .data import _PLY_TYPES, EvalSet
from .metrics import Spread

STUFF: tuple[int, ...] = (0,)  # background
MIN_POINTS = 50  # evaluate_panoptic.py's --min_inst_points default
_OFFSET = np.int64(2) ** 32


def stuff_free(sem: np.ndarray, inst: np.ndarray, stuff: Iterable[int] = STUFF) -> np.ndarray:
    """``inst`` with the instance id of every stuff point set to 0: (N,) int64."""
    inst = np.asarray(inst).astype(np.int64).copy()
    inst[np.isin(np.asarray(sem), np.asarray(list(stuff), dtype=np.int64))] = 0
    return inst


@dataclass
class PanopticCounts:
    """Per-class sums over scans: true positives, the sum of their IoUs, false positives and
    false negatives, each (C,)."""

    n_classes: int
    min_points: int = MIN_POINTS
    tp: np.ndarray = field(init=False)
    iou: np.ndarray = field(init=False)
    fp: np.ndarray = field(init=False)
    fn: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.tp = np.zeros(self.n_classes, np.int64)
        self.iou = np.zeros(self.n_classes, np.float64)
        self.fp = np.zeros(self.n_classes, np.int64)
        self.fn = np.zeros(self.n_classes, np.int64)

    def add(
        self,
        truth_sem: np.ndarray,
        truth_inst: np.ndarray,
        pred_sem: np.ndarray,
        pred_inst: np.ndarray,
        classes: Sequence[int],
    ) -> None:
        """Add one scan.

        Parameters
        ----------
        truth_sem, pred_sem : (N,) int
            Classes; ``truth_sem`` < 0 marks unlabelled points (left out).
        truth_inst, pred_inst : (N,) int
            Instance ids (any non-negative integers below 2**32; 0 is an id like the others:
            a thing's points with id 0 form one segment).
        classes : the evaluated classes
        """
        ts, ti = np.asarray(truth_sem).astype(np.int64), np.asarray(truth_inst).astype(np.int64)
        ps, pi = np.asarray(pred_sem).astype(np.int64), np.asarray(pred_inst).astype(np.int64)
        if not (ts.shape == ti.shape == ps.shape == pi.shape) or ts.ndim != 1:
            raise ConfigError(
                f"panoptic: per-point arrays of one length expected, got {ts.shape}, {ti.shape}, "
                f"{ps.shape}, {pi.shape}"
            )
        classes = np.asarray(list(classes), np.int64)
        # the API drops the points whose truth is an ignored class (here: unlabelled, or a class not
        # evaluated)
        keep = np.isin(ts, classes)
        ts, ti, ps, pi = ts[keep], ti[keep] + 1, ps[keep], pi[keep] + 1
        for c in classes:
            in_p, in_t = ps == c, ts == c
            p_ids, p_n = np.unique(pi[in_p], return_counts=True)
            t_ids, t_n = np.unique(ti[in_t], return_counts=True)
            both = in_p & in_t
            combo, inter = np.unique(pi[both] + _OFFSET * ti[both], return_counts=True)
            t_of, p_of = combo // _OFFSET, combo % _OFFSET
            t_area = t_n[np.searchsorted(t_ids, t_of)]
            p_area = p_n[np.searchsorted(p_ids, p_of)]
            ious = inter.astype(np.float64) / (t_area + p_area - inter).astype(np.float64)
            hit = ious > 0.5
            self.tp[c] += int(hit.sum())
            self.iou[c] += float(ious[hit].sum())
            t_matched = np.isin(t_ids, t_of[hit])
            p_matched = np.isin(p_ids, p_of[hit])
            self.fn[c] += int(((t_n >= self.min_points) & ~t_matched).sum())
            self.fp[c] += int(((p_n >= self.min_points) & ~p_matched).sum())


@dataclass(frozen=True)
class PanopticScores:
    """Panoptic figures of one run.

    Attributes
    ----------
    classes : (K,) int, the evaluated classes; things : those of them that are things
    pq, sq, rq : (C,) float64 per class (NaN for a class not evaluated)
    PQ, SQ, RQ : means over the evaluated classes
    PQ_dagger : the mean of the things' PQ and the stuff classes' semantic IoU
    PQ_th, SQ_th, RQ_th, PQ_st, SQ_st, RQ_st : means over things and over stuff (NaN when none)
    """

    classes: np.ndarray
    things: np.ndarray
    pq: np.ndarray
    sq: np.ndarray
    rq: np.ndarray
    PQ: float
    SQ: float
    RQ: float
    PQ_dagger: float
    PQ_th: float
    SQ_th: float
    RQ_th: float
    PQ_st: float
    SQ_st: float
    RQ_st: float

    OVERALL = ("PQ", "SQ", "RQ", "PQ_dagger", "PQ_th", "SQ_th", "RQ_th", "PQ_st", "SQ_st", "RQ_st")

    def as_dict(self, names: dict[int, str] | None = None) -> dict:
        def name(c: int) -> str:
            return names.get(c, f"class_{c}") if names else f"class_{c}"

        def num(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        out: dict = {k: num(getattr(self, k)) for k in self.OVERALL}
        out["things"] = [name(int(c)) for c in self.things]
        for k in ("pq", "sq", "rq"):
            out[k] = {name(int(c)): float(getattr(self, k)[c]) for c in self.classes}
        return out


def _mean(x: np.ndarray) -> float:
    return float(x.mean()) if x.size else math.nan


def panoptic_scores(
    counts: PanopticCounts,
    classes: Sequence[int],
    semantic_iou: np.ndarray,
    stuff: Iterable[int] = STUFF,
) -> PanopticScores:
    """The figures of :class:`PanopticScores` from summed counts; ``semantic_iou`` (C,) is the
    run's per-class IoU (:func:`.metrics.scores`), for PQ†."""
    eps = 1e-15  # as the API: 0/0 -> 0
    classes = np.asarray(sorted(int(c) for c in classes), np.int64)
    if classes.size == 0:
        raise ConfigError("panoptic: no evaluated class")
    tp = counts.tp.astype(np.float64)
    sq_all = counts.iou / np.maximum(tp, eps)
    rq_all = tp / np.maximum(tp + 0.5 * counts.fp + 0.5 * counts.fn, eps)
    pq_all = sq_all * rq_all
    pq, sq, rq = (np.full(counts.n_classes, np.nan) for _ in range(3))
    pq[classes], sq[classes], rq[classes] = pq_all[classes], sq_all[classes], rq_all[classes]
    is_stuff = np.isin(classes, np.asarray(list(stuff), np.int64))
    th, st = classes[~is_stuff], classes[is_stuff]
    dagger = np.concatenate([pq_all[th], np.asarray(semantic_iou, np.float64)[st]])
    return PanopticScores(
        classes=classes,
        things=th,
        pq=pq,
        sq=sq,
        rq=rq,
        PQ=_mean(pq_all[classes]),
        SQ=_mean(sq_all[classes]),
        RQ=_mean(rq_all[classes]),
        PQ_dagger=_mean(dagger),
        PQ_th=_mean(pq_all[th]),
        SQ_th=_mean(sq_all[th]),
        RQ_th=_mean(rq_all[th]),
        PQ_st=_mean(pq_all[st]),
        SQ_st=_mean(sq_all[st]),
        RQ_st=_mean(rq_all[st]),
    )


def summarise(runs: Sequence[PanopticScores]) -> dict:
    """Per-seed panoptic scores into spreads: ``{"PQ": Spread, ..., "pq": {c: Spread}, ...}``."""
    if not runs:
        raise ConfigError("no panoptic run to summarise")
    classes = sorted({int(c) for r in runs for c in r.classes})
    out: dict = {k: Spread.of([getattr(r, k) for r in runs]) for k in PanopticScores.OVERALL}
    for k in ("pq", "sq", "rq"):
        out[k] = {c: Spread.of([getattr(r, k)[c] for r in runs]) for c in classes}
    out["things"] = sorted({int(c) for r in runs for c in r.things})
    return out


def spread_dict(summary: dict, names: dict[int, str]) -> dict:
    """A panoptic summary as JSON-ready dictionaries."""
    out: dict = {k: summary[k].as_dict() for k in PanopticScores.OVERALL}
    out["things"] = [names.get(c, f"class_{c}") for c in summary["things"]]
    for k in ("pq", "sq", "rq"):
        out[k] = {names.get(c, f"class_{c}"): s.as_dict() for c, s in summary[k].items()}
    return out


def _ply_property(path: Path, name: str) -> np.ndarray | None:
    """One vertex property of a binary little-endian PLY (None when it has none)."""
    raw = path.read_bytes()
    end = raw.find(b"end_header\n")
    fields, n, in_vertex = [], 0, False
    for line in raw[:end].decode("ascii", "replace").splitlines():
        parts = line.split()
        if parts[:1] == ["element"]:
            in_vertex = parts[1] == "vertex"
            n = int(parts[2]) if in_vertex else n
        elif parts[:1] == ["property"] and in_vertex and parts[1] in _PLY_TYPES:
            fields.append((parts[2], _PLY_TYPES[parts[1]]))
    if name not in (f for f, _ in fields):
        return None
    return np.frombuffer(raw, dtype=np.dtype(fields), count=n, offset=end + len(b"end_header\n"))[
        name
    ]


def truth_instances(test: EvalSet) -> list[np.ndarray]:
    """The ground truth's instance ids of each scan of ``test`` ((N,) int64 each, in scan order),
    as the field's readers see them: a SemanticKITTI label's upper 16 bits, a PLY's or NPZ's
    ``instance`` (0 everywhere for a cloud without one)."""
    out = []
    for s in test.scans:
        p = Path(s.path)
        if test.format == "semantickitti":
            inst = np.fromfile(p.parent.parent / "labels" / f"{p.stem}.label", dtype="<u4") >> 16
        elif test.format == "npz":
            with np.load(p) as z:
                inst = z["instance"] if "instance" in z.files else None
        else:
            inst = _ply_property(p, "instance")
        inst = np.zeros(len(s), np.int64) if inst is None else np.asarray(inst).astype(np.int64)
        if len(inst) != len(s):
            raise ConfigError(f"{s.path}: {len(inst)} instance ids for {len(s)} points")
        out.append(inst)
    return out


def evaluate_scans(
    truth: Sequence[np.ndarray],
    truth_inst: Sequence[np.ndarray],
    pred: Sequence[np.ndarray],
    pred_inst: Sequence[np.ndarray],
    classes: Sequence[int],
    semantic_iou: np.ndarray,
    n_classes: int,
    *,
    stuff: Iterable[int] = STUFF,
    min_points: int = MIN_POINTS,
) -> PanopticScores:
    """Panoptic scores of a test set, scan by scan (each list holds one (N_i,) array per scan);
    stuff instance ids are taken as 0 on both sides (see the module's docstring)."""
    counts = PanopticCounts(n_classes, min_points)
    stuff = tuple(stuff)
    for ts, ti, ps, pi in zip(truth, truth_inst, pred, pred_inst, strict=True):
        counts.add(ts, stuff_free(ts, ti, stuff), ps, stuff_free(ps, pi, stuff), classes)
    return panoptic_scores(counts, classes, semantic_iou, stuff)
