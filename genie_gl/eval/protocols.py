"""The paper's protocols (§4.4) as presets, against a target set the user names: their own
real scans in SemanticKITTI layout, or a stand-in (scenes of a strategy and sensor profile held
out of the synthetic data).

- ``mix`` (Experiment 1): the target's training scans plus synthetic scans so that the synthetic
  share of the training points is 0, 10, ..., 90 %; every ratio trained once per seed (the paper:
  twice; three seeds give a spread). The real part is fixed and synthetic scans are added, so
  the training set grows with the ratio; the classical model's rounds are set by early stopping
  on held-out scenes of the mix, RandLA-Net's epochs by its fixed number of steps, so the
  training effort scales with the data.
- ``finetune`` (Experiment 2): train on all the synthetic data, then go on training on the
  target's training scans (more boosting rounds, or more steps from the synthetic weights),
  against training on the target alone.
- ``scarce`` (§4.4.3): ``mix`` with three classes, pallet, rack and small load carrier; every
  other point is "other" (class 0), and the means are over the three.

Synthetic scans are added whole, in an order drawn from the seed, until the share is reached.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from .data import EvalSet, read_set
from .metrics import Spread
from .features import PointTable
from .run import EvalResult, evaluate, make_model

log = logging.getLogger(__name__)

PRESETS = ("mix", "finetune", "scarce")
RATIOS = tuple(r / 10 for r in range(10))
SCARCE_CLASSES = (1, 2, 9)  # pallet, rack, small load carrier


def scarce_map(n_classes: int = 10) -> dict[int, int]:
    """Every class but the scarce three to 0 ("other")."""
    return {c: (c if c in SCARCE_CLASSES else 0) for c in range(n_classes)}


def synthetic_share(
    real: EvalSet, synthetic: Sequence[EvalSet], ratio: float, *, rng: np.random.Generator
) -> list:
    """Synthetic scans, whole, in a random order, until they are ``ratio`` of real + synthetic
    points (the last scan taken when it brings the share nearer)."""
    if ratio <= 0:
        return []
    want = real.n_points * ratio / (1.0 - ratio)
    pool = [s for ss in synthetic for s in ss.scans]
    chosen, n = [], 0
    for i in rng.permutation(len(pool)):
        if n >= want:
            break
        size = len(pool[i])
        if abs(n + size - want) > abs(n - want) and n > 0:
            break
        chosen.append(pool[i])
        n += size
    if n < want * 0.95:
        log.warning(
            "mix %.0f %%: only %d synthetic points for %d wanted (the share reached is %.1f %%)",
            100 * ratio,
            n,
            int(want),
            100 * n / (n + real.n_points),
        )
    return chosen


def mix(
    target_train: str | EvalSet,
    target_test: str | EvalSet,
    synthetic: Sequence[str | EvalSet],
    *,
    out: str | os.PathLike,
    model: str = "classical",
    seeds: Sequence[int] = (0, 1, 2),
    ratios: Sequence[float] = RATIOS,
    scarce: bool = False,
    workers: int = 1,
    label_map: str | os.PathLike | None = None,
    cache: str | os.PathLike | None = None,
    progress: bool = False,
    params: Any = None,
) -> dict:
    """Experiment 1 (``scarce``: §4.4.3) on a target; returns {ratio: EvalResult} and writes
    ``out/ratio_XX/`` and the curve."""
    real = (
        target_train
        if isinstance(target_train, EvalSet)
        else read_set(target_train, label_map=label_map)
    )
    test = (
        target_test
        if isinstance(target_test, EvalSet)
        else read_set(target_test, label_map=label_map)
    )
    syn = [s if isinstance(s, EvalSet) else read_set(s) for s in synthetic]
    class_map = (
        scarce_map(max(10, max(s.max_class() for s in [real, test, *syn]) + 1)) if scarce else None
    )
    eval_classes = SCARCE_CLASSES if scarce else None
    results: dict[float, list[EvalResult]] = {}
    for ratio in ratios:
        per_seed = []
        for seed in seeds:
            chosen = synthetic_share(
                real, syn, ratio, rng=np.random.default_rng([seed, int(round(ratio * 100))])
            )
            train = [real] + (
                [replace(syn[0], scans=tuple(chosen), spec=f"synthetic {ratio:.0%}")]
                if chosen
                else []
            )
            per_seed.append(
                evaluate(
                    train,
                    [test],
                    model=model,
                    seeds=[seed],
                    workers=workers,
                    cache=cache,
                    progress=progress,
                    class_map=class_map,
                    eval_classes=eval_classes,
                    params=params,
                    out=Path(out) / f"ratio_{int(round(ratio * 100)):02d}" / f"seed{seed}",
                    pictures=False,
                )
            )
        results[ratio] = per_seed
    return {"ratios": list(ratios), "results": results, "summary": curve(results)}


def curve(results: dict[float, list[EvalResult]]) -> dict[str, list[Spread]]:
    """mIoU and mAcc spreads per ratio (one EvalResult per seed)."""
    return {
        "mIoU": [Spread.of([r.tests[0].runs[0].miou for r in rs]) for rs in results.values()],
        "mAcc": [Spread.of([r.tests[0].runs[0].macc for r in rs]) for rs in results.values()],
    }


def finetune(
    target_train: str | EvalSet,
    target_test: str | EvalSet,
    synthetic: Sequence[str | EvalSet],
    *,
    out: str | os.PathLike,
    model: str = "classical",
    seeds: Sequence[int] = (0, 1, 2),
    workers: int = 1,
    label_map: str | os.PathLike | None = None,
    cache: str | os.PathLike | None = None,
    progress: bool = False,
    params: Any = None,
    scarce: bool = False,
) -> dict[str, EvalResult]:
    """Experiment 2: {"target only", "synthetic only", "synthetic then target"} results."""
    real = (
        target_train
        if isinstance(target_train, EvalSet)
        else read_set(target_train, label_map=label_map)
    )
    test = (
        target_test
        if isinstance(target_test, EvalSet)
        else read_set(target_test, label_map=label_map)
    )
    syn = [s if isinstance(s, EvalSet) else read_set(s) for s in synthetic]
    n_classes = max(10, max(s.max_class() for s in [real, test, *syn]) + 1)
    class_map = scarce_map(n_classes) if scarce else None
    eval_classes = SCARCE_CLASSES if scarce else None
    kw = dict(
        model=model,
        seeds=seeds,
        workers=workers,
        cache=cache,
        progress=progress,
        class_map=class_map,
        eval_classes=eval_classes,
        params=params,
        pictures=False,
    )
    out = Path(out)
    real_only = evaluate([real], [test], out=out / "target_only", **kw)
    syn_only = evaluate(syn, [test], out=out / "synthetic_only", **kw)
    lut = None
    if class_map is not None:
        lut = np.arange(n_classes, dtype=np.int16)
        for a, b in class_map.items():
            lut[a] = b
    syn_pts = PointTable(
        [s for ss in syn for s in ss.scans], class_map=lut, workers=workers, cache=cache
    )
    pretrained: dict[int, Any] = {}

    def init(seed: int) -> Any:
        if seed not in pretrained:
            m = make_model(model, int(lut.max()) + 1 if lut is not None else n_classes, params)
            pretrained[seed] = m.fit(syn_pts, rng=np.random.default_rng(seed), threads=workers)
        return pretrained[seed]

    tuned = evaluate([real], [test], out=out / "synthetic_then_target", init=init, **kw)
    return {"target only": real_only, "synthetic only": syn_only, "synthetic then target": tuned}
