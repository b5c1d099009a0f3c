"""Evaluation: train segmentation models on exported datasets (ours, or a user's own in
SemanticKITTI layout) and test them with the paper's metrics.

``evaluate(train, test, model=..., seeds=...)`` is the entry point (:mod:`.run`); reading
(:mod:`.data`, :mod:`.labelmap`), features (:mod:`.features`), models (:mod:`.classical`,
:mod:`.randla`), metrics (:mod:`.metrics`; panoptic quality: :mod:`.panoptic`, with
the instance
model of :mod:`.instances`), predictions as ``.label`` files
(:mod:`.predictions`), the paper's protocols (:mod:`.protocols`), tables and pictures
(:mod:`.report`, :mod:`.plots`). This package imports nothing above ``export``.
"""

from __future__ import annotations

from .data import EvalSet, Scan, read_set
from .metrics import Scores, Spread, compare, confusion, scores
from .run import MODELS, EvalResult, evaluate

__all__ = [
    "EvalResult",
    "EvalSet",
    "MODELS",
    "Scan",
    "Scores",
    "Spread",
    "compare",
    "confusion",
    "evaluate",
    "read_set",
    "scores",
]
