"""``genie bench accuracy``: what accuracy costs, on the user's own scene and sensor.

``genie bench accuracy [--scene PATH] [--sensor PROFILE] [--seed S] [--cameras N | --poses FILE]
[--repeats R] [--budget-mm X] [--budget-px Y] --out DIR``

Every knob of :mod:`genie_gl.bench.knobs` is turned through its levels, one at a time, the
others left at their defaults. Each row is timed over ``--repeats`` passes over the cameras
after one warm-up pass, all in this process, split into render, lens remap, each effect and
unprojection (median and interquartile range of the per-frame milliseconds); and its errors
are measured (:mod:`genie_gl.bench.accuracy_errors`) against a reference:

* ``--scene`` omitted: the built-in case (:mod:`genie_gl.bench.analytic`); knobs that change
  geometry are measured against analytic truth, knobs that change how faithfully an effect
  is simulated against the exact setting.
* a USD stage, or a layout / strategy JSON (built with ``--seed``): against the most exact
  setting of every knob at once, rendered once per run and reused by every row.

Errors are measured with the effects that draw random numbers (noise) switched off, so they
show the knobs and not the noise; the noise is checked on its own, as a distribution: the
measured σ against the model's at several depths. Writes ``accuracy.json``, ``accuracy.png``
and ``accuracy.md`` (the table in Markdown); ``--budget-mm`` / ``--budget-px`` also write
``accuracy.yaml``, the fastest
setting within the budget, as an ``accuracy:`` block that ``genie dataset --accuracy`` reads.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..sensors.accuracy import AccuracySettings, write_accuracy
from ..placement.genetic import CoverageProblem, genetic_placement, greedy_placement
from .accuracy_budget import pick
from .accuracy_case import check_path, content_poses, make_case  # noqa: F401  (content_poses: public)
from .accuracy_errors import compare, noise_check, pool
from .accuracy_plot import pareto, plot
from .accuracy_runner import Runner, references, spread
from .knobs import (
    KNOBS,
    PLACEMENT_DEFAULT,
    PLACEMENT_LEVELS,
    Case,
    Knob,
    Setting,
    exact_setting,
    levels,
)

PLACEMENT_CAMERAS = 12


# -- the case -----------------------------------------------------------------------------------
# -- the bench --------------------------------------------------------------------------------
def row_for(
    runner: Runner, knob: Knob | None, value: Any, setting: Setting, mode: str, refs: dict
) -> dict:
    runner.run(setting, (mode,))
    parts = [
        compare(f, ref, runner.case.sensor)
        for f, ref in zip(runner.frames[(setting.key(), mode)], refs[mode])
    ]
    return {
        "knob": knob.name if knob else "budget",
        "title": knob.title if knob else "budget pick",
        "level": knob.label(value) if knob else setting.accuracy.label(),
        "value": value,
        "resolution": setting.resolution,
        "settings": setting.accuracy.to_dict(),
        "is_default": setting.key() == Setting().key(),
        "reference": {"analytic": "analytic truth", "exact": "exact setting"}[mode],
        "available": True,
        "time_ms": runner.timings[setting.key()],
        "errors": pool(parts),
    }


def noise_rows(runner: Runner) -> list[dict]:
    """σ measured against the model's, per depth-noise effect of the sensor."""
    exact = exact_setting(runner.case)
    ideal = [i for _, i in runner.frames[(exact.key(), "reference")]]
    out = []
    for k, eff in enumerate(runner.case.sensor.effects):
        if hasattr(eff, "sigma") and getattr(eff, "draws", False):
            bins = noise_check(eff, ideal, rng=np.random.default_rng([runner.seed, k]))
            out.append({"effect": eff.name, "model": getattr(eff, "model", ""), "bins": bins})
    return out


def placement_rows(case: Case, repeats: int, seed: int) -> list[dict]:
    """Coverage against seconds for the genetic placement's effort (strategy scenes only), for
    at least ``PLACEMENT_CAMERAS`` cameras (discs of 6 m, the placement's default)."""
    problem = CoverageProblem(case.layout, 6.0)
    n = max(len(case.poses), PLACEMENT_CAMERAS)  # a few cameras leave a search nothing to find
    rows = []
    for gens, popn in PLACEMENT_LEVELS:
        ts, cov = [], 0.0
        for _ in range(min(repeats, 3) + 1):
            t = time.perf_counter()
            res = (
                greedy_placement(problem, n)
                if gens == 0
                else genetic_placement(
                    problem, n, rng=np.random.default_rng(seed), population=popn, generations=gens
                )
            )
            ts.append(time.perf_counter() - t)
            cov = res.coverage
        rows.append(
            {
                "generations": gens,
                "population": popn,
                "label": "greedy" if gens == 0 else f"{gens}x{popn}",
                "is_default": (gens, popn) == PLACEMENT_DEFAULT,
                "coverage_pct": 100.0 * cov,
                "cameras": n,
                "seconds": spread(ts[1:]),
            }
        )
    return rows


