"""Markdown tables of evaluation results: every figure as mean ± std over the seeds, a
difference beside its spread and its verdict (:func:`.metrics.compare`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from .metrics import Spread, delta_text


def table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    """A markdown table."""
    out = ["| " + " | ".join(str(h) for h in header) + " |", "|" + " --- |" * len(header)]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(out) + "\n"


def per_class_rows(
    summaries: Mapping[str, dict], names: Mapping[int, str], metric: str = "iou"
) -> tuple[list, list]:
    """Header and rows: one row per model/condition, one column per class, then the mean."""
    classes = sorted({c for s in summaries.values() for c in s[metric]})
    header = [
        "",
        *(names.get(c, f"class_{c}") for c in classes),
        "mIoU" if metric == "iou" else "mAcc",
    ]
    rows = []
    for label, s in summaries.items():
        cells = [s[metric][c].text(2) if c in s[metric] else "—" for c in classes]
        rows.append([label, *cells, s["miou" if metric == "iou" else "macc"].text(3)])
    return header, rows


def result_markdown(result: Any) -> str:
    """The report of one :func:`~.run.evaluate` run."""
    lines = [
        f"# {result.model}: trained on {', '.join(result.train)}\n",
        f"Seeds {', '.join(map(str, result.seeds))}; {result.n_train_points:,} training points; "
        f"figures are mean ± std over the seeds.\n",
    ]
    for t in result.tests:
        s = t.summary
        lines.append(f"## {t.name} ({t.n_points:,} points)\n")
        lines.append(
            table(["mIoU", "mAcc", "OA"], [[s["miou"].text(), s["macc"].text(), s["oa"].text()]])
        )
        header, rows = per_class_rows({"IoU": s}, result.names, "iou")
        _, acc_rows = per_class_rows({"Acc": s}, result.names, "acc")
        lines.append("\n" + table(header[:-1], [r[:-1] for r in rows + acc_rows]))
        left = left_out(t, result.names, result.seeds)
        if left:
            lines.append("\n" + left)
        if t.unseen:
            lines.append(
                "\nTest classes never seen in training: "
                + ", ".join(result.names.get(c, str(c)) for c in t.unseen)
                + ".\n"
            )
        if t.panoptic:
            lines.append("\n" + panoptic_markdown(t.panoptic, result.names))
    return "\n".join(lines)


def left_out(test: Any, names: Mapping[int, str], seeds: Sequence[int]) -> str:
    """The sentence naming the classes left out of a test's means (no true point in the test
    set) and how many points each run predicted as each of them ('' when none)."""
    evaluated = set(test.summary["classes"])
    n_classes = test.runs[0].confusion.shape[0]
    out = [
        c
        for c in range(n_classes)
        if c not in evaluated and (c in names or any(r.confusion[:, c].sum() for r in test.runs))
    ]
    if not out:
        return ""
    parts = []
    for c in out:
        counts = [int(r.confusion[:, c].sum()) for r in test.runs]
        per = ", ".join(f"{n:,}" for n in counts)
        parts.append(
            f"{names.get(c, f'class_{c}')} ({per} point{'s' if counts != [1] else ''} predicted as "
            "it" + (f", seeds {', '.join(map(str, seeds))})" if len(counts) > 1 else ")")
        )
    return (
        "Left out of the means (no point of the class in this test set; a point predicted as one "
        "of them "
        "counts against its true class): " + "; ".join(parts) + ".\n"
    )


PANOPTIC_ROWS = {
    "model": "classes predicted by the model, each thing class clustered (DBSCAN)",
    "one per class": "predicted classes, one instance per thing class (floor)",
    "true classes": "true classes, clustered (what the clustering alone loses)",
}


def panoptic_markdown(pan: Mapping[str, dict], names: Mapping[int, str]) -> str:
    """The panoptic tables of one test: the instance model and its baselines (PQ, SQ, RQ, PQ†,
    over things and stuff), then PQ, SQ and RQ per class of the model."""
    rows = [
        [
            PANOPTIC_ROWS.get(k, k),
            *(
                s[m].text()
                for m in ("PQ", "SQ", "RQ", "PQ_dagger", "PQ_th", "SQ_th", "RQ_th", "PQ_st")
            ),
        ]
        for k, s in pan.items()
    ]
    first = next(iter(pan.values()))
    stuff = [c for c in sorted(first["pq"]) if c not in first["things"]]
    md = (
        "### Panoptic quality (semantic-kitti-api's PanopticEval; things: "
        + ", ".join(names.get(c, f"class_{c}") for c in first["things"])
        + "; stuff: "
        + (", ".join(names.get(c, f"class_{c}") for c in stuff) or "none")
        + ")\n\n"
    )
    md += table(
        [
            "instances from",
            "PQ",
            "SQ",
            "RQ",
            "PQ†",
            "PQ things",
            "SQ things",
            "RQ things",
            "PQ stuff",
        ],
        rows,
    )
    model = pan.get("model")
    if model is not None:
        classes = sorted(model["pq"])
        md += "\n" + table(
            ["", *(names.get(c, f"class_{c}") for c in classes)],
            [[k.upper(), *(model[k][c].text(2) for c in classes)] for k in ("pq", "sq", "rq")],
        )
    return md


def versus(a: Spread, b: Spread) -> str:
    """``a`` against ``b`` as text: the difference, its spread and the verdict."""
    return delta_text(a, b)
