"""``--budget-mm`` / ``--budget-px``: the fastest accuracy setting whose error stays within a
budget.

The depth budget bounds the p99 depth error (mm) where ids agree; the pixel budget bounds the
mean silhouette displacement (``edge_px``). The rows turn one knob at a time, so the pick
first combines, knob by knob, the fastest level whose own row is within the budget; that
combination is rendered and measured like any row, and kept when it is within the budget and
faster than the fastest single row within it (the two timed again side by side); otherwise
the fastest single row is kept. "Fastest" counts times within half the fastest row's IQR as ties,
won by the more exact row. The resolution is left out (it changes the sensor, not a setting),
and so is a knob this build's dataset run cannot apply (tessellation without a scene builder
that takes ``segments``).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any, Callable

from ..sensors.accuracy import AccuracySettings
from .knobs import KNOB, Setting

METRICS = (("depth_p99_mm", "mm"), ("edge_px", "px"))


def within(errors: dict, budget_mm: float | None, budget_px: float | None) -> bool:
    return (budget_mm is None or errors["depth_p99_mm"] <= budget_mm) and (
        budget_px is None or errors["edge_px"] <= budget_px
    )


def _ms(row: dict) -> float:
    return row["time_ms"]["total"]["median"]


def fastest(rows: list[dict]) -> dict:
    """The fastest row, where a time within half the fastest's spread (its IQR) counts as a
    tie that the more exact row wins (p99 depth error, then edge error): a shared machine's noise
    never buys a less exact setting."""
    best = min(rows, key=_ms)
    band = _ms(best) + 0.5 * best["time_ms"]["total"].get("iqr", 0.0)
    tied = [r for r in rows if _ms(r) <= band]
    return min(tied, key=lambda r: (r["errors"]["depth_p99_mm"], r["errors"]["edge_px"], _ms(r)))


def pick(
    runner,
    rows: list[dict],
    refs: dict,
    budget_mm: float | None,
    budget_px: float | None,
    row_for: Callable,
    skip: tuple[str, ...] = (),
) -> dict[str, Any]:
    """The chosen setting, the row that measured it and a comment for the written file;
    knobs named in ``skip`` (those a dataset run cannot apply) keep their defaults."""
    text = " and ".join(
        t
        for t in (
            f"p99 depth error <= {budget_mm:g} mm" if budget_mm is not None else "",
            f"edge error <= {budget_px:g} px" if budget_px is not None else "",
        )
        if t
    )
    eligible = [
        r for r in rows if r.get("available") and r["knob"] not in (set(skip) | {"resolution"})
    ]
    ok = [r for r in eligible if within(r["errors"], budget_mm, budget_px)]
    if not ok:
        best = min(eligible, key=lambda r: (r["errors"]["depth_p99_mm"], r["errors"]["edge_px"]))
        return {
            "settings": best["settings"],
            "row": best,
            "within": False,
            "budget_mm": budget_mm,
            "budget_px": budget_px,
            "comment": f"no measured setting meets {text}; the most exact one measured "
            f"({best['level']} "
            f"{best['title']}): p99 {best['errors']['depth_p99_mm']:.3f} mm, "
            f"edge {best['errors']['edge_px']:.3f} px",
        }
    single = fastest(ok)
    acc = AccuracySettings()
    for name in sorted({r["knob"] for r in ok}):
        best = fastest([r for r in ok if r["knob"] == name])
        acc = replace(acc, **{KNOB[name].field: best["value"]})
    chosen = single
    combined = None
    if acc != AccuracySettings(**single["settings"]):
        modes = ("analytic", "exact") if "analytic" in refs else ("exact",)
        setting = Setting(1.0, acc)
        base = Setting(1.0, AccuracySettings(**single["settings"]))
        t_fast, t_comb = runner.side_by_side([base, setting])  # a fair race between the two
        runner.timings[setting.key()] = t_comb
        measured = [row_for(runner, None, None, setting, m, refs) for m in modes]
        combined = measured[-1]
        combined["errors"] = {k: max(m["errors"][k] for m in measured) for k in combined["errors"]}
        combined["reference"] = " and ".join(m["reference"] for m in measured)
        combined["ratio_to_fastest_single"] = t_comb["total"]["median"] / t_fast["total"]["median"]
        if (
            within(combined["errors"], budget_mm, budget_px)
            and combined["ratio_to_fastest_single"] < 1
        ):
            chosen = combined
    e = chosen["errors"]
    label = AccuracySettings(**chosen["settings"]).label()
    comment = (
        f"fastest setting with {text}: {label}: {_ms(chosen):.1f} ms/frame, p99 depth error "
        f"{e['depth_p99_mm']:.3f} mm, edge error {e['edge_px']:.3f} px (reference: "
        f"{chosen['reference']})\n"
        f"written by genie bench accuracy; use with: genie dataset ... --accuracy FILE"
    )
    return {
        "settings": chosen["settings"],
        "row": chosen,
        "combined": combined,
        "within": True,
        "budget_mm": budget_mm,
        "budget_px": budget_px,
        "comment": comment,
    }
