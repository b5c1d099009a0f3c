"""Tables and pictures of the studies and presets (markdown into ``OUT/<study>.md``, PNGs beside
it). Every cell is mean ± std over the seeds; a difference is given with its spread and called a
gain or a loss only when it exceeds it (:func:`genie_gl.eval.metrics.compare`)."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

from ..eval import protocols
from ..eval.metrics import Spread, delta_text
from ..eval.plots import curve_png, delta_bars_png, iou_bars_png, matrix_png
from ..eval.report import table
from ..labels import CLASSES
from ..outputs import atomic_write_text
from . import datasets as ds
from .costs import cost_text
from .datasets import PROFILE, SENSORS, STRATEGIES, data_cost


def spread(d: dict) -> Spread:
    return Spread(d["mean"], d["std"], d["min"], d["max"], tuple(d.get("values", ())))


def _test(metrics: dict, index: int = 0) -> dict:
    return metrics["tests"][index]


def _summary_spreads(t: dict) -> dict:
    """A test's summary with Spreads keyed by class id (for the bar plots)."""
    ids = {v: k for k, v in CLASSES.items()}
    s = t["summary"]
    return {
        "miou": spread(s["miou"]),
        "macc": spread(s["macc"]),
        "iou": {ids.get(n, i + 100): spread(v) for i, (n, v) in enumerate(s["iou"].items())},
        "acc": {ids.get(n, i + 100): spread(v) for i, (n, v) in enumerate(s["acc"].items())},
    }


def _reproduce(c: Any, command: str) -> str:
    """``command`` with the sizes of this run that are not the defaults (``--seeds``,
    ``--scenes``, ``--test-scenes``, ``--cameras``) before its ``--out``."""
    extra = []
    if tuple(c.seeds) != (0, 1, 2):
        extra.append(f"--seeds {','.join(map(str, c.seeds))}")
    for option, value, default in (
        ("--scenes", c.scenes, ds.SCENES),
        ("--test-scenes", c.test_scenes, ds.TEST_SCENES),
        ("--cameras", c.cameras, ds.CAMERAS),
    ):
        if value != default:
            extra.append(f"{option} {value}")
    if not extra:
        return command
    head, sep, tail = command.partition(" --out")
    return f"{head} {' '.join(extra)}{sep}{tail}"


def _header(title: str, c: Any, command: str) -> str:
    load = os.getloadavg()
    command = _reproduce(c, command)
    return (
        f"## {title}\n\nMeasured {time.strftime('%Y-%m-%d')}, load average {load[0]:.1f} (2 "
        "cores), "
        f"seeds {', '.join(map(str, c.seeds))}; {c.scenes} training scenes and {c.test_scenes} "
        "held-out "
        f"test scenes (another seed) of {c.cameras} cameras per condition. Reproduce: `{command}"
        "`.\n\n"
    )


def strategy_study(c: Any, results: dict) -> str:
    rows, bars = [], {}
    for held in STRATEGIES:
        cross = _test(results[f"strategy-classical-to-{held}"][1])
        base = {
            m: spread(_test(results[f"strategy-{m}-to-{held}"][1])["summary"]["miou"])
            for m in ("height", "majority")
        }
        own = spread(_test(results[f"strategy-classical-in-{held}"][1])["summary"]["miou"])
        mc = spread(cross["summary"]["miou"])
        others = " + ".join(s for s in STRATEGIES if s != held)
        rows.append(
            [
                held,
                others,
                mc.text(),
                base["height"].text(),
                base["majority"].text(),
                delta_text(mc, base["height"]),
                own.text(),
                delta_text(mc, own),
                ", ".join(cross["unseen_classes"]) or "—",
            ]
        )
        bars[f"{held} (held out)"] = _summary_spreads(cross)
    md = _header(
        "Strategy transfer: train on two strategies, test on the third",
        c,
        "genie eval --study strategy --out out/studies --yes",
    )
    md += table(
        [
            "test strategy (held out)",
            "trained on",
            "classical mIoU",
            "height only",
            "majority",
            "classical − height",
            "trained on the test strategy itself",
            "transfer − own",
            "never seen",
        ],
        rows,
    )
    pics = []
    for held in STRATEGIES:
        cross = _test(results[f"strategy-classical-to-{held}"][1])
        summ = {
            "classical": _summary_spreads(cross),
            "height only": _summary_spreads(_test(results[f"strategy-height-to-{held}"][1])),
            "majority": _summary_spreads(_test(results[f"strategy-majority-to-{held}"][1])),
        }
        names = {k: v for k, v in CLASSES.items()}
        p = iou_bars_png(
            summ,
            names,
            c.out / f"strategy-{held}.iou.png",
            title=f"IoU per class on held-out {held} (trained on the other two)",
        )
        pics.append(p.name)
    md += "\n" + "\n".join(f"![{p}]({p})" for p in pics) + "\n"
    # per-class table of the classical cross-strategy runs
    classes = sorted(
        {
            n
            for b in results.values()
            if b[0].name.startswith("strategy-classical-to")
            for n in _test(b[1])["summary"]["iou"]
        },
        key=lambda n: {v: k for k, v in CLASSES.items()}.get(n, 99),
    )
    rows2 = []
    for held in STRATEGIES:
        s = _test(results[f"strategy-classical-to-{held}"][1])["summary"]["iou"]
        rows2.append([held, *(spread(s[n]).text(2) if n in s else "—" for n in classes)])
    md += "\nIoU per class (classical, held-out strategy):\n\n" + table(
        ["test strategy", *classes], rows2
    )
    return md


