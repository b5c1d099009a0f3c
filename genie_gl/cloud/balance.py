"""Curating a dataset the way the paper did (§4.1.2, Table 3): class-balanced sub-sampling.

The paper drops clouds with few points, a small labelled share or background only, then
sub-samples to a budget; its synthetic set ends with the class shares of Table 3
(``PAPER``). Here a target distribution is reached by keeping, of each class, the share of
its points the target asks for:

1. :func:`plan` finds the largest total N whose target counts ``p_c · N`` the data can give
   for every class whose target share is above ``rare`` (2 %); each class keeps
   ``min(available, p_c · N)`` points (a rare class, or one with no points at all, may fall
   short: Table 3's rare classes hold 3.1 % together, so the others' shares can grow by at
   most that), scaled down to the budget if there is one; short classes are named with why.
2. The counts are spread over the chunks in proportion to what each holds (largest
   remainders, ties to the earlier chunk); a chunk left with fewer than ``min_points``
   points, or with background only, is dropped and the plan made again without it.
3. :func:`balance_chunks` draws the points of each class of each chunk with ``rng``.

Everything but the last step is arithmetic on counts; the draws come from an explicit
Generator, so the same seed gives the same points.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np

from ..errors import ConfigError, did_you_mean
from .pointcloud import PointCloud

# Table 3, synthetic column: points per class id (DESIGN.md label map)
PAPER: dict[int, int] = {
    0: 4_931_280,
    1: 254_597,
    2: 2_797_079,
    3: 4_131_134,
    4: 2_531,
    5: 5_096_091,
    6: 2_270_590,
    7: 56_680,
    8: 70_289,
    9: 239_697,
}
# Table 3, real column (the NavVis VLX 2 scans: a mobile scanner's chunks of 25 000 points)
PAPER_REAL: dict[int, int] = {
    0: 998_260,
    1: 14_303,
    2: 8_574,
    3: 8_933,
    4: 14_090,
    5: 70_972,
    6: 87_646,
    7: 1_400,
    8: 10_862,
    9: 9_955,
}
RARE = 0.02  # a class whose target share is at most this may fall short (it gives what it has)


@dataclass
class Plan:
    """What to keep: ``quota`` (chunks, classes) int64 points per chunk and class, ``keep``
    (chunks,) bool, the total ``target`` N, and ``short`` {class: reason}."""

    quota: np.ndarray
    keep: np.ndarray
    total_n: float
    short: dict[int, str] = field(default_factory=dict)


def load_target(spec: str, names: Mapping[int, str]) -> dict[int, float]:
    """A target distribution {class id: share summing to 1}: ``"paper"`` (Table 3's synthetic
    column), ``"paper-real"`` (its real column) or a JSON
    file ``{class name or id: share or points}`` (names as in ``names``; spaces and
    underscores alike)."""
    if spec in ("paper", "paper-real"):
        raw: dict = {str(k): v for k, v in (PAPER if spec == "paper" else PAPER_REAL).items()}
        source = spec
    else:
        source = spec
        try:
            raw = json.loads(Path(spec).read_text())
        except OSError as exc:
            raise ConfigError(
                f"--class-balance {spec}: cannot read the file ({exc.strerror}); "
                "expected 'paper' or a JSON file {class: share}"
            ) from None
        except json.JSONDecodeError as exc:
            raise ConfigError(f"{spec}: invalid JSON at line {exc.lineno}: {exc.msg}") from None
        if not isinstance(raw, dict) or not raw:
            raise ConfigError(
                f"{spec}: expected an object {{class name or id: share}}, got {raw!r:.60}"
            )
    norm = {n.lower().replace(" ", "_"): k for k, n in names.items()}
    out: dict[int, float] = {}
    for key, value in raw.items():
        k = str(key).strip()
        if k.isdigit():
            cid = int(k)
        elif k.lower().replace(" ", "_") in norm:
            cid = norm[k.lower().replace(" ", "_")]
        else:
            raise ConfigError(
                f"{source}: class {key!r} is not in the label map"
                f"{did_you_mean(k, list(norm))} (known: {', '.join(norm)})"
            )
        if (
            not isinstance(value, (int, float))
            or isinstance(value, bool)
            or not np.isfinite(value)
            or value < 0
        ):
            raise ConfigError(
                f"{source}: {key}: expected a share or a point count >= 0, got {value!r}"
            )
        out[cid] = out.get(cid, 0.0) + float(value)
    total = sum(out.values())
    if total <= 0:
        raise ConfigError(f"{source}: the shares sum to 0")
    return {k: v / total for k, v in sorted(out.items())}


def _largest_total(
    available: np.ndarray, p: np.ndarray, rare: float, required: np.ndarray | None = None
) -> float:
    """The largest N whose target counts p_c·N every class above the ``rare`` share can give
    (rare classes give what they have; a class without points is left out, unless it is
    ``required``: then N is 0)."""
    if required is not None and np.any(required & (p > rare) & (available == 0)):
        return 0.0
    has = (p > 0) & (available > 0)
    if not has.any():
        return 0.0
    major = has & (p > rare)
    use = major if major.any() else has
    return float(np.min(available[use] / p[use]))


def _spread(counts: np.ndarray, want: np.ndarray) -> np.ndarray:
    """Spread ``want[c]`` points of each class over the chunks in proportion to ``counts``
    (largest remainders; ties to the earlier chunk)."""
    avail = counts.sum(0)
    rate = np.divide(want, avail, out=np.zeros(len(want)), where=avail > 0)
    exact = counts * rate
    q = np.floor(exact).astype(np.int64)
    rest = want - q.sum(0)
    frac = exact - q
    for c in np.flatnonzero(rest > 0):
        order = np.lexsort((np.arange(len(frac)), -frac[:, c]))
        q[order[: rest[c]], c] += 1
    return np.minimum(q, counts)


def plan(
    counts: np.ndarray,
    target: np.ndarray | None,
    *,
    rng: np.random.Generator,
    rare: float = RARE,
    budget: int | None = None,
    min_points: int = 1,
    background: int = 0,
) -> Plan:
    """How many points of each class each chunk keeps.

    Parameters
    ----------
    counts : (chunks, classes) int, points per chunk and class id.
    target : (classes,) float shares summing to 1, or None (keep the data's own shares).
    rng : draws the chunks a budget keeps (nothing is drawn without a binding budget).
    rare : classes whose target share is at most this may fall short.
    budget : at most this many points in all. As the paper did, whole chunks are
        sub-sampled first: the fewest chunks, in a random order, whose plan reaches the
        budget, then thinned to it (not every chunk thinned, which would leave them all
        below ``min_points``).
    min_points : a chunk left with fewer is dropped (as is one left with background only).
    """
    counts = np.asarray(counts, np.int64)
    full = _plan(counts, target, rare, None, min_points, background)
    if budget is None or full.quota.sum() <= budget:
        return full
    # the chunks kept must hold every class above the rare share that the data holds
    required = full.quota.sum(0) > 0
    order = rng.permutation(len(counts))

    def prefix(k: int, cap: int | None, req: np.ndarray | None = required) -> Plan:
        sub = np.zeros(len(counts), bool)
        sub[order[:k]] = True
        return _plan(counts * sub[:, None], target, rare, cap, min_points, background, req)

    lo, hi = 1, len(counts)
    while lo < hi:  # the shortest prefix of the order whose plan reaches the budget
        mid = (lo + hi) // 2
        if prefix(mid, None).quota.sum() >= budget:
            hi = mid
        else:
            lo = mid + 1
    # thinned to the budget, some chunks may fall below min_points: take a few more chunks
    # until the thinned plan comes within 1 % of the budget (or the fullest one tried)
    best = None
    for req in (required, None):  # without the required classes only if nothing else works
        for k in sorted({*range(lo, min(len(counts), lo + 16) + 1), len(counts)}):
            cand = prefix(k, budget, req)
            if best is None or cand.quota.sum() > best.quota.sum():
                best = cand
            if best.quota.sum() >= 0.99 * budget:
                return best
        if best.quota.sum() > 0:
            return best
    return best


def _plan(
    counts: np.ndarray,
    target: np.ndarray | None,
    rare: float,
    budget: int | None,
    min_points: int,
    background: int,
    required: np.ndarray | None = None,
) -> Plan:
    n_chunks, n_cls = counts.shape
    keep = counts.sum(1) > 0
    short: dict[int, str] = {}
    first: tuple[float, np.ndarray] | None = None  # the first pass's total and points per class
    for _ in range(10):
        c = counts * keep[:, None]
        avail = c.sum(0).astype(np.float64)
        if target is None:
            want = avail.copy()
            total_n = float(avail.sum())
        else:
            p = np.asarray(target, np.float64)
            total_n = _largest_total(avail, p, rare, required)
            want = np.minimum(avail, np.floor(p * total_n + 1e-9))
            first = first or (total_n, avail)
            short = {}
            for k in np.flatnonzero((p > 0) & (avail < p * total_n - 0.5)).tolist():
                short[k] = (
                    "no points in the chunks kept"
                    if avail[k] == 0
                    else f"{int(avail[k])} points in the data, {p[k] * total_n:.0f} wanted "
                    f"({100 * avail[k] / max(total_n, 1):.2f} % of {100 * p[k]:.2f} %)"
                )
        if budget is not None and want.sum() > budget:
            want = np.floor(want * (budget / want.sum()))
        quota = _spread(c, want.astype(np.int64))
        per_chunk = quota.sum(1)
        labelled = per_chunk - quota[:, background] if background < n_cls else per_chunk
        ok = keep & (per_chunk >= max(min_points, 1)) & (labelled > 0)
        if np.array_equal(ok, keep):
            break
        keep = ok
    quota[~keep] = 0
    if first is not None and first[0] > 0 and not keep.any():  # balanced, nothing was left: say why
        total0, avail0 = first
        p = np.asarray(target, np.float64)
        use = (p > rare) & (avail0 > 0)
        lim = (
            int(np.flatnonzero(use)[np.argmin(avail0[use] / p[use])])
            if use.any()
            else int(np.argmax(p))
        )
        short[lim] = (
            f"{int(avail0[lim])} points in the data limit the balanced total to {total0:.0f} "
            f"({100 * p[lim]:.2f} % of it), too few for any chunk to keep min_points {min_points} "
            "with a labelled point: nothing kept (more scenes or cameras, or a lower --min-points)"
        )
    return Plan(quota, keep, total_n, short)


def sample(semantic: np.ndarray, quota: np.ndarray, *, rng: np.random.Generator) -> np.ndarray:
    """Indices (ascending) of ``quota[c]`` points of each class c, drawn without replacement."""
    out = []
    for c in np.flatnonzero(quota).tolist():
        idx = np.flatnonzero(semantic == c)
        n = int(quota[c])
        out.append(idx if n >= len(idx) else idx[rng.choice(len(idx), n, replace=False)])
    return np.sort(np.concatenate(out)) if out else np.zeros(0, np.int64)


def balance_chunks(
    chunks: list[tuple[tuple[int, int], PointCloud]],
    target: Mapping[int, float] | None,
    *,
    rng: np.random.Generator,
    budget: int | None = None,
    rare: float = RARE,
    min_points: int = 1,
) -> tuple[list[tuple[tuple[int, int], PointCloud]], Plan]:
    """The chunks sub-sampled towards ``target`` ({class id: share}) and capped at
    ``budget`` points, with the plan that chose them."""
    counts = _counts([t for _, t in chunks])
    p = None
    if target is not None:
        p = np.zeros(max(counts.shape[1], max(target) + 1))
        for k, v in target.items():
            p[k] = v
        counts = np.pad(counts, ((0, 0), (0, len(p) - counts.shape[1])))
    pl = plan(counts, p, rng=rng, rare=rare, budget=budget, min_points=min_points)
    return apply_plan(chunks, pl.quota, pl.keep, rng=rng), pl


def save_chunks(path: Path, chunks: list[tuple[tuple[int, int], PointCloud]], info: dict) -> None:
    """One scene's chunks, their class counts and ``info`` (JSON) in an npz (written to a
    temporary name, then renamed)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    clouds = [t for _, t in chunks]
    arrays = {
        "keys": np.array([k for k, _ in chunks], np.int64).reshape(-1, 2),
        "ends": np.cumsum([len(t) for t in clouds]).astype(np.int64),
        "counts": _counts(clouds),
        "info": np.frombuffer(json.dumps(info).encode(), np.uint8),
    }
    if clouds:
        merged = PointCloud.concatenate(clouds)
        for f in ("xyz", "semantic", "instance", "origin", "rgb", "normal", "camera"):
            if getattr(merged, f) is not None:
                arrays[f] = getattr(merged, f)
    tmp = path.with_name(path.stem + ".tmp.npz")
    np.savez(tmp, **arrays)
    tmp.replace(path)


