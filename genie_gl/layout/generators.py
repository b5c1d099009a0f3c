"""Region generators: split a parent region into labelled child rectangles ("slots").

A generator is a class with ``generate(parent, *, rng) -> list[Child]``; its constructor takes
the strategy's ``args``. Register a new one with one line::

    @register("my_generator")
    class MyGenerator(Generator): ...

The strategy maps each slot a generator produces (``cell``, ``line``, ``path`` …) to a
region-type provider. Sizes are metres; a child's orientation is decided by the strategy's
orientation provider (generators suggest one: the direction of a line, the parent's own).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..errors import ConfigError, did_you_mean
from .model import ORIENTATIONS, Region

EPS = 1e-9
#: what a region made by the per-region loop (:meth:`Generator.generate`) costs, in regions'
#: worth of the engine's array path: ~60 us against ~1.7 us a region (``genie bench layout``,
#: R=20 L=4, strips_per_region against strips)
LOOP_COST = 30.0


@dataclass(frozen=True)
class Child:
    """A rectangle a generator made, with its slot name and suggested orientation."""

    x: float
    y: float
    w: float
    h: float
    slot: str
    orientation: str | None = None


@dataclass(frozen=True, eq=False)
class Parents:
    """The regions of one type that a level expands, as arrays (x, y, w, h float64; orient
    int8 index into ORIENTATIONS), in breadth-first order."""

    x: np.ndarray
    y: np.ndarray
    w: np.ndarray
    h: np.ndarray
    orient: np.ndarray
    type: str

    def __len__(self) -> int:
        return len(self.x)

    def region(self, i: int) -> Region:
        return Region(
            float(self.x[i]),
            float(self.y[i]),
            float(self.w[i]),
            float(self.h[i]),
            self.type,
            ORIENTATIONS[self.orient[i]],
        )


@dataclass(frozen=True, eq=False)
class Children:
    """What a generator made for a batch of parents, as arrays grouped by parent (ascending):
    parent (index into the batch), x, y, w, h, slot (index into the generator's ``slots``),
    orient (suggested orientation, index into ORIENTATIONS, -1 for none), and generator
    reports as (parent, dict) pairs."""

    parent: np.ndarray
    x: np.ndarray
    y: np.ndarray
    w: np.ndarray
    h: np.ndarray
    slot: np.ndarray
    orient: np.ndarray
    reports: list[tuple[int, dict]]

    def __len__(self) -> int:
        return len(self.parent)


class Generator:
    """Base class: ``slots`` lists the slot names the generator can produce.

    Implement ``generate(parent, rng) -> list[Child]`` for one region; the engine calls
    ``generate_batch(parents, *, rng) -> Children`` once per level and region type, which by
    default loops over ``generate``. A generator that splits many regions the same way can
    override ``generate_batch`` with array code (the benchmark's does): the tree then grows a
    level at a time without a Python object per node.
    """

    slots: ClassVar[tuple[str, ...]] = ()
    # the argument names it reads; None: any (a strategy naming another one is refused)
    arguments: ClassVar[tuple[str, ...] | None] = None

    def __init__(self, **args: Any) -> None:
        self.args = args

    def generate(self, parent: Region, *, rng: np.random.Generator) -> list[Child]:
        raise NotImplementedError

    def generate_batch(self, parents: Parents, *, rng: np.random.Generator) -> Children:
        slot_index = {s: k for k, s in enumerate(self.slots)}
        rows: list[tuple] = []
        reports: list[tuple[int, dict]] = []
        for i in range(len(parents)):
            self.report = None
            for c in self.generate(parents.region(i), rng=rng):
                rows.append(
                    (
                        i,
                        c.x,
                        c.y,
                        c.w,
                        c.h,
                        slot_index[c.slot],
                        -1 if c.orientation is None else ORIENTATIONS.index(c.orientation),
                    )
                )
            if self.report:
                reports.append((i, self.report))
        cols = list(zip(*rows)) if rows else [()] * 7
        dtypes = (np.int64, np.float64, np.float64, np.float64, np.float64, np.int32, np.int8)
        return Children(*(np.array(c, dt) for c, dt in zip(cols, dtypes)), reports)

    def check(self, where: str) -> None:
        """Validate arguments; raise ConfigError naming ``where`` (file and JSON path)."""

    def check_fits(self, width: float, height: float, where: str) -> None:
        """Raise ConfigError naming ``where`` when what the arguments ask for cannot fit a
        parent of ``width`` x ``height`` metres (checked on the strategy's root)."""

    def max_children(self, w: float, h: float, parents: float, area: float) -> float:
        """An upper bound on the children this generator makes for ``parents`` regions, each
        at most ``w`` x ``h`` m, together covering at most ``area`` m² (the limits' estimate,
        :func:`~genie_gl.layout.estimate.layout_estimate`). The default, for a generator that
        does not say: as a grid of 4 m cells would."""
        return parents * (max(w, h) / 4.0 + 1) ** 2

    def work(self, w: float, h: float, parents: float) -> float:
        """Work beyond the children made, in regions' worth (overlap tests, walk steps / 10):
        0 unless the generator says."""
        return 0.0

    def child_cost(self) -> float:
        """What one child costs to make, in regions' worth: 1 with array code
        (``generate_batch``), :data:`LOOP_COST` through the per-region loop (``generate``)."""
        return 1.0 if type(self).generate_batch is not Generator.generate_batch else LOOP_COST

    def always_splits(self, slots: set[str]) -> bool:
        """True when every parent gets at least one child in one of ``slots`` (the slots the
        strategy gives a type), whatever its size and the draw: the parent is then no leaf
        any more (the estimate's bound). False unless the generator says."""
        return False


GENERATORS: dict[str, type[Generator]] = {}


def register(name: str):
    """Class decorator adding a generator to the registry under ``name``."""

    def wrap(cls: type[Generator]) -> type[Generator]:
        GENERATORS[name] = cls
        return cls

    return wrap


def get_generator(name: str, where: str) -> type[Generator]:
    try:
        return GENERATORS[name]
    except KeyError:
        raise ConfigError(
            f"{where}: unknown generator {name!r}{did_you_mean(name, GENERATORS)} "
            f"(known: {', '.join(sorted(GENERATORS))})"
        ) from None


def _range(
    value: Any, where: str, name: str, positive: bool = True, whole: bool = False
) -> tuple[float, float]:
    lo, hi = (value, value) if np.isscalar(value) else tuple(value)
    if any(
        isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)
        for v in (lo, hi)
    ):
        raise ConfigError(
            f"{where}.{name}: expected {'whole numbers' if whole else 'finite numbers'} or a range "
            f"[min, max] of them, got {value!r}"
        )
    if whole and (float(lo) != int(lo) or float(hi) != int(hi)):
        raise ConfigError(f"{where}.{name}: expected whole numbers, got {value!r}")
    if positive and (lo <= 0 or hi < lo):
        raise ConfigError(
            f"{where}.{name}: expected a positive size or a range [min, max] with "
            f"0 < min <= max, got {value!r}"
        )
    if not positive and (lo < 0 or hi < lo):
        raise ConfigError(
            f"{where}.{name}: expected a value >= 0 or a range [min, max], got {value!r}"
        )
    return float(lo), float(hi)


def _number(
    args: dict,
    key: str,
    default: float,
    where: str,
    *,
    lo: float = 0.0,
    lo_open: bool = False,
    whole: bool = False,
) -> float:
    """A generator argument that is one finite number (>= lo, or > lo), whole where it counts."""
    v = args.get(key, default)
    ok = (
        not isinstance(v, bool)
        and isinstance(v, (int, float))
        and math.isfinite(v)
        and (v > lo if lo_open else v >= lo)
    )
    if not ok or (whole and float(v) != int(v)):
        kind = "a whole number" if whole else "a finite number"
        raise ConfigError(
            f"{where}.args.{key}: expected {kind} {'>' if lo_open else '>='} {lo:g}, got {v!r:.40}"
        )
    return float(v)


def _draw(r: tuple[float, float], *, rng: np.random.Generator) -> float:
    return r[0] if r[0] == r[1] else float(rng.uniform(r[0], r[1]))


def _along(parent: Region) -> bool:
    """True when the parent's orientation runs along x (left/right)."""
    return parent.orientation in ("left", "right")


@register("grid")
class Grid(Generator):
    """Cells of ``cell: [w, h]`` (w across, h along the parent's orientation), ``spacing``
    between cells and an ``aisle`` every ``aisle_every`` rows; the leftover is an ``empty``
    region (``leftover: "empty"``) or spread between cells (``"spread"``)."""

    slots = ("cell", "empty")
    arguments = ("aisle", "aisle_every", "cell", "leftover", "spacing")

    def check(self, where: str) -> None:
        cell = self.args.get("cell")
        if (
            not isinstance(cell, (list, tuple))
            or len(cell) != 2
            or not all(
                not isinstance(c, bool)
                and isinstance(c, (int, float))
                and math.isfinite(c)
                and c > 0
                for c in cell
            )
        ):
            raise ConfigError(
                f"{where}.args.cell: expected [width, height], finite numbers > 0 in metres, "
                f"got {cell!r}"
            )
        for k in ("spacing", "aisle"):
            _number(self.args, k, 0.0, where)
        _number(self.args, "aisle_every", 0, where, whole=True)
        if self.args.get("leftover", "empty") not in ("empty", "spread"):
            raise ConfigError(
                f"{where}.args.leftover: expected 'empty' or 'spread', got "
                f"{self.args['leftover']!r}"
            )

    def check_fits(self, width: float, height: float, where: str) -> None:
        cell = self.args.get("cell")
        if isinstance(cell, list) and len(cell) == 2:
            cw, ch = sorted(float(c) for c in cell)
            if ch > max(width, height) or cw > min(width, height):
                raise ConfigError(
                    f"{where}.args.cell: a {cell[0]} x {cell[1]} m cell is larger than its parent "
                    f"({width} x {height} m)"
                )

    def _per_parent(self, w: float, h: float) -> float:
        cw, ch = map(float, self.args["cell"])
        sp = float(self.args.get("spacing", 0.0))
        # cells across times rows along (aisles only remove rows), either way round, plus 2
        # leftovers
        fit = lambda a, c: math.floor((a + sp + EPS) / (c + sp))  # noqa: E731
        return max(fit(w, cw) * fit(h, ch), fit(h, cw) * fit(w, ch)) + 2

    def max_children(self, w: float, h: float, parents: float, area: float) -> float:
        cw, ch = map(float, self.args["cell"])
        # cells never overlap: no more than the parents' area holds, plus two leftovers each
        return min(parents * self._per_parent(w, h), area * (1 + 1e-9) / (cw * ch) + 2 * parents)

    def always_splits(self, slots: set[str]) -> bool:
        return {"cell", "empty"} <= slots  # cells, or one "empty" child when none fits

    def generate(self, parent: Region, *, rng: np.random.Generator) -> list[Child]:
        cw, ch = map(float, self.args["cell"])
        sp = float(self.args.get("spacing", 0.0))
        aisle, every = float(self.args.get("aisle", 0.0)), int(self.args.get("aisle_every", 0))
        swap = _along(parent)  # cell "height" runs along the parent's orientation
        W, H = (parent.h, parent.w) if swap else (parent.w, parent.h)
        nx = int((W + sp + EPS) // (cw + sp))
        rows, y, r = [], 0.0, 0
        while y + ch <= H + EPS:
            rows.append(y)
            r += 1
            y += ch + sp + (aisle if every and r % every == 0 else 0.0)
        if nx == 0 or not rows:
            return [Child(parent.x, parent.y, parent.w, parent.h, "empty", parent.orientation)]
        gap_x = sp
        if self.args.get("leftover", "empty") == "spread" and nx > 1:
            gap_x = (W - nx * cw) / (nx - 1)
        out = []
        for y in rows:
            for i in range(nx):
                x = i * (cw + gap_x)
                if swap:
                    out.append(Child(parent.x + y, parent.y + x, ch, cw, "cell"))
                else:
                    out.append(Child(parent.x + x, parent.y + y, cw, ch, "cell"))
        if self.args.get("leftover", "empty") == "empty":
            used_w = nx * cw + (nx - 1) * gap_x
            used_h = rows[-1] + ch
            rest = []
            if W - used_w > EPS:
                rest.append((used_w, 0.0, W - used_w, H))
            if H - used_h > EPS:
                rest.append((0.0, used_h, used_w, H - used_h))
            for x, y, w, h in rest:
                out.append(
                    Child(parent.x + y, parent.y + x, h, w, "empty")
                    if swap
                    else Child(parent.x + x, parent.y + y, w, h, "empty")
                )
        return out


@register("assembly_line")
class AssemblyLine(Generator):
    """The main line across the parent: a strip of width ``line_width`` at a random position,
    ``material_width`` strips on both sides, then ``paths`` parallel lanes (forklift / STR)
    of ``path_width`` separated by ``path_spacing``; what is left becomes ``rest`` regions.
    ``direction``: "horizontal", "vertical" or "random" (line along x or y)."""

    slots = ("line", "material", "path", "rest")
    arguments = ("direction", "line_width", "material_width", "path_spacing", "path_width", "paths")

    def check(self, where: str) -> None:
        a = self.args
        for k in ("line_width", "material_width", "path_width", "path_spacing"):
            if k in a:
                _range(a[k], f"{where}.args", k, positive=(k in ("line_width", "path_width")))
        if "paths" in a:
            _range(a["paths"], f"{where}.args", "paths", positive=False, whole=True)
        if a.get("direction", "random") not in ("horizontal", "vertical", "random"):
            raise ConfigError(
                f"{where}.args.direction: expected horizontal, vertical or random, got "
                f"{a['direction']!r}"
            )

    def check_fits(self, width: float, height: float, where: str) -> None:
        lw = self.args.get("line_width", 0)
        lw = max(lw) if isinstance(lw, list) else float(lw)
        if lw > max(width, height):
            raise ConfigError(
                f"{where}.args.line_width: a {lw} m line does not fit its parent ({width} x "
                f"{height} m)"
            )

    def max_children(self, w: float, h: float, parents: float, area: float) -> float:
        # per path a strip and a leftover band; the line, two material strips and their bands
        return parents * (2 * _range(self.args.get("paths", [1, 2]), "", "paths", False)[1] + 8)

    def always_splits(self, slots: set[str]) -> bool:
        return {"line", "rest"} <= slots  # the line, or one "rest" child when it does not fit

    def generate(self, parent: Region, *, rng: np.random.Generator) -> list[Child]:
        a = self.args
        direction = a.get("direction", "random")
        if direction == "random":
            direction = "horizontal" if rng.random() < 0.5 else "vertical"
        horiz = direction == "horizontal"
        span = parent.h if horiz else parent.w  # across the line
        line_w = _draw(_range(a.get("line_width", 4.0), "", "line_width"), rng=rng)
        mat_w = _draw(_range(a.get("material_width", 0.0), "", "material_width", False), rng=rng)
        lo, hi = _range(a.get("paths", [1, 2]), "", "paths", False)
        n_paths = int(rng.integers(int(lo), int(hi) + 1)) if hi > lo else int(lo)
        path_w = _range(a.get("path_width", 2.5), "", "path_width")
        path_sp = _range(a.get("path_spacing", 0.0), "", "path_spacing", False)
        # strips stacked across the line: paths, material, line, material, paths
        widths = [_draw(path_w, rng=rng) for _ in range(n_paths)]
        gaps = [_draw(path_sp, rng=rng) for _ in range(n_paths)]
        core = line_w + 2 * mat_w
        side = [(w, g) for w, g in zip(widths, gaps)]
        below = side[: (n_paths + 1) // 2]
        above = side[(n_paths + 1) // 2 :]
        need = core + sum(w + g for w, g in side)
        while need > span + EPS and (below or above):  # drop paths that do not fit
            (above if len(above) >= len(below) and above else below).pop()
            need = core + sum(w + g for w, g in below + above)
        if core > span + EPS:
            return [Child(parent.x, parent.y, parent.w, parent.h, "rest", parent.orientation)]
        start = float(rng.uniform(0.0, span - need)) if span - need > EPS else 0.0
        strips: list[tuple[float, float, str]] = []
        t = start
        for w, g in reversed(below):
            strips.append((t, w, "path"))
            t += w + g
        if mat_w > 0:
            strips.append((t, mat_w, "material"))
        t += mat_w
        strips.append((t, line_w, "line"))
        t += line_w
        if mat_w > 0:
            strips.append((t, mat_w, "material"))
        t += mat_w
        for w, g in above:
            t += g
            strips.append((t, w, "path"))
            t += w
        # leftover bands
        out: list[Child] = []
        cursor = 0.0
        along = "right" if horiz else "up"
        for s0, w, slot in strips:
            if s0 - cursor > EPS:
                out.append(self._band(parent, horiz, cursor, s0 - cursor, "rest", None))
            out.append(self._band(parent, horiz, s0, w, slot, along))
            cursor = s0 + w
        if span - cursor > EPS:
            out.append(self._band(parent, horiz, cursor, span - cursor, "rest", None))
        return out

    @staticmethod
    def _band(
        parent: Region, horiz: bool, s0: float, w: float, slot: str, orient: str | None
    ) -> Child:
        if horiz:
            return Child(parent.x, parent.y + s0, parent.w, w, slot, orient)
        return Child(parent.x + s0, parent.y, w, parent.h, slot, orient)


@register("random_rooms")
class RandomRooms(Generator):
    """``count: [min, max]`` rooms of ``width``/``height`` ranges placed without overlap, at
    least ``gap`` apart; gives up on a room after ``attempts`` tries and reports how many it
    placed (never loops forever)."""

    slots = ("room",)
    arguments = ("attempts", "count", "gap", "height", "width")

    def check(self, where: str) -> None:
        a = self.args
        _range(a.get("count", [1, 1]), f"{where}.args", "count", positive=True, whole=True)
        _range(a.get("width", 1.0), f"{where}.args", "width")
        _range(a.get("height", 1.0), f"{where}.args", "height")
        _number(a, "gap", 0.0, where)
        _number(a, "attempts", 50, where, lo=1, whole=True)

    def max_children(self, w: float, h: float, parents: float, area: float) -> float:
        return parents * _range(self.args.get("count", [1, 1]), "", "count")[1]

    def work(self, w: float, h: float, parents: float) -> float:
        # each try of each room tests the rooms placed before it: count² · attempts / 2 tests
        n = _range(self.args.get("count", [1, 1]), "", "count")[1]
        return parents * n * n * float(self.args.get("attempts", 50)) / 2 / 10

    def always_splits(self, slots: set[str]) -> bool:
        return "room" in slots  # at least one room is asked for, and the first always fits

    def generate(self, parent: Region, *, rng: np.random.Generator) -> list[Child]:
        a = self.args
        lo, hi = _range(a.get("count", [1, 1]), "", "count")
        want = int(rng.integers(int(lo), int(hi) + 1))
        wr, hr = (
            _range(a.get("width", 1.0), "", "width"),
            _range(a.get("height", 1.0), "", "height"),
        )
        gap, attempts = float(a.get("gap", 0.0)), int(a.get("attempts", 50))
        placed: list[Child] = []
        for _ in range(want):
            for _ in range(attempts):
                w, h = min(_draw(wr, rng=rng), parent.w), min(_draw(hr, rng=rng), parent.h)
                x = parent.x + float(rng.uniform(0, parent.w - w)) if parent.w > w else parent.x
                y = parent.y + float(rng.uniform(0, parent.h - h)) if parent.h > h else parent.y
                c = Region(x - gap / 2, y - gap / 2, w + gap, h + gap, "")
                if not any(c.overlaps(Region(p.x, p.y, p.w, p.h, "")) for p in placed):
                    placed.append(Child(x, y, w, h, "room"))
                    break
        self.report = {"requested": want, "placed": len(placed)}
        return placed


@register("drunkard_walk")
class DrunkardWalk(Generator):
    """A random walk of ``steps`` over blocks of ``block`` metres, rasterised, then cut back
    into rectangles (maximal row runs merged downwards): irregular rooms."""

    slots = ("room",)
    arguments = ("block", "steps")

    CHUNK = 1 << 20  # steps drawn at a time (the same stream as one draw: memory stays small)

    def check(self, where: str) -> None:
        _number(self.args, "block", 1.0, where, lo_open=True)
        _number(self.args, "steps", 50, where, lo=1, whole=True)

    def max_children(self, w: float, h: float, parents: float, area: float) -> float:
        b, steps = float(self.args.get("block", 1.0)), float(self.args.get("steps", 50))
        # rectangles of whole blocks, disjoint: no more than the blocks visited or the area holds
        return min(parents * min(steps + 1, (w / b) * (h / b)), area * (1 + 1e-9) / (b * b))

    def work(self, w: float, h: float, parents: float) -> float:
        return parents * float(self.args.get("steps", 50)) / 10

    def generate(self, parent: Region, *, rng: np.random.Generator) -> list[Child]:
        b = float(self.args.get("block", 1.0))
        nx, ny = int(parent.w // b), int(parent.h // b)
        if nx == 0 or ny == 0:
            return []
        grid = np.zeros((ny, nx), bool)
        i, j = ny // 2, nx // 2
        di, dj = (0, 1, 0, -1), (1, 0, -1, 0)
        left = int(self.args.get("steps", 50))
        while left:
            for step in rng.integers(0, 4, min(left, self.CHUNK)).tolist():
                grid[i, j] = True
                i = min(max(i + di[step], 0), ny - 1)
                j = min(max(j + dj[step], 0), nx - 1)
            left -= min(left, self.CHUNK)
        grid[i, j] = True
        return [
            Child(parent.x + c0 * b, parent.y + r0 * b, (c1 - c0) * b, (r1 - r0) * b, "room")
            for r0, r1, c0, c1 in rectangles(grid)
        ]


def rectangles(mask: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Cover a boolean grid exactly with rectangles (r0, r1, c0, c1), half-open, greedily:
    runs along rows, extended down while the next row has the same run."""
    mask = mask.copy()
    out = []
    H, W = mask.shape
    for r in range(H):
        c = 0
        while c < W:
            if not mask[r, c]:
                c += 1
                continue
            c1 = c
            while c1 < W and mask[r, c1]:
                c1 += 1
            r1 = r + 1
            while r1 < H and mask[r1, c:c1].all():
                r1 += 1
            mask[r:r1, c:c1] = False
            out.append((r, r1, c, c1))
            c = c1
    return out