def sensor_study(c: Any, results: dict) -> str:
    cells = [
        [
            spread(_test(results[f"sensor-{tr}"][1], j)["summary"]["miou"])
            for j in range(len(SENSORS))
        ]
        for tr in SENSORS
    ]
    md = _header(
        "Sensor transfer: train on one sensor's data, test on each (assembly line)",
        c,
        "genie eval --study sensor --out out/studies --yes",
    )
    md += table(
        ["trained on \\ tested on", *SENSORS],
        [[tr, *(x.text() for x in row)] for tr, row in zip(SENSORS, cells)],
    )
    p = matrix_png(
        cells, SENSORS, SENSORS, c.out / "sensor-transfer.png", title="mIoU, classical model"
    )
    md += f"\n![sensor transfer]({p.name})\n"
    return md


def _costs(c: Any) -> tuple[dict | None, str]:
    """The dedicated timing run (``OUT/costs.json`` of ``--study costs``) and the cost column's
    heading; without one, the training dataset's own per-frame milliseconds, said so."""
    timed = c.out / "costs.json"
    if timed.is_file():
        r = json.loads(timed.read_text())
        head = (
            f"its cost, ms per frame (timed alone, {r['date']}, load {r['load_before']:.1f}"
            f"-{r['load_after']:.1f}: "
            "costs.md)"
        )
        return r, head
    return (
        None,
        "its cost, ms per frame (the dataset run's manifest: no costs.json; run --study costs)",
    )


def accuracy_study(c: Any, results: dict) -> str:
    on = spread(_test(results[f"sensor-{PROFILE}"][1], 1)["summary"]["miou"])
    timed, head = _costs(c)
    cost = data_cost(c.train("assembly_line", PROFILE), c.cache).get("capture", {})
    rows, labels, deltas, costs = [], [], [], []
    for e in ds.profile_effects(PROFILE):
        off = spread(_test(results[f"accuracy-no-{e}"][1])["summary"]["miou"])
        if timed is not None:
            entry = timed["effects"].get(e)
            ms = entry["ms_per_frame"] if entry and entry["ran_frames"] else None
            cell = cost_text(entry)
        else:
            ms = cost.get(f"effect:{e}", {}).get("per_frame_ms")
            cell = f"{ms:.1f}" if ms is not None else "—"
        d = on.mean - off.mean
        rows.append([e, off.text(), on.text(), delta_text(on, off), cell])
        labels.append(e)
        deltas.append((d, on.std + off.std))
        costs.append(ms)
    ideal = spread(_test(results["sensor-ideal_pinhole"][1], 1)["summary"]["miou"])
    if timed is not None:
        total = timed["(full profile)"] - timed["(ideal render)"]
    else:
        total = sum(v.get("per_frame_ms", 0.0) for k, v in cost.items() if k.startswith("effect:"))
    rows.append(
        [
            "every effect (ideal sensor)",
            ideal.text(),
            on.text(),
            delta_text(on, ideal),
            f"{total:.1f}",
        ]
    )
    md = _header(
        f"What accuracy buys: each {PROFILE} effect off and on, tested on full-profile data",
        c,
        "genie eval --study accuracy --out out/studies --yes",
    )
    md += table(
        [
            "effect",
            "mIoU trained without it",
            "mIoU trained with it (full profile)",
            "Δ (on − off)",
            head,
        ],
        rows,
    )
    p = delta_bars_png(
        labels + ["all (ideal)"],
        deltas + [(on.mean - ideal.mean, on.std + ideal.std)],
        costs + [total],
        c.out / "accuracy-buys.png",
        title=f"ΔmIoU of training with each {PROFILE} effect, beside its cost",
    )
    md += f"\n![what accuracy buys]({p.name})\n"
    return md


