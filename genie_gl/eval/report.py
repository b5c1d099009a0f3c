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


def per_class_rows(summaries: Mapping[str, dict], names: Mapping[int, str], metric: str = "iou") -> tuple[list, list]:
    """Header and rows: one row per model/condition, one column per class, then the mean."""
    classes = sorted({c for s in summaries.values() for c in s[metric]})
    header = ["", *(names.get(c, f"class_{c}") for c in classes), "mIoU" if metric == "iou" else "mAcc"]
    rows = []
    for label, s in summaries.items():
        cells = [s[metric][c].text(2) if c in s[metric] else "—" for c in classes]
        rows.append([label, *cells, s["miou" if metric == "iou" else "macc"].text(3)])
    return header, rows


def result_markdown(result: Any) -> str:
    """The report of one :func:`~.run.evaluate` run."""
    lines = [f"# {result.model}: trained on {', '.join(result.train)}\n",
             f"Seeds {', '.join(map(str, result.seeds))}; {result.n_train_points:,} training points; "
             f"figures are mean ± std over the seeds.\n"]
    for t in result.tests:
        s = t.summary
        lines.append(f"## {t.name} ({t.n_points:,} points)\n")
        lines.append(table(["mIoU", "mAcc", "OA"], [[s["miou"].text(), s["macc"].text(), s["oa"].text()]]))
        header, rows = per_class_rows({"IoU": s}, result.names, "iou")
        _, acc_rows = per_class_rows({"Acc": s}, result.names, "acc")
        lines.append("\n" + table(header[:-1], [r[:-1] for r in rows + acc_rows]))
        if t.unseen:
            lines.append("\nTest classes never seen in training: "
                         + ", ".join(result.names.get(c, str(c)) for c in t.unseen) + ".\n")
    return "\n".join(lines)


def versus(a: Spread, b: Spread) -> str:
    """``a`` against ``b`` as text: the difference, its spread and the verdict."""
    return delta_text(a, b)