def _counts(clouds: list[PointCloud]) -> np.ndarray:
    n = max([int(t.semantic.max(initial=0)) + 1 for t in clouds] + [len(PAPER)])
    return (
        np.stack([np.bincount(t.semantic, minlength=n) for t in clouds])
        if clouds
        else np.zeros((0, n), np.int64)
    )


def load_chunks(path: Path) -> tuple[list[tuple[tuple[int, int], PointCloud]], dict]:
    """What :func:`save_chunks` wrote: (chunks, info)."""
    with np.load(path) as z:
        info = json.loads(z["info"].tobytes().decode())
        ends = z["ends"]
        if len(ends) == 0:
            return [], info
        f = {
            k: z[k]
            for k in ("xyz", "semantic", "instance", "origin", "rgb", "normal", "camera")
            if k in z
        }
        merged = PointCloud(**f)
        starts = np.r_[0, ends[:-1]]
        return [
            ((int(k[0]), int(k[1])), merged.select(slice(a, b)))
            for k, a, b in zip(z["keys"], starts, ends)
        ], info


def plan_dataset(
    caches: list[Path],
    target: Mapping[int, float] | None,
    *,
    rng: np.random.Generator,
    budget: int | None = None,
    rare: float = RARE,
    min_points: int = 1,
) -> list[tuple[np.ndarray, np.ndarray, dict]]:
    """One :func:`plan` over every scene's chunks (read from their caches' counts, in scene
    order); returns per scene (quota, keep, report)."""
    per_scene = []
    for c in caches:
        if not Path(c).is_file():
            raise ConfigError(
                f"{c}: the unbalanced chunks of this scene are gone, and balancing needs every "
                "scene's; make the dataset again into an empty folder"
            )
        with np.load(c) as z:
            per_scene.append(z["counts"])
    n_cls = max([m.shape[1] for m in per_scene] + [max(target or {0: 0}) + 1])
    counts = np.concatenate([np.pad(m, ((0, 0), (0, n_cls - m.shape[1]))) for m in per_scene])
    p = None
    if target is not None:
        p = np.zeros(n_cls)
        for k, v in target.items():
            p[k] = v
    pl = plan(counts, p, rng=rng, rare=rare, budget=budget, min_points=min_points)
    out, a = [], 0
    short = {str(c): r for c, r in pl.short.items()}
    for m in per_scene:
        b = a + len(m)
        q, k = pl.quota[a:b], pl.keep[a:b]
        out.append(
            (
                q,
                k,
                {
                    "before": {str(c): int(v) for c, v in enumerate(counts[a:b].sum(0)) if v},
                    "after": {str(c): int(v) for c, v in enumerate(q.sum(0)) if v},
                    "chunks_dropped": int((~k).sum()),
                    "short": short,
                },
            )
        )
        a = b
    return out


