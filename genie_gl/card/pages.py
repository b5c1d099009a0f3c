"""The report card as Markdown, and a page per sensor with its curves under ``docs/sensors/``.

:func:`card_markdown` is the card's table (what ``genie report-card`` prints);
:func:`write_pages` writes, for each card, ``<sensor>.md`` with four PNG curves beside it —
``<sensor>_sigma.png`` (temporal noise and plane-fit RMS against distance and angle),
``<sensor>_bias.png`` (systematic error and Z accuracy), ``<sensor>_fill.png`` (fill rate of
walls, panels and bars) and ``<sensor>_edges.png`` (flying pixels and lateral noise at the
step) — with the published figures drawn on them, and ``index.md`` linking the pages.
The folder is claimed through :mod:`genie_gl.outputs` (only files genie-gl wrote are replaced;
its ``manifest.json`` records them), and every file is written to a temporary name and renamed.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Iterable

import numpy as np

from ..outputs import PNG_SOFTWARE, OutputFolder, atomic_write_text, claim_folder
from .references import METRICS, Figure
from .report import Judgement, Measurement, ReportCard

CURVES = ("sigma", "bias", "fill", "edges")

COMMAND = "genie report-card --sensor {sensor} --pages docs/sensors"


def _num(v: float | None, digits: int = 3) -> str:
    if v is None or not math.isfinite(v):
        return "–"
    return f"{v:.{digits}g}" if abs(v) < 1000 else f"{v:.0f}"


def _condition(f: Figure) -> str:
    d = (
        f"{f.distance_m:g} m"
        if f.distance_m is not None
        else f"{f.distance_range_m[0]:g}–{f.distance_range_m[1]:g} m"
    )
    parts = [d]
    if f.angle_deg:
        parts.append(f"{f.angle_deg:g}°")
    if f.part:
        parts.append(f.part)
    return ", ".join(parts)


def _published(f: Figure) -> str:
    unit = METRICS[f.metric][1]
    v = f"{f.value:g}" + (f" + {f.per_m:g}/m" if f.per_m else "")
    sign = {"max": "≤ ", "min": "≥ ", "max_abs": "abs ≤ ", "value": ""}[f.bound]
    tol = f" ± {f.tolerance:g}" if f.bound == "value" else ""
    return f"{sign}{v}{tol} {unit}"


def _verdict(j: Judgement | None, unit: str) -> tuple[str, str]:
    if j is None:
        return "", ""
    if j.verdict == "not measured":
        return "–", "not measured"
    if (
        j.distance_m is None
    ):  # by construction or not modelled, with nothing measured under the figure
        return "–", j.verdict
    at = f" (at {j.distance_m:g} m)"
    return f"{_num(j.ours)} {unit}{at}", j.verdict


def card_markdown(card: ReportCard, heading: str = "##") -> str:
    """The card's comparison and measurement tables as Markdown."""
    lines = [f"{heading} Against published figures", ""]
    yours = card.captures or card.capture_source
    head = "| metric | conditions | published | source (how read) | ours | verdict |"
    rule = "| --- | --- | --- | --- | --- | --- |"
    if yours:
        head += " your camera | verdict |"
        rule += " --- | --- |"
    if card.comparisons:
        lines += [head, rule]
        for c in card.comparisons:
            f = c.figure
            unit = METRICS[f.metric][1]
            ours, verdict = _verdict(c.sim, unit)
            tag = f.source.verification + ("" if f.counted else ", not counted")
            why = f" ({c.sim.why})" if c.sim.why else ""
            row = (
                f"| {f.metric} | {_condition(f)} | {_published(f)} | {f.source.key} ({tag}) | "
                f"{ours} | "
                f"**{verdict}**{why} |"
            )
            if yours:
                y, yv = _verdict(c.captures, unit)
                row += f" {y} | {yv} |"
            lines.append(row)
        n = card.counts()
        lines += [
            "",
            f"Counted figures: {n['pass']} pass, {n['differs']} differ, {n['not measured']} not "
            "measured "
            "(only figures read in their source count; secondary and unverified ones are shown, "
            f"not counted; so are {n['by construction']} read by construction and "
            f"{n['not modelled']} "
            "not modelled, which the profile could not have failed).",
        ]
    else:
        lines.append("No reference file: nothing to compare against.")
    lines += ["", f"{heading} Measured", ""]
    lines += _measured_tables(card.measurements)
    if card.captures:
        lines += ["", f"{heading} Your captures ({card.capture_source})", ""]
        lines += _measured_tables(card.captures)
    return "\n".join(lines) + "\n"


