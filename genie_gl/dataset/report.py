"""The dataset's report: points per class as text, JSON and a bar chart (the paper's Table 3),
and what the run cost per stage and per effect."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from .. import labels


def class_totals(stats: list[dict]) -> dict[int, int]:
    total: dict[int, int] = {}
    for s in stats:
        for k, v in s["class_points"].items():
            total[int(k)] = total.get(int(k), 0) + int(v)
    return total


def histogram(
    out: Path,
    stats: list[dict],
    target: dict[int, float] | None = None,
    short: dict[str, str] | None = None,
    reference: dict[int, int] | None = None,
) -> dict[str, int]:
    """Write ``histogram.{txt,json,png}`` under ``out``; returns {class name: points}. With a
    ``target`` distribution (``--class-balance``) the text shows it next to the share reached,
    and names the classes ``short`` of it, with why; with ``reference`` points per class (a
    mobile-scan map: Table 3's real column) their shares too."""
    total = class_totals(stats)
    n = sum(total.values()) or 1
    ref_n = sum((reference or {}).values()) or 1
    lines = [
        f"{'id':>3}  {'class':<20}{'points':>14}{'share':>9}"
        + (f"{'target':>9}" if target else "")
        + (f"{'real':>9}" if reference else "")
    ]
    for k in sorted(set(total) | set(target or {})):
        lines.append(
            f"{k:>3}  {labels.name(k):<20}{total.get(k, 0):>14,}{100 * total.get(k, 0) / n:>8.2f}%"
            + (f"{100 * target.get(k, 0.0):>8.2f}%" if target else "")
            + (f"{100 * reference.get(k, 0) / ref_n:>8.2f}%" if reference else "")
        )
    if reference:
        lines.append(
            "real: the share of the class in the paper's real data (Table 3, a mobile scanner's "
            "chunks of 25 000 points)"
        )
    for k, why in sorted((short or {}).items(), key=lambda kv: int(kv[0])):
        lines.append(f"short of its target: {labels.name(int(k))}: {why}")
    (out / "histogram.txt").write_text("\n".join(lines) + "\n")
    (out / "histogram.json").write_text(
        json.dumps({labels.name(k): v for k, v in sorted(total.items())}, indent=1)
    )
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.5))
    keys = sorted(total)
    ax.bar(
        [labels.name(k) for k in keys],
        [total[k] for k in keys],
        color=[np.array(labels.color(k)) / 255 for k in keys],
    )
    ax.set_yscale("log")
    ax.set_ylabel("points")
    ax.set_title(
        f"points per class ({len(stats)} scene{'s' * (len(stats) != 1)}, {sum(total.values()):,} "
        "points)"
    )
    plt.setp(ax.get_xticklabels(), rotation=30, ha="right")
    fig.tight_layout()
    fig.savefig(out / "histogram.png", dpi=100, metadata={"Software": None})
    plt.close(fig)
    return {labels.name(k): v for k, v in total.items()}


def dataset_cost(stats: list[dict[str, Any]]) -> dict[str, Any]:
    """The manifest's ``cost`` block from the scenes' stats (``timings_s``, ``frame_cost_ms``,
    ``cameras``): per stage and per effect, the total and the per-frame milliseconds."""
    frames = sum(int(s.get("cameras", 0)) for s in stats)
    stages: dict[str, float] = {}
    parts: dict[str, float] = {}
    for s in stats:
        for k, v in (s.get("timings_s") or {}).items():
            stages[k] = stages.get(k, 0.0) + 1e3 * float(v)
        for k, v in (s.get("frame_cost_ms") or {}).items():
            parts[k] = parts.get(k, 0.0) + float(v)
    per = max(frames, 1)
    return {
        "frames": frames,
        "stages": {k: {"total_ms": v, "per_frame_ms": v / per} for k, v in stages.items()},
        "capture": {k: {"total_ms": v, "per_frame_ms": v / per} for k, v in sorted(parts.items())},
    }
