"""``accuracy.png``: error against milliseconds per frame, one series per knob, the Pareto front.

Three panels on log axes: the p99 depth error (mm), the mean silhouette displacement (px)
and the surface sampling gap (mm, the pay-off of resolution), each against the median time per frame
(ms). Each knob is a line through its levels, every
level labelled; the default setting is ringed; the Pareto front (no other row both faster and
more exact, among rows measured against the same reference) is the dashed staircase. An error of
exactly zero (the row equals its reference)
cannot sit on a log axis: it is drawn at the panel's floor as an open triangle, and the floor
is named in the panel. A third panel shows placement coverage against seconds when the scene
has a layout.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

PANELS = (
    ("depth_p99_mm", "p99 |depth error| (mm)"),
    ("edge_px", "silhouette error (px, mean displacement)"),
    ("sampling_mm", "surface sampling gap (mm, median)"),
)


def pareto(rows: list[dict]) -> dict[str, dict[str, list[int]]]:
    """Per metric and per reference (errors against different references do not compare),
    indices of the available rows on the Pareto front of time against error, fastest first."""
    out: dict[str, dict[str, list[int]]] = {}
    refs = list(dict.fromkeys(r["reference"] for r in rows if r.get("available")))
    for metric, _ in PANELS:
        out[metric] = {}
        for ref in refs:
            pts = sorted(
                (r["time_ms"]["total"]["median"], r["errors"][metric], i)
                for i, r in enumerate(rows)
                if r.get("available") and r["reference"] == ref
            )
            front, best = [], np.inf
            for t, e, i in pts:
                if e < best:
                    front.append(i)
                    best = e
            out[metric][ref] = front
    return out


def plot(result: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = result["rows"]
    placement = result.get("placement") or []
    n = len(PANELS) + (1 if placement else 0)
    fig, axes = plt.subplots(1, n, figsize=(5.6 * n, 5.5))
    colours = plt.get_cmap("tab10")
    knobs = list(dict.fromkeys(r["knob"] for r in rows if r.get("available")))
    c = result["case"]
    for ax, (metric, ylabel) in zip(axes, PANELS):
        vals = [r["errors"][metric] for r in rows if r.get("available")]
        pos = [v for v in vals if v > 0]
        floor = (min(pos) / 3) if pos else 1e-3

        def y(v):  # noqa: E306
            return v if v > 0 else floor

        for k, name in enumerate(knobs):
            rs = [r for r in rows if r.get("knob") == name and r.get("available")]
            xs = [r["time_ms"]["total"]["median"] for r in rs]
            ys = [y(r["errors"][metric]) for r in rs]
            col = colours(k % 10)
            ax.plot(xs, ys, "-", color=col, alpha=0.7, label=rs[0]["title"])
            for r, xv, yv in zip(rs, xs, ys):
                zero = r["errors"][metric] <= 0
                ax.plot(xv, yv, "v" if zero else "o", color=col, mfc="none" if zero else col, ms=6)
                ax.errorbar(
                    xv, yv, xerr=r["time_ms"]["total"]["iqr"] / 2, color=col, alpha=0.4, capsize=2
                )
                ax.annotate(
                    r["level"],
                    (xv, yv),
                    textcoords="offset points",
                    xytext=(4, 4),
                    fontsize=7,
                    color=col,
                )
        defaults = [r for r in rows if r.get("available") and r.get("is_default")]
        if defaults:
            r = defaults[0]
            ax.plot(
                r["time_ms"]["total"]["median"],
                y(r["errors"][metric]),
                "o",
                ms=16,
                mfc="none",
                mec="k",
                mew=2,
                label="default setting",
            )
        fronts = result.get("pareto", {}).get(metric, {})
        for j, (ref, idx) in enumerate(fronts.items()):
            front = [rows[i] for i in idx]
            fx = [r["time_ms"]["total"]["median"] for r in front]
            fy = [y(r["errors"][metric]) for r in front]
            ax.step(
                fx,
                fy,
                ("--", ":")[j % 2],
                where="post",
                color="k",
                lw=1.4,
                label=f"Pareto front{f' (vs {ref})' if len(fronts) > 1 else ''}",
            )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("time per frame (ms, median over repeats; bars: IQR)")
        ax.set_ylabel(ylabel)
        zeros = len(vals) - len(pos)
        ax.set_title(
            f"{ylabel.split(' (')[0]} vs time"
            + (
                f"\n({zeros} rows with zero error drawn at {floor:.2g}, open triangles)"
                if zeros
                else ""
            ),
            fontsize=10,
        )
        ax.grid(True, which="both", alpha=0.3)
    if placement:
        ax = axes[-1]
        xs = [p["seconds"]["median"] for p in placement]
        ys = [p["coverage_pct"] for p in placement]
        ax.plot(xs, ys, "o-", color="tab:purple", label="placement (generations x population)")
        for p, xv, yv in zip(placement, xs, ys):
            ax.annotate(
                p["label"], (xv, yv), textcoords="offset points", xytext=(4, -10), fontsize=7
            )
            if p["is_default"]:
                ax.plot(xv, yv, "o", ms=16, mfc="none", mec="k", mew=2, label="default setting")
        ax.set_xscale("log")
        ax.set_xlabel("placement time (s, median)")
        ax.set_ylabel("weighted floor coverage (%)")
        ax.set_title("placement effort: coverage vs seconds", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    title = (
        f"What accuracy costs: {Path(c['source']).name if c['kind'] != 'builtin' else c['source']}"
        ", "
        f"sensor {c['sensor']} ({c['size'][0]}x{c['size'][1]}), {c['cameras']} camera(s), "
        f"{c['repeats']} repeats; reference: {c['reference']}"
    )
    fig.suptitle("\n".join(textwrap.wrap(title, 70 * n)), fontsize=10)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(
        handles, labels, loc="lower center", ncol=min(len(labels), 6), fontsize=8, frameon=False
    )
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    tmp = path.with_name(f".{path.stem}.tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    tmp.replace(path)