def balance_study(c: Any, results: dict) -> str:
    nat = _test(results[f"sensor-{PROFILE}"][1], 1)
    bal = _test(results["balance-paper"][1])
    a, b = spread(nat["summary"]["miou"]), spread(bal["summary"]["miou"])
    rows = [
        [
            "natural",
            f"{results[f'sensor-{PROFILE}'][1]['n_train_points']:,}",
            a.text(),
            spread(nat["summary"]["macc"]).text(),
            "—",
        ],
        [
            "--class-balance paper",
            f"{results['balance-paper'][1]['n_train_points']:,}",
            b.text(),
            spread(bal["summary"]["macc"]).text(),
            delta_text(b, a),
        ],
    ]
    md = _header(
        "Class balance: --class-balance paper against the natural distribution",
        c,
        "genie eval --study balance --out out/studies --yes",
    )
    md += table(["training data", "points", "mIoU", "mAcc", "Δ mIoU vs natural"], rows)
    p = iou_bars_png(
        {"natural": _summary_spreads(nat), "paper balance": _summary_spreads(bal)},
        CLASSES,
        c.out / "balance.iou.png",
        title="IoU per class: natural against paper-balanced training data",
    )
    md += f"\n![class balance]({p.name})\n"
    return md


def models_study(c: Any, results: dict) -> str:
    cl = _test(results[f"sensor-{PROFILE}"][1], 1)
    a = spread(cl["summary"]["miou"])
    rows = [
        [
            "classical (LightGBM)",
            a.text(),
            spread(cl["summary"]["macc"]).text(),
            spread(cl["summary"]["oa"]).text(),
            "—",
        ]
    ]
    bars = {"classical": _summary_spreads(cl)}
    for key, label in (("models-randla", "RandLA-Net"),):
        ne = _test(results[key][1])
        b = spread(ne["summary"]["miou"])
        rows.append(
            [
                label,
                b.text(),
                spread(ne["summary"]["macc"]).text(),
                spread(ne["summary"]["oa"]).text(),
                delta_text(b, a),
            ]
        )
        bars[label] = _summary_spreads(ne)
    md = _header(
        "RandLA-Net against classical on the same split (assembly line, D435)",
        c,
        "genie eval --study models --out out/studies --yes",
    )
    md += table(["model", "mIoU", "mAcc", "OA", "model − classical"], rows)
    p = iou_bars_png(
        bars,
        CLASSES,
        c.out / "models.iou.png",
        title="IoU per class: classical against RandLA-Net",
    )
    md += f"\n![models]({p.name})\n"
    return md


def mix_study(c: Any, target_train: Any, target_test: Any, synthetic: list) -> str:
    folders = [
        ds.ensure(d, c.cache, workers=c.workers, progress=c.progress)
        for d in [target_train, target_test, *synthetic]
    ]
    res = protocols.mix(
        str(folders[0]),
        str(folders[1]),
        [str(f) for f in folders[2:]],
        out=c.out / "runs" / "mix",
        seeds=c.seeds,
        workers=c.workers,
        cache=c.cache / "features",
        progress=c.progress,
    )
    md = _header(
        f"The mix preset (Experiment 1) on the stand-in target: {target_train.strategy} seen by "
        f"{target_train.sensor} ({target_train.scenes} training scenes, {target_test.scenes} test "
        "scenes); "
        f"synthetic: {' + '.join(s.strategy for s in synthetic)} with {synthetic[0].sensor}",
        c,
        "genie eval --study mix --out out/studies --yes",
    )
    return md + preset_table("mix", res, c.out)


def preset_table(preset: str, res: dict, out: Path) -> str:
    if preset == "finetune":
        rows = [
            [k, spread_of(v, "miou").text(), spread_of(v, "macc").text()] for k, v in res.items()
        ]
        base = spread_of(res["target only"], "miou")
        for r, (k, v) in zip(rows, res.items()):
            r.append("—" if k == "target only" else delta_text(spread_of(v, "miou"), base))
        return table(["training", "mIoU", "mAcc", "Δ mIoU vs target only"], rows)
    ratios, curve = res["ratios"], res["summary"]
    base = curve["mIoU"][0]
    rows = []
    for r, mi, ma, runs in zip(ratios, curve["mIoU"], curve["mAcc"], res["results"].values()):
        rows.append(
            [
                f"{r:.0%}",
                f"{runs[0].n_train_points:,}",
                mi.text(),
                ma.text(),
                "—" if r == 0 else delta_text(mi, base),
            ]
        )
    p = curve_png(
        [100 * r for r in ratios],
        curve,
        out / f"{preset}-curve.png",
        title=f"{preset}: mIoU and mAcc on the target's test scenes (± std over seeds)",
        ylabel="score",
    )
    return (
        table(
            ["synthetic share", "training points (seed 0)", "mIoU", "mAcc", "Δ mIoU vs 0 %"], rows
        )
        + f"\n![{preset} curve]({p.name})\n"
    )


def spread_of(result: Any, metric: str) -> Spread:
    return result.tests[0].summary[metric]


def preset_markdown(preset: str, res: Any, out: Path) -> str:
    text = f"## {preset}\n\n" + preset_table(preset, res, out)
    atomic_write_text(out / f"{preset}.md", text)
    return text
