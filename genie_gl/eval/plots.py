"""Pictures of evaluation results (matplotlib, Agg): the confusion matrix as a heat map,
per-class IoU bars with their spread, a transfer matrix, and the mixing curve (the paper's
Fig. 6: mIoU and mAcc against the synthetic share)."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ..outputs import PNG_SOFTWARE, check_replaceable, png_is_ours
from .metrics import Spread


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: str | os.PathLike) -> Path:
    """Save a figure as a PNG stamped as genie-gl's, atomically; a PNG genie-gl did not write
    is never replaced."""
    path = check_replaceable(path, png_is_ours, what="PNG picture")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.png")
    try:
        fig.savefig(tmp, dpi=110, bbox_inches="tight", metadata={"Software": PNG_SOFTWARE})
        tmp.replace(path)
    finally:
        _plt().close(fig)
        if tmp.exists():
            tmp.unlink()
    return path


def confusion_png(
    conf: np.ndarray, names: Mapping[int, str], path: str | os.PathLike, *, title: str = ""
) -> Path:
    """Row-normalised confusion matrix (true class in rows) over the classes that occur."""
    plt = _plt()
    conf = np.asarray(conf, np.float64)
    keep = np.flatnonzero((conf.sum(0) + conf.sum(1)) > 0)
    c = conf[np.ix_(keep, keep)]
    norm = c / np.maximum(c.sum(1, keepdims=True), 1)
    labels = [names.get(int(k), f"class_{k}") for k in keep]
    fig, ax = plt.subplots(figsize=(1.0 + 0.6 * len(keep), 0.8 + 0.55 * len(keep)))
    im = ax.imshow(norm, cmap="Blues", vmin=0, vmax=1)
    for i in range(len(keep)):
        for j in range(len(keep)):
            if norm[i, j] >= 0.005:
                ax.text(
                    j,
                    i,
                    f"{norm[i, j]:.2f}",
                    ha="center",
                    va="center",
                    fontsize=7,
                    color="white" if norm[i, j] > 0.6 else "black",
                )
    ax.set_xticks(range(len(keep)), labels, rotation=45, ha="right")
    ax.set_yticks(range(len(keep)), labels)
    ax.set_xlabel("predicted")
    ax.set_ylabel("true")
    ax.set_title(title, fontsize=9)
    fig.colorbar(im, ax=ax, fraction=0.046)
    return _save(fig, path)


def iou_bars_png(
    summaries: Mapping[str, dict],
    names: Mapping[int, str],
    path: str | os.PathLike,
    *,
    title: str = "",
    metric: str = "iou",
) -> Path:
    """Per-class bars (mean) with error bars (std over seeds), one bar group per class."""
    plt = _plt()
    classes = sorted({c for s in summaries.values() for c in s[metric]})
    width = 0.8 / max(1, len(summaries))
    fig, ax = plt.subplots(figsize=(1.2 + 0.9 * len(classes) + 0.3 * len(summaries), 3.6))
    for i, (label, s) in enumerate(summaries.items()):
        mean = [s[metric][c].mean if c in s[metric] else np.nan for c in classes]
        std = [s[metric][c].std if c in s[metric] else 0 for c in classes]
        x = np.arange(len(classes)) + (i - (len(summaries) - 1) / 2) * width
        ax.bar(
            x,
            mean,
            width,
            yerr=std,
            capsize=2,
            label=f"{label} (m{metric.upper()} {s['m' + metric].text()})",
        )
    ax.set_xticks(
        range(len(classes)), [names.get(c, f"class_{c}") for c in classes], rotation=30, ha="right"
    )
    ax.set_ylabel(metric.upper() if metric == "iou" else "Acc")
    ax.set_ylim(0, 1)
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, loc="upper right")
    ax.grid(axis="y", alpha=0.3)
    return _save(fig, path)


def matrix_png(
    cells: Sequence[Sequence[Spread]],
    rows: Sequence[str],
    cols: Sequence[str],
    path: str | os.PathLike,
    *,
    title: str = "",
    xlabel: str = "test",
    ylabel: str = "train",
) -> Path:
    """A transfer matrix: mIoU mean ± std in each cell."""
    plt = _plt()
    m = np.array([[c.mean for c in r] for r in cells], np.float64)
    fig, ax = plt.subplots(figsize=(1.6 + 1.5 * len(cols), 1.0 + 0.8 * len(rows)))
    im = ax.imshow(m, cmap="viridis", vmin=0, vmax=max(0.01, float(np.nanmax(m))))
    for i, r in enumerate(cells):
        for j, c in enumerate(r):
            ax.text(
                j,
                i,
                f"{c.mean:.3f}\n± {c.std:.3f}",
                ha="center",
                va="center",
                fontsize=8,
                color="white" if c.mean < 0.6 * np.nanmax(m) else "black",
            )
    ax.set_xticks(range(len(cols)), cols, rotation=20, ha="right")
    ax.set_yticks(range(len(rows)), rows)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=9)
    fig.colorbar(im, ax=ax, fraction=0.046)
    return _save(fig, path)


def curve_png(
    x: Sequence[float],
    series: Mapping[str, Sequence[Spread]],
    path: str | os.PathLike,
    *,
    title: str = "",
    xlabel: str = "synthetic share (%)",
    ylabel: str = "",
) -> Path:
    """Lines with a band of ± std (the paper's Fig. 6 style mixing curve)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(5.5, 3.4))
    for label, vals in series.items():
        mean = np.array([v.mean for v in vals])
        std = np.array([v.std for v in vals])
        ax.plot(x, mean, marker="o", ms=3, label=label)
        ax.fill_between(x, mean - std, mean + std, alpha=0.2)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return _save(fig, path)


def delta_bars_png(
    labels: Sequence[str],
    deltas: Sequence[tuple[float, float]],
    costs_ms: Sequence[float | None],
    path: str | os.PathLike,
    *,
    title: str = "",
) -> Path:
    """ΔmIoU with its spread per effect, beside the effect's ms per frame."""
    plt = _plt()
    fig, (a, b) = plt.subplots(1, 2, figsize=(8.5, 0.9 + 0.45 * len(labels)), sharey=True)
    y = np.arange(len(labels))
    a.barh(y, [d for d, _ in deltas], xerr=[s for _, s in deltas], capsize=3, color="tab:blue")
    a.axvline(0, color="k", lw=0.8)
    a.set_yticks(y, labels)
    a.set_xlabel("ΔmIoU (on − off), ± spread")
    b.barh(y, [c if c is not None else 0 for c in costs_ms], color="tab:orange")
    b.set_xlabel("ms per frame")
    fig.suptitle(title, fontsize=9)
    return _save(fig, path)