def _measured_tables(ms: Iterable[Measurement]) -> list[str]:
    ms = list(ms)
    out: list[str] = []
    wall_cols = [
        "fill_rate_pct",
        "z_accuracy_pct",
        "plane_fit_rms_mm",
        "subpixel_rms_px",
        "temporal_noise_mm",
        "bias_mm",
        "banding_occupied",
        "banding_peak_ratio",
    ]
    walls = [m for m in ms if m.scene == "wall"]
    cols = [c for c in wall_cols if any(m.metric == c for m in walls)]
    if walls:
        out += [
            "Walls (central ROI; per-frame metrics averaged over the frames):",
            "",
            "| distance (m) | angle (°) | "
            + " | ".join(f"{c} ({METRICS[c][1]})" for c in cols)
            + " |",
            "| --- | --- | " + " | ".join("---" for _ in cols) + " |",
        ]
        keys = sorted({(m.angle_deg, m.distance_m) for m in walls})
        for a, d in keys:
            vals = {m.metric: m.value for m in walls if m.distance_m == d and m.angle_deg == a}
            out.append(f"| {d:g} | {a:g} | " + " | ".join(_num(vals.get(c)) for c in cols) + " |")
        out.append("")
    steps = [m for m in ms if m.scene == "step"]
    if steps:
        scols = ["edge_fill_pct", "flying_pixel_pct", "lateral_noise_px"]
        out += [
            "Depth step (0.5 m deep, edge on the optical axis):",
            "",
            "| distance (m) | " + " | ".join(f"{c} ({METRICS[c][1]})" for c in scols) + " |",
            "| --- | " + " | ".join("---" for _ in scols) + " |",
        ]
        for d in sorted({m.distance_m for m in steps}):
            vals = {m.metric: m.value for m in steps if m.distance_m == d}
            out.append(f"| {d:g} | " + " | ".join(_num(vals.get(c)) for c in scols) + " |")
        out.append("")
    for scene, title in (
        ("bars", "Thin bars (fill, % of the bar's pixels returning the bar)"),
        ("panels", "Material panels (fill, %)"),
    ):
        part_ms = [m for m in ms if m.scene == scene]
        if not part_ms:
            continue
        parts = list(dict.fromkeys(m.part for m in part_ms))
        out += [
            title + ":",
            "",
            "| distance (m) | " + " | ".join(str(p) for p in parts) + " |",
            "| --- | " + " | ".join("---" for _ in parts) + " |",
        ]
        for d in sorted({m.distance_m for m in part_ms}):
            vals = {m.part: m.value for m in part_ms if m.distance_m == d}
            out.append(f"| {d:g} | " + " | ".join(_num(vals.get(p)) for p in parts) + " |")
        out.append("")
    return out