def check_arguments(args: argparse.Namespace) -> None:
    """What can be checked before the output folder is claimed (``genie bench`` calls it)."""
    check_path(args)


def run(args: argparse.Namespace) -> int:
    case = make_case(args)
    chosen = KNOBS
    if args.knobs:
        names = [s.strip() for s in args.knobs.split(",") if s.strip()]
        unknown = [n for n in names if n not in {k.name for k in KNOBS}]
        if unknown:
            raise ConfigError(
                f"--knobs: unknown {', '.join(unknown)}; expected some of "
                f"{', '.join(k.name for k in KNOBS)}"
            )
        chosen = tuple(k for k in KNOBS if k.name in names)
    runner = Runner(case, args.repeats, args.seed)
    try:
        return _run(args, case, chosen, runner)
    finally:
        runner.close()


def _run(args: argparse.Namespace, case: Case, chosen: tuple[Knob, ...], runner: Runner) -> int:
    t0 = time.perf_counter()
    refs = references(runner, None if args.no_cache else Path(args.out) / "cache")
    plan = [(k, k.requires(case)) for k in chosen]
    runner.time_many([k.setting(v) for k, why in plan if not why for v, _ in levels(k, case)])
    rows: list[dict] = []
    for knob, why in plan:
        if why:
            rows.append({"knob": knob.name, "title": knob.title, "available": False, "reason": why})
            continue
        mode = "analytic" if case.kind == "builtin" and knob.geometric else "exact"
        for value, label in levels(knob, case):
            rows.append(
                row_for(runner, knob, value, knob.setting(value), mode, refs) | {"level": label}
            )
    result: dict[str, Any] = {
        "case": {
            "kind": case.kind,
            "source": case.source,
            "sensor": case.sensor.name,
            "effects": [e.name for e in case.sensor.effects],
            "cameras": len(case.poses),
            "repeats": args.repeats,
            "seed": args.seed,
            "size": [case.sensor.width, case.sensor.height],
            "reference": (
                "analytic truth for geometric knobs, the exact setting for effect knobs"
                if case.kind == "builtin"
                else "the exact setting: " + exact_setting(case).accuracy.label()
            ),
        },
        "rows": rows,
        "noise": noise_rows(runner),
        "placement": placement_rows(case, args.repeats, args.seed)
        if case.layout is not None
        else [],
    }
    result["pareto"] = pareto(rows)
    if args.budget_mm is not None or args.budget_px is not None:
        result["budget"] = pick(
            runner, rows, refs, args.budget_mm, args.budget_px, row_for, dataset_cannot()
        )
    result["wall_s"] = time.perf_counter() - t0
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    print_table(result)
    tmp = out / ".accuracy.json.tmp"
    tmp.write_text(json.dumps(result, indent=1, default=_json))
    tmp.replace(out / "accuracy.json")
    plot(result, out / "accuracy.png")
    tmp = out / ".accuracy.md.tmp"
    tmp.write_text(markdown(result))
    tmp.replace(out / "accuracy.md")
    if "budget" in result:
        b = result["budget"]
        write_accuracy(
            out / "accuracy.yaml", AccuracySettings(**b["settings"]), comment=b["comment"]
        )
        print(f"budget: {b['comment'].splitlines()[0]} -> {out / 'accuracy.yaml'}")
    print(f"wrote {out / 'accuracy.json'} and {out / 'accuracy.png'} ({result['wall_s']:.0f} s)")
    return 0


def dataset_cannot() -> tuple[str, ...]:
    """Knobs that ``genie dataset --accuracy`` cannot apply in this build (the budget leaves
    them at their defaults)."""
    return ()  # every knob reaches a dataset run: build_scene and read_usd take segments=


def _json(o: Any) -> Any:
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(type(o).__name__)


