"""``genie dataset --class-balance paper|FILE --points-budget N``: the dataset's curation.

The paper curated its synthetic set (§4.1.2, Table 3): clouds with few points, a small
labelled share or background only dropped, then a sub-sample to a budget, ending with the
class shares of Table 3. A dataset run asks for the same with these hooks: each scene keeps
its unbalanced chunks in ``DIR/.balance/NNNNNN.npz``; once every scene is made, one plan over
all of them (:mod:`.cloud.balance`) says what each chunk keeps, and each scene is sub-sampled
with its own generator and written whole. Scene order, never worker count, decides: the
same seed gives the same bytes whatever ``--workers``.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .errors import ConfigError

BALANCE_SEED = 0x62616C616E6365  # "balance": the dataset's generator for the chunks a budget keeps


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--class-balance", default=None, metavar="paper|FILE",
                   help="sub-sample chunks and points towards a class distribution: 'paper' (Table 3's "
                        "synthetic column) or a JSON file {class: share}")
    p.add_argument("--points-budget", type=int, default=None, metavar="N", help="at most N points in the dataset")


def config(args: argparse.Namespace, names: dict[int, str]) -> dict[str, Any]:
    """The curation entries of the dataset's config (none when not asked for)."""
    from .cloud.balance import load_target

    spec, budget = getattr(args, "class_balance", None), getattr(args, "points_budget", None)
    if not spec and budget is None:
        return {}
    if args.format == "bop":
        raise ConfigError("--class-balance and --points-budget sub-sample point clouds; --format bop writes "
                          "images: use a point-cloud format")
    if budget is not None and budget < 1:
        raise ConfigError(f"--points-budget {budget}: expected a number of points >= 1")
    out: dict[str, Any] = {}
    if spec:
        out["class_balance"] = {"name": spec, "target": {str(k): v for k, v in load_target(spec, names).items()}}
    if budget is not None:
        out["points_budget"] = int(budget)
    return out


def active(cfg: dict[str, Any]) -> bool:
    return bool(cfg.get("class_balance") or cfg.get("points_budget"))


def target(cfg: dict[str, Any]) -> dict[int, float] | None:
    t = cfg.get("class_balance")
    return None if not t else {int(k): v for k, v in t["target"].items()}


def cache_path(cfg: dict[str, Any], index: int) -> Path:
    return Path(cfg["out"]) / ".balance" / f"{index:06d}.npz"


def cache_scene(cfg: dict[str, Any], index: int, kept: list, layout, info: dict) -> dict[str, Any]:
    """Keep scene ``index``'s unbalanced chunks, its layout and ``info`` (instances, cameras,
    points_total) until every scene is made."""
    from .cloud.balance import save_chunks

    save_chunks(cache_path(cfg, index), kept, {"layout": layout.to_dict(), **info})
    return {"scene": index, "pending": True}


def finish(cfg: dict[str, Any], scene_dir: Callable[[int], Path],
           write_chunks: Callable[[dict, Path, list], np.ndarray]) -> None:
    """One plan over every scene's chunks, then each scene not written yet sub-sampled with
    its sixth generator (``SeedSequence([seed, index]).spawn(6)[5]``) and written whole."""
    from .cloud.balance import apply_plan, load_chunks, plan_dataset
    from .layout import Layout

    caches = [cache_path(cfg, i) for i in range(cfg["scenes"])]
    rng = np.random.default_rng(np.random.SeedSequence([int(cfg["seed"]), BALANCE_SEED]))
    plans = plan_dataset(caches, target(cfg), rng=rng, budget=cfg.get("points_budget"), min_points=cfg["min_points"])
    for i, (cache, (quota, keep, report)) in enumerate(zip(caches, plans)):
        final = scene_dir(i)
        if final.exists():
            continue
        chunks, info = load_chunks(cache)
        kept = apply_plan(chunks, quota, keep,
                          rng=np.random.default_rng(np.random.SeedSequence([int(cfg["seed"]), i]).spawn(6)[5]))
        tmp = final.parent / f".tmp-{final.name}-{os.getpid()}"
        shutil.rmtree(tmp, ignore_errors=True)
        tmp.mkdir(parents=True)
        counts = write_chunks(cfg, tmp, kept)
        Layout.from_dict(info.pop("layout")).to_json(tmp / "layout.json")
        stats = {"scene": i, **info, "chunks": len(kept),
                 "class_points": {str(k): int(v) for k, v in enumerate(counts) if v}, "balance": report}
        (tmp / "stats.json").write_text(json.dumps(stats, indent=1, sort_keys=True))
        tmp.replace(final)  # the scene appears whole, or not at all


def short(stats: list[dict]) -> dict[str, str] | None:
    """The classes that fell short of their target, and why (the same for every scene)."""
    return stats[0].get("balance", {}).get("short") if stats else None


def manifest(cfg: dict[str, Any], stats: list[dict], names: dict[int, str]) -> dict[str, Any]:
    """The manifest's ``class_balance`` entry: reached next to target, short classes."""
    from .cloud.balance import summary

    if not active(cfg):
        return {}
    points: dict[int, int] = {}
    for st in stats:
        for k, v in st["class_points"].items():
            points[int(k)] = points.get(int(k), 0) + v
    entry = summary(points, target(cfg), short(stats) or {}, names)
    entry["draws"] = (f"chunks a budget keeps: SeedSequence([seed, {BALANCE_SEED:#x}]); points: "
                      "SeedSequence([seed, scene index]).spawn(6)[5]")
    return {"class_balance": entry}