def apply_plan(
    chunks: list[tuple[tuple[int, int], PointCloud]],
    quota: np.ndarray,
    keep: np.ndarray,
    *,
    rng: np.random.Generator,
) -> list[tuple[tuple[int, int], PointCloud]]:
    """The kept chunks, each sub-sampled to its row of ``quota`` (drawn with ``rng``)."""
    return [
        (key, tile.select(sample(tile.semantic, q, rng=rng)))
        for (key, tile), q, k in zip(chunks, quota, keep)
        if k
    ]


def summary(
    class_points: Mapping[int, int],
    target: Mapping[int, float] | None,
    short: Mapping[str, str],
    names: Mapping[int, str],
) -> dict:
    """Reached next to target, per class name, and the classes that fell short, and why."""
    total = sum(class_points.values()) or 1
    ids = sorted(set(class_points) | set(target or {}))
    rows = {}
    for k in ids:
        rows[names.get(k, f"class_{k}")] = {
            "points": int(class_points.get(k, 0)),
            "reached_pct": round(100 * class_points.get(k, 0) / total, 3),
            "target_pct": None if target is None else round(100 * target.get(k, 0.0), 3),
        }
    reasons = {names.get(int(k), f"class_{k}"): why for k, why in short.items()}
    return {"classes": rows, "short": reasons, "points": int(sum(class_points.values()))}