# -- curves ----------------------------------------------------------------------------------
def _series(
    ms: Iterable[Measurement],
    metric: str,
    angle: float = 0.0,
    part: str | None = None,
    scale_by_distance: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    pts = sorted(
        (m.distance_m, m.value * (scale_by_distance * m.distance_m if scale_by_distance else 1.0))
        for m in ms
        if m.metric == metric and m.angle_deg == angle and m.part == part and math.isfinite(m.value)
    )
    if not pts:
        return np.zeros(0), np.zeros(0)
    a = np.array(pts)
    return a[:, 0], a[:, 1]


def _draw_figures(
    ax, figures: Iterable[Figure], metric_to_mm: dict[str, float | None], color: str = "k"
) -> None:
    """Published figures on an axis in mm (or the metric's unit): bounds as dashed steps over
    their distances, values as points with the tolerance as an error bar."""
    for f in figures:
        if f.metric not in metric_to_mm:
            continue
        scale = metric_to_mm[f.metric]  # None: plotted in its unit; k: value (in % of d) x k x d
        lo, hi = (f.distance_m, f.distance_m) if f.distance_m is not None else f.distance_range_m
        ds = np.linspace(lo, hi, 20) if hi > lo else np.array([lo])
        ys = np.array([f.limit(d) * (scale * d if scale else 1.0) for d in ds])
        style = "--" if f.counted else ":"
        label = f"{f.source.key}: {_published(f)}"
        if f.bound == "value":
            err = float(f.tolerance or 0) * (scale * ds[0] if scale else 1.0)
            ax.errorbar(
                ds,
                ys,
                yerr=err,
                fmt="s",
                color=color,
                mfc="none" if not f.counted else color,
                capsize=4,
                label=label,
            )
        elif len(ds) == 1:
            ax.plot(
                ds,
                ys,
                "v" if f.bound in ("max", "max_abs") else "^",
                color=color,
                ms=9,
                label=label,
            )
            if f.bound == "max_abs":
                ax.plot(ds, -ys, "^", color=color, ms=9)
        else:
            ax.plot(ds, ys, style, color=color, label=label)
            if f.bound == "max_abs":
                ax.plot(ds, -ys, style, color=color)


def _save(fig, path: Path) -> None:
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.png")
    try:
        fig.savefig(tmp, format="png", dpi=110, metadata={"Software": PNG_SOFTWARE})
        tmp.replace(path)
    finally:
        if tmp.exists():
            tmp.unlink()


def page_names(sensor: str) -> list[str]:
    """The files :func:`write_pages` writes for one sensor (the index aside)."""
    return [f"{sensor}.md", *(f"{sensor}_{c}.png" for c in CURVES)]


def write_curves(card: ReportCard, folder: Path) -> list[str]:
    """The card's four PNG curves in ``folder``; returns their file names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ms = card.measurements
    figs = [c.figure for c in card.comparisons]
    names = []
    # sigma: temporal noise and plane-fit RMS against distance; temporal noise against angle
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
    for metric, label in (
        ("temporal_noise_mm", "temporal noise (RMS of per-pixel std)"),
        ("plane_fit_rms_mm", "plane-fit RMS (spatial noise)"),
    ):
        x, y = _series(ms, metric)
        a1.plot(x, y, "o-", label=label)
    _draw_figures(
        a1,
        figs,
        {
            "temporal_noise_mm": None,
            "plane_fit_rms_mm": None,
            "temporal_noise_pct": 10.0,
            "plane_fit_rms_pct": 10.0,
        },
    )
    a1.set(
        xlabel="wall distance (m)",
        ylabel="σ (mm)",
        title=f"{card.sensor}: depth noise against distance",
    )
    a1.set_yscale("log")
    a1.grid(True, which="both", alpha=0.3)
    a1.legend(fontsize=7)
    angles = sorted(
        {m.distance_m for m in ms if m.metric == "temporal_noise_mm" and m.angle_deg > 0}
    )
    for d in angles:
        pts = sorted(
            (m.angle_deg, m.value)
            for m in ms
            if m.metric == "temporal_noise_mm" and m.distance_m == d
        )
        if pts:
            a = np.array(pts)
            a2.plot(a[:, 0], a[:, 1], "o-", label=f"{d:g} m")
    a2.set(
        xlabel="incidence angle on the axis (°)",
        ylabel="temporal noise (mm)",
        title="against angle",
    )
    a2.grid(True, alpha=0.3)
    if angles:
        a2.legend(fontsize=8)
    fig.tight_layout()
    names.append(f"{card.sensor}_sigma.png")
    _save(fig, folder / names[-1])
    plt.close(fig)
    # bias: systematic error and Z accuracy (as mm) against distance
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    x, y = _series(ms, "bias_mm")
    ax.plot(x, y, "o-", label="systematic error (temporal mean − truth, median)")
    x, y = _series(ms, "z_accuracy_pct", scale_by_distance=10.0)
    ax.plot(x, y, "s-", mfc="none", label="Z accuracy (DQT median), as mm")
    _draw_figures(ax, figs, {"bias_mm": None, "bias_pct": 10.0, "z_accuracy_pct": 10.0})
    ax.axhline(0, color="0.5", lw=0.8)
    ax.set(
        xlabel="wall distance (m)",
        ylabel="bias (mm)",
        title=f"{card.sensor}: bias against distance",
    )
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    names.append(f"{card.sensor}_bias.png")
    _save(fig, folder / names[-1])
    plt.close(fig)
    # fill: walls against distance, panels and bars
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
    x, y = _series(ms, "fill_rate_pct")
    a1.plot(x, y, "o-", label="wall, central ROI")
    for part in dict.fromkeys(m.part for m in ms if m.metric == "panel_fill_pct"):
        x, y = _series(ms, "panel_fill_pct", part=part)
        a1.plot(x, y, "s--", label=f"panel: {part}")
    _draw_figures(a1, figs, {"fill_rate_pct": None, "panel_fill_pct": None})
    a1.set(
        xlabel="distance (m)",
        ylabel="fill rate (%)",
        ylim=(-5, 105),
        title=f"{card.sensor}: fill rate",
    )
    a1.grid(True, alpha=0.3)
    a1.legend(fontsize=7)
    bars = [m for m in ms if m.metric == "bar_fill_pct"]
    for d in sorted({m.distance_m for m in bars}):
        pts = sorted((float(m.part.split("_")[1][:-2]), m.value) for m in bars if m.distance_m == d)
        a = np.array(pts)
        a2.plot(a[:, 0], a[:, 1], "o-", label=f"bars at {d:g} m")
    a2.set(
        xlabel="bar width (mm)",
        ylabel="bar pixels returning the bar (%)",
        ylim=(-5, 105),
        title="thin bars",
    )
    a2.set_xscale("log")
    widths = sorted({float(m.part.split("_")[1][:-2]) for m in bars})
    if widths:
        a2.set_xticks(widths, [f"{w:g}" for w in widths])
        a2.minorticks_off()
    a2.grid(True, alpha=0.3)
    if bars:
        a2.legend(fontsize=8)
    fig.tight_layout()
    names.append(f"{card.sensor}_fill.png")
    _save(fig, folder / names[-1])
    plt.close(fig)
    # edges: flying pixels and lateral noise at the step
    fig, ax = plt.subplots(figsize=(6.5, 5.0))
    x, y = _series(ms, "flying_pixel_pct")
    ax.plot(x, y, "o-", label="flying pixels (% of valid pixels within 3 px of the edge)")
    x, y = _series(ms, "edge_fill_pct")
    ax.plot(
        x, 100.0 - y, "s--", mfc="none", label="pixels without return within 3 px of the edge (%)"
    )
    _draw_figures(ax, figs, {"flying_pixel_pct": None})
    ax.set(xlabel="step distance (m)", ylabel="%", title=f"{card.sensor}: at a 0.5 m depth step")
    ax.grid(True, alpha=0.3)
    handles, labels = ax.get_legend_handles_labels()
    x, y = _series(ms, "lateral_noise_px")
    if len(x):
        ax2 = ax.twinx()
        ax2.plot(x, y, "^:", color="C3", label="lateral noise of the edge (px, right axis)")
        ax2.set_ylabel("lateral noise (px)")
        h2, l2 = ax2.get_legend_handles_labels()
        handles, labels = handles + h2, labels + l2
    ax.legend(handles, labels, fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=1)
    fig.tight_layout()
    names.append(f"{card.sensor}_edges.png")
    _save(fig, folder / names[-1])
    plt.close(fig)
    return names


def page_markdown(card: ReportCard, images: list[str], references: dict | None = None) -> str:
    """A sensor's page: the card, its curves, its sources and how to remake it."""
    s = card.settings
    lines = [
        f"# {card.sensor}: report card",
        "",
        f"The profile `sensors/{card.sensor}.yaml` rendered through the standard test scenes and "
        "measured "
        "with the depth-quality metrics of the field (Intel's depth quality tool, Azure Kinect's "
        "error "
        "definitions), beside the published figures of `sensors/"
        f"{card.sensor}.reference.yml`.",
        "",
        f"Settings: seed {s.seed}, {s.frames} frames per scene, central ROI {s.roi_fraction:g} of "
        "width and "
        f"height. Remake with `{COMMAND.format(sensor=card.sensor)}` (or `make sensor-pages`).",
        "",
    ]
    lines.append(card_markdown(card))
    lines += ["## Curves", ""]
    lines += [f"![{name}]({name})" for name in images]
    lines += [
        "",
        "Published figures are drawn in black: dashed lines are bounds over a distance range, "
        "triangles bounds at one distance, squares values with their tolerance (hollow and dotted: "
        "not read in their source, not counted).",
        "",
    ]
    if references:
        lines += ["## Sources", ""]
        for key, src in references.items():
            url = f" <{src.url}>" if src.url else ""
            note = f" {src.note}" if src.note else ""
            lines.append(
                f"- **{key}** ({src.verification}): {src.citation}. *{src.where}*.{url}{note}"
            )
        lines.append("")
    return "\n".join(lines)


def write_pages(
    cards: Iterable[ReportCard],
    folder: str | os.PathLike | OutputFolder,
    references: dict | None = None,
) -> list[Path]:
    """A page and four curves per card in ``folder`` and ``index.md`` linking every page
    genie-gl wrote there; ``references`` maps a sensor to its
    :class:`~genie_gl.card.references.References` (for the page's source list). ``folder`` is a
    path (claimed here through :func:`genie_gl.outputs.claim_folder`) or a folder already
    claimed. Returns the pages written (index last)."""
    cards = list(cards)
    if not isinstance(folder, OutputFolder):
        names = [n for c in cards for n in page_names(c.sensor)] + ["index.md"]
        folder = claim_folder(folder, "report-card", names, option="pages")
    out = folder.path
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for card in cards:
        images = write_curves(card, out)
        refs = (references or {}).get(card.sensor)
        page = out / f"{card.sensor}.md"
        atomic_write_text(page, page_markdown(card, images, None if refs is None else refs.sources))
        written.append(page)
    rows = [
        "# Sensor report cards",
        "",
        "Each shipped sensor profile rendered through the standard test scenes (flat walls at "
        "0.3–4 m and "
        "0–60°, a depth step, thin bars, dark and shiny panels) and measured with the field's "
        "depth-quality "
        "metrics, beside the figures published for the real device. Every figure names its source "
        "and how it "
        "was read.",
        "",
        "| sensor | counted figures: pass / differ / not measured | page |",
        "| --- | --- | --- |",
    ]
    for name in folder.outputs():
        page = out / name
        if not name.endswith(".md") or name == "index.md" or not page.is_file():
            continue
        text = page.read_text(encoding="utf-8")
        summary = next((ln for ln in text.splitlines() if ln.startswith("Counted figures:")), "")
        nums = summary.replace("Counted figures: ", "").split(" (")[0] if summary else "no figures"
        rows.append(f"| {page.stem} | {nums} | [{page.name}]({page.name}) |")
    index = out / "index.md"
    atomic_write_text(index, "\n".join(rows) + "\n")
    written.append(index)
    folder.finish({"pages": [c.sensor for c in cards]})
    return written
