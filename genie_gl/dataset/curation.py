"""``genie dataset --class-balance paper|FILE --points-budget N``: the dataset's curation.

The paper curated its synthetic set (§4.1.2, Table 3): clouds with few points, a small
labelled share or background only dropped, then a sub-sample to a budget, ending with the
class shares of Table 3. A dataset run asks for the same with these hooks: each scene keeps
its unbalanced chunks in ``DIR/.balance/NNNNNN.npz``; once every scene is made, one plan over
all of them (:mod:`.cloud.balance`) says what each chunk keeps, and each scene is sub-sampled
with its own generator and written whole (its file record and ``stats.json`` first, then
renamed into place, as every dataset scene is). Scene order, never worker count, decides:
the same seed gives the same bytes whatever ``--workers``. The options are fields of
:class:`~genie_gl.dataset.DatasetConfig` (``class_balance``, ``points_budget``, the target
read where the configuration is checked), both fingerprinted, so a resume with other ones is
refused.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from ..cloud.balance import apply_plan, load_chunks, plan_dataset, save_chunks, summary
from ..export import SceneData, get_format
from ..labels import CLASSES
from ..layout import Layout
from ..outputs import publish_folder
from .manifest import RECORD, record_files, recorded_files, scene_complete
from .streams import SceneStreams

BALANCE_SEED = 0x62616C616E6365  # "balance": the dataset's generator for the chunks a budget keeps


def active(cfg) -> bool:
    return bool(cfg.class_balance or cfg.points_budget)


def target(cfg) -> dict[int, float] | None:
    t = cfg.class_balance
    return None if not t else {int(k): v for k, v in t["target"].items()}


def cache_path(cfg, index: int) -> Path:
    return Path(cfg.out) / ".balance" / f"{index:06d}.npz"


def cache_scene(cfg, index: int, kept: list, layout, info: dict) -> dict[str, Any]:
    """Keep scene ``index``'s unbalanced chunks, its layout and ``info`` (instances, cameras,
    points_total) until every scene is made; the scene's result, pending."""
    save_chunks(cache_path(cfg, index), kept, {"layout": layout.to_dict(), **info})
    return {"scene": index, "pending": True}


def finish(cfg, *, verify: bool = False) -> list[int]:
    """One plan over every scene's chunks, then each scene not complete yet sub-sampled with
    its own stream (:class:`~.streams.SceneStreams` ``balance``), written into a
    temporary folder with its file record and renamed into place; returns the scenes written."""
    out, fmt = Path(cfg.out), get_format(cfg.format)
    for stale in (out / ".balance").glob("*.tmp.npz"):  # a cache a killed run left half-written
        stale.unlink()
    todo = [
        i for i in range(cfg.scenes) if scene_complete(fmt.scene_dir(out, i), verify=verify) is None
    ]
    if not todo:  # a re-run of a finished dataset needs no plan (nor the caches)
        return []
    caches = [cache_path(cfg, i) for i in range(cfg.scenes)]
    rng = np.random.default_rng(np.random.SeedSequence([int(cfg.seed), BALANCE_SEED]))
    plans = plan_dataset(
        caches, target(cfg), rng=rng, budget=cfg.points_budget, min_points=cfg.min_points
    )
    written = []
    for i, (cache, (quota, keep, report)) in enumerate(zip(caches, plans)):
        if i not in todo:
            continue
        final = fmt.scene_dir(out, i)
        chunks, info = load_chunks(cache)
        kept = apply_plan(chunks, quota, keep, rng=SceneStreams(cfg.seed, i).rng("balance"))
        layout = Layout.from_dict(info.pop("layout"))
        for stale in final.parent.glob(f".tmp-{final.name}-*"):
            shutil.rmtree(stale, ignore_errors=True)
        tmp = final.parent / f".tmp-{final.name}-{os.getpid()}"
        tmp.mkdir(parents=True)
        data = SceneData(i, None, layout, [], kept, cfg)
        fmt.write_scene(data, tmp)
        layout.to_json(tmp / "layout.json")
        counts = np.zeros(65536, np.int64)
        for _, tile in kept:
            np.add.at(counts, tile.semantic, 1)
        stats = {
            "scene": i,
            **info,
            "chunks": len(kept),
            "class_points": {str(k): int(v) for k, v in enumerate(counts) if v},
            "balance": report,
        }
        stats["files"] = record_files(tmp)
        (tmp / RECORD).write_text(json.dumps(stats, indent=1, sort_keys=True))
        if fmt.before_rename is not None:
            fmt.before_rename(data, out)
        # the scene appears whole, or not at all; an incomplete one of an earlier run has its own
        # files replaced, the user's kept
        publish_folder(tmp, final, previous=recorded_files(final), record=RECORD)
        written.append(i)
    return written


def short(stats: list[dict]) -> dict[str, str] | None:
    """The classes that fell short of their target, and why (the same for every scene)."""
    return stats[0].get("balance", {}).get("short") if stats else None


def manifest(cfg, stats: list[dict]) -> dict[str, Any]:
    """The manifest's ``class_balance`` entry: reached next to target, short classes."""
    if not active(cfg):
        return {}
    points: dict[int, int] = {}
    for st in stats:
        for k, v in st["class_points"].items():
            points[int(k)] = points.get(int(k), 0) + v
    entry = summary(points, target(cfg), short(stats) or {}, CLASSES)
    entry["draws"] = (
        f"chunks a budget keeps: SeedSequence([seed, {BALANCE_SEED:#x}]); points: "
        f"{SceneStreams.describe()['balance']}"
    )
    return {"class_balance": entry}
