"""What captured frames cost and what their effects did, summed from the frames' records.

Each frame made by :func:`~genie_gl.capture.capture` records its render's milliseconds
(``meta["render_ms"]``, or ``meta["cost_ms"]`` per part) and, per sensor effect, whether it
ran, why, its milliseconds and the pixels it changed (``meta["effects"]``, written by
:func:`~genie_gl.effects.simulate.simulate`). Manifests and benchmarks sum them here.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from ..frame import Frame


def frame_cost(meta: dict[str, Any]) -> dict[str, float]:
    """One frame's milliseconds per part, from its ``meta``: ``cost_ms`` when it has it, the
    per-effect log ``effects`` (``[{"name", "run", "ms"}, ...]``) for the effects, and the
    renderer's ``render_ms`` otherwise."""
    cost = dict(meta.get("cost_ms") or {})
    for e in meta.get("effects") or []:
        if (
            isinstance(e, dict)
            and "ms" in e
            and f"effect:{e.get('name')}" not in (meta.get("cost_ms") or {})
        ):
            key = f"effect:{e.get('name')}"
            cost[key] = cost.get(key, 0.0) + float(e["ms"])
    if "render" not in cost:
        cost["render"] = float(meta.get("render_ms", 0.0))
    return cost


def frame_costs(frames: Iterable[Frame]) -> dict[str, float]:
    """Milliseconds summed over ``frames`` per part of making them: ``render``, ``distortion``
    and ``effect:<name>`` (from each frame's ``meta["cost_ms"]``; a frame without it, an
    ideal pinhole frame, counts its ``render_ms``)."""
    out: dict[str, float] = {}
    for f in frames:
        for k, v in frame_cost(f.meta or {}).items():
            out[k] = out.get(k, 0.0) + float(v)
    return out


def effect_totals(frames: Iterable[Frame]) -> dict[str, dict[str, Any]]:
    """Per effect over captured frames (their ``meta["effects"]``): frames it ran on, frames
    it skipped, its total milliseconds and the pixels it changed."""
    out: dict[str, dict[str, Any]] = {}
    for f in frames:
        for e in (f.meta or {}).get("effects", []):
            add_totals(
                out,
                {
                    e["name"]: {
                        "run": int(e["run"]),
                        "skipped": int(not e["run"]),
                        "ms": e["ms"],
                        "changed": e["changed"],
                    }
                },
            )
    return out


def add_totals(
    into: dict[str, dict[str, Any]], more: dict[str, dict[str, Any]]
) -> dict[str, dict[str, Any]]:
    """Sum ``more`` (as :func:`effect_totals` gives) into ``into``; returns ``into``."""
    for name, t in more.items():
        acc = into.setdefault(name, {"run": 0, "skipped": 0, "ms": 0.0, "changed": 0})
        for k in ("run", "skipped", "changed"):
            acc[k] += int(t.get(k, 0))
        acc["ms"] = round(acc["ms"] + float(t.get("ms", 0.0)), 3)
    return into