def markdown(result: dict) -> str:
    """The rows as a Markdown table (what ``accuracy.md`` holds, for a README or a report)."""
    out = [
        "| knob | level | ms/frame (IQR) | render ms | effects ms | dz p99 mm | p2s mm | id % | "
        "sil % | "
        "edge px | gap mm | reference |",
        "|" + " --- |" * 12,
    ]
    for r in result["rows"]:
        if not r["available"]:
            out.append(f"| {r['title']} | — | unavailable: {r['reason']} |" + " |" * 9)
            continue
        t, e = r["time_ms"], r["errors"]
        eff = sum(v["median"] for k, v in t.items() if k.startswith("effect:") or k == "distortion")
        out.append(
            f"| {r['title']} | {r['level']}{' (default)' if r['is_default'] else ''} | "
            f"{t['total']['median']:.0f} ({t['total']['iqr']:.0f}) | {t['render']['median']:.0f} | "
            f"{eff:.0f} | "
            f"{e['depth_p99_mm']:.2f} | {e['p2s_mean_mm']:.2f} | {e['id_pct']:.2f} | "
            f"{e['silhouette_pct']:.1f} | "
            f"{e['edge_px']:.3f} | {e['sampling_mm']:.2f} | {r['reference']} |"
        )
    return "\n".join(out) + "\n"


def print_table(result: dict) -> None:
    c = result["case"]
    print(
        f"accuracy on {c['source']}, sensor {c['sensor']} {c['size'][0]}x{c['size'][1]} "
        f"({', '.join(c['effects']) or 'no effects'}), {c['cameras']} cameras, {c['repeats']} "
        "repeats"
    )
    print(f"reference: {c['reference']}; errors with noise off (noise checked below)")
    parts = sorted(
        {
            k
            for r in result["rows"]
            if r["available"]
            for k in r["time_ms"]
            if k.startswith("effect:") or k == "distortion"
        }
    )
    names = [k.split(":", 1)[-1][:9] for k in parts]
    head = (
        f"{'knob':<30}{'level':>8}{'ms/frame':>9}{'IQR':>6}{'render':>7}"
        + "".join(f"{n:>10}" for n in names)
        + f"{'unproj':>7}{'dz med':>7}{'dz p99':>7}{'p2s':>6}{'id %':>6}{'sil %':>6}{'edge px':>8}"
        f"{'gap mm':>7}  ref"
    )
    print(head)
    print("-" * len(head))
    for r in result["rows"]:
        if not r["available"]:
            print(f"{r['title']:<30}{'—':>8}  unavailable: {r['reason']}")
            continue
        t, e = r["time_ms"], r["errors"]
        mark = " *" if r["is_default"] else ""
        cells = "".join(f"{t[k]['median'] if k in t else 0.0:>10.1f}" for k in parts)
        print(
            f"{r['title']:<30}{r['level'] + mark:>8}{t['total']['median']:>9.1f}"
            f"{t['total']['iqr']:>6.1f}"
            f"{t['render']['median']:>7.1f}{cells}{t['unprojection']['median']:>7.1f}"
            f"{e['depth_median_mm']:>7.3f}{e['depth_p99_mm']:>7.2f}{e['p2s_mean_mm']:>6.2f}"
            f"{e['id_pct']:>6.2f}"
            f"{e['silhouette_pct']:>6.1f}{e['edge_px']:>8.3f}{e['sampling_mm']:>7.2f}  "
            f"{r['reference']}"
        )
    print(
        "(* default; ms: median per frame over repeats, IQR its spread, then the median ms of the "
        "render and "
        "of each effect; dz: |depth error| mm where ids agree; "
        "p2s: mean point-to-surface mm; id %: pixels whose instance differs; sil %: on "
        "silhouettes; "
        "edge px: mean silhouette displacement; gap mm: median distance from the reference surface "
        "to the cloud)"
    )
    for n in result["noise"]:
        cells = ", ".join(
            f"z {b['z_m']:.2f} m: {b['measured_mm']:.2f} vs {b['model_mm']:.2f} mm"
            for b in n["bins"]
        )
        print(f"noise {n['effect']} {n['model']}: measured σ vs model σ — {cells}")
    for p in result["placement"]:
        print(
            f"placement {p['label']:>8} ({p['cameras']} cameras): coverage {p['coverage_pct']:.2f} "
            "% in "
            f"{1e3 * p['seconds']['median']:.1f} ms (IQR {1e3 * p['seconds']['iqr']:.1f}"
            f"){' *' if p['is_default'] else ''}"
        )
    if "budget" in result:
        print(f"budget pick: {result['budget']['comment'].splitlines()[0]}")
