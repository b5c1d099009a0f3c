"""The classical model and the two baselines it must beat.

:class:`ClassicalModel` is LightGBM's histogram gradient boosting (one tree per class and round)
on the features of :mod:`.features`. Training takes a class-balanced sub-sample of the training
points (each class gives at most its share of ``max_points``; a rare class gives all it has),
weights each point by ``(n_c) ** -balance`` (0: as sampled, 1: every class equal; 0.5 between),
and stops early on held-out scans (``validation`` of the training scenes, chosen by the seed,
never the test set). LightGBM runs column-wise with ``deterministic=True``: each feature's
histogram is summed by one thread in row order, so 1 and 2 threads give the same trees, and the
same seed the same bytes.

:class:`HeightModel` is the same classifier on the height above the floor alone;
:class:`MajorityModel` predicts the most common training class everywhere.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np

import lightgbm as lgb
from tqdm import tqdm

from ..errors import ConfigError
from .features import HEIGHT_COLUMN, PointTable

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BoostParams:
    """LightGBM settings of the classical model (defaults measured in docs/eval.md)."""

    max_points: int = 150_000  # training points after the class-balanced sub-sample
    balance: float = 0.5  # point weight (n_c) ** -balance
    rounds: int = 200  # at most; early stopping usually ends sooner
    early_stop: int = 15  # rounds without a better validation loss
    learning_rate: float = 0.15
    num_leaves: int = 31
    min_data_in_leaf: int = 40
    feature_fraction: float = 0.8
    bagging_fraction: float = 0.8
    max_bin: int = 63
    validation: float = 0.15  # share of the training groups (scenes) held out for early stopping

    def lgb(self, n_classes: int, seed: int, threads: int) -> dict[str, Any]:
        return {
            "objective": "multiclass",
            "num_class": n_classes,
            "learning_rate": self.learning_rate,
            "num_leaves": self.num_leaves,
            "min_data_in_leaf": self.min_data_in_leaf,
            "feature_fraction": self.feature_fraction,
            "bagging_fraction": self.bagging_fraction,
            "bagging_freq": 1,
            "max_bin": self.max_bin,
            "seed": seed,
            "deterministic": True,
            "force_col_wise": True,
            "num_threads": max(1, threads),
            "verbose": -1,
        }


def balanced_sample(labels: np.ndarray, max_points: int, *, rng: np.random.Generator) -> np.ndarray:
    """Indices of a class-balanced sub-sample: each labelled class gives at most an equal share
    of ``max_points`` (what a rarer class leaves is shared by the others), sorted.

    Parameters
    ----------
    labels : (N,) int, -1 = unlabelled (never drawn)
    """
    labels = np.asarray(labels)
    classes, counts = np.unique(labels[labels >= 0], return_counts=True)
    if classes.size == 0:
        raise ConfigError("training set: no labelled point")
    # water-filling: the largest per-class cap q with sum(min(count, q)) <= max_points
    order = np.sort(counts)
    left, quota = max_points, 0
    for i, c in enumerate(order):
        share = left // (len(order) - i)
        if c <= share:
            left -= int(c)
            quota = int(c)
        else:
            quota = share
            break
    else:
        quota = int(order[-1])
    take = []
    for c, n in zip(classes, counts):
        idx = np.flatnonzero(labels == c)
        take.append(idx if n <= quota else rng.choice(idx, size=quota, replace=False))
    return np.sort(np.concatenate(take))


def split_groups(groups: np.ndarray, share: float, *, rng: np.random.Generator) -> np.ndarray:
    """Boolean mask of the points whose group (scene) is held out: ``share`` of the groups,
    at least one when there are two or more, chosen by ``rng``."""
    uniq = np.unique(groups)
    if uniq.size < 2 or share <= 0:
        return np.zeros(len(groups), bool)
    n = min(uniq.size - 1, max(1, int(round(share * uniq.size))))
    held = rng.choice(uniq, size=n, replace=False)
    return np.isin(groups, held)


@dataclass
class ClassicalModel:
    """Gradient-boosted trees on per-point features (see the module's docstring)."""

    n_classes: int
    params: BoostParams = field(default_factory=BoostParams)
    columns: tuple[int, ...] | None = None  # feature columns used (None: all)
    booster: Any = None
    rounds_used: int = 0
    trained_classes: tuple[int, ...] = ()

    name = "classical"

    def _x(self, x: np.ndarray) -> np.ndarray:
        return x if self.columns is None else x[:, list(self.columns)]

    def fit(
        self,
        data: PointTable,
        *,
        rng: np.random.Generator,
        threads: int = 1,
        init: "ClassicalModel | None" = None,
        progress: bool = False,
    ) -> "ClassicalModel":
        """Train on ``data`` (its features, classes and scene groups); ``init``: a trained model
        to go on boosting from (fine-tuning)."""
        x, y, groups = data.features, data.labels.astype(np.int64), data.groups
        seed = int(rng.integers(2**31 - 1))
        held = split_groups(groups, self.params.validation, rng=rng)
        tr = balanced_sample(np.where(held, -1, y), self.params.max_points, rng=rng)
        va = (
            balanced_sample(np.where(held, y, -1), max(1, self.params.max_points // 4), rng=rng)
            if held.any()
            else None
        )
        self.trained_classes = tuple(int(c) for c in np.unique(y[y >= 0]))

        def weights(lab: np.ndarray) -> np.ndarray:
            cls, cnt = np.unique(lab, return_counts=True)
            w = np.zeros(self.n_classes)
            w[cls] = cnt.astype(np.float64) ** -self.params.balance
            w = w[lab]
            return (w / w.mean()).astype(np.float32)

        xt = self._x(x[tr])
        dtrain = lgb.Dataset(
            xt,
            label=y[tr],
            weight=weights(y[tr]),
            free_raw_data=True,
            params={"max_bin": self.params.max_bin, "verbose": -1},
        )
        sets, callbacks = [dtrain], []
        if va is not None and len(va):
            sets.append(
                lgb.Dataset(self._x(x[va]), label=y[va], weight=weights(y[va]), reference=dtrain)
            )
            callbacks.append(lgb.early_stopping(self.params.early_stop, verbose=False))
        bar = None
        if progress:
            bar = tqdm(total=self.params.rounds, desc="boosting", unit="round", leave=False)

            def tick(env: Any) -> None:
                bar.update()

            callbacks.append(tick)
        try:
            self.booster = lgb.train(
                self.params.lgb(self.n_classes, seed, threads),
                dtrain,
                num_boost_round=self.params.rounds,
                valid_sets=sets[1:] or None,
                callbacks=callbacks,
                init_model=init.booster if init is not None else None,
            )
        finally:
            if bar is not None:
                bar.close()
        self.rounds_used = int(self.booster.best_iteration or self.booster.current_iteration())
        log.info("classical model: %d training points, %d rounds", len(tr), self.rounds_used)
        return self

    def predict(self, data: PointTable, *, threads: int = 1, batch: int = 200_000) -> np.ndarray:
        """(N,) int16 classes of ``data``'s points."""
        if self.booster is None:
            raise ConfigError("the model is not trained")
        x = data.features
        out = np.empty(len(x), np.int16)
        it = self.booster.best_iteration or None
        for i in range(0, len(x), batch):
            p = self.booster.predict(
                self._x(x[i : i + batch]), num_iteration=it, num_threads=max(1, threads)
            )
            out[i : i + batch] = p.argmax(1)
        return out


@dataclass
class HeightModel(ClassicalModel):
    """The classical classifier on one feature: the height above the floor."""

    name = "height"

    def __post_init__(self) -> None:
        self.columns = (HEIGHT_COLUMN,)


@dataclass
class MajorityModel:
    """Predicts the most common training class everywhere."""

    n_classes: int
    majority: int = 0
    trained_classes: tuple[int, ...] = ()
    rounds_used: int = 0

    name = "majority"

    def fit(
        self,
        data: PointTable,
        *,
        rng: np.random.Generator,
        threads: int = 1,
        init: Any = None,
        progress: bool = False,
    ) -> "MajorityModel":
        y = data.labels
        counts = np.bincount(y[y >= 0].astype(np.int64), minlength=self.n_classes)
        self.majority = int(counts.argmax())
        self.trained_classes = tuple(int(c) for c in np.flatnonzero(counts))
        return self

    def predict(self, data: PointTable, *, threads: int = 1, batch: int = 0) -> np.ndarray:
        return np.full(len(data), self.majority, np.int16)
