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

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..errors import ConfigError, did_you_mean
from .model import ORIENTATIONS, Region

EPS = 1e-9


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
        return Region(float(self.x[i]), float(self.y[i]), float(self.w[i]), float(self.h[i]), self.type,
                      ORIENTATIONS[self.orient[i]])


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


@dataclass(frozen=True)
class RegionBound:
    """The most a generator makes of one parent region (the size check before a dataset run,
    :mod:`genie_gl.dataset.limits`).

    Attributes
    ----------
    per_parent : float, regions made of one parent, at most.
    min_area_m2 : float or None, the smallest area of a region it makes (m²): its regions of a
        level cover the hall at most twice, so a level makes at most 2·area/min_area_m2 of
        them (plus the parents); None: no such bound.
    work : float, work per parent besides making regions (e.g. overlap tests / 10).
    """

    per_parent: float
    min_area_m2: float | None = None
    work: float = 0.0


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
                rows.append((i, c.x, c.y, c.w, c.h, slot_index[c.slot],
                             -1 if c.orientation is None else ORIENTATIONS.index(c.orientation)))
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

    def bound(self, hall_w: float, hall_h: float) -> RegionBound:
        """The most regions it makes of one parent in a hall of ``hall_w`` x ``hall_h`` m, its
        arguments at their largest. A generator that does not say is taken to make at most
        one region per 4 m x 4 m cell of the hall (override this to say more exactly)."""
        return RegionBound((max(hall_w, hall_h) / 4.0 + 1) ** 2)


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
        raise ConfigError(f"{where}: unknown generator {name!r}{did_you_mean(name, GENERATORS)} "
                          f"(known: {', '.join(sorted(GENERATORS))})") from None


def _range(value: Any, where: str, name: str, positive: bool = True) -> tuple[float, float]:
    lo, hi = (value, value) if np.isscalar(value) else tuple(value)
    if positive and (lo <= 0 or hi < lo):
        raise ConfigError(f"{where}.{name}: expected a positive size or a range [min, max] with "
                          f"0 < min <= max, got {value!r}")
    if not positive and (lo < 0 or hi < lo):
        raise ConfigError(f"{where}.{name}: expected a value >= 0 or a range [min, max], got {value!r}")
    return float(lo), float(hi)


def _draw(r: tuple[float, float], *, rng: np.random.Generator) -> float:
    return r[0] if r[0] == r[1] else float(rng.uniform(r[0], r[1]))


def _largest(value: Any, default: float) -> float:
    """The largest value of a number or a [min, max] range argument (``default`` when unset)."""
    if value is None:
        return default
    if isinstance(value, (list, tuple)):
        return float(max(value)) if value else default
    return float(value)


def _along(parent: Region) -> bool:
    """True when the parent's orientation runs along x (left/right)."""
    return parent.orientation in ("left", "right")


@register("grid")
class Grid(Generator):
    """Cells of ``cell: [w, h]`` (w across, h along the parent's orientation), ``spacing``
    between cells and an ``aisle`` every ``aisle_every`` rows; the leftover is an ``empty``
    region (``leftover: "empty"``) or spread between cells (``"spread"``)."""

    slots = ("cell", "empty")
    arguments = ('aisle', 'aisle_every', 'cell', 'leftover', 'spacing')

    def check(self, where: str) -> None:
        cell = self.args.get("cell")
        if not isinstance(cell, (list, tuple)) or len(cell) != 2 or min(cell) <= 0:
            raise ConfigError(f"{where}.args.cell: expected [width, height] > 0 in metres, got {cell!r}")
        for k in ("spacing", "aisle"):
            if float(self.args.get(k, 0)) < 0:
                raise ConfigError(f"{where}.args.{k}: expected >= 0, got {self.args[k]!r}")
        if self.args.get("leftover", "empty") not in ("empty", "spread"):
            raise ConfigError(f"{where}.args.leftover: expected 'empty' or 'spread', got {self.args['leftover']!r}")

    def check_fits(self, width: float, height: float, where: str) -> None:
        cell = self.args.get("cell")
        if isinstance(cell, list) and len(cell) == 2:
            cw, ch = sorted(float(c) for c in cell)
            if ch > max(width, height) or cw > min(width, height):
                raise ConfigError(f"{where}.args.cell: a {cell[0]} x {cell[1]} m cell is larger than its parent "
                                  f"({width} x {height} m)")

    def bound(self, hall_w: float, hall_h: float) -> RegionBound:
        cw, ch = (float(c) for c in self.args.get("cell", (1.0, 1.0)))
        sp = float(self.args.get("spacing", 0.0))
        return RegionBound((max(hall_w, hall_h) / (min(cw, ch) + sp) + 1) ** 2 + 1, min_area_m2=cw * ch)

    def generate(self, parent: Region, *, rng: np.random.Generator) -> list[Child]:
        cw, ch = map(float, self.args["cell"])
        sp = float(self.args.get("spacing", 0.0))
        aisle, every = float(self.args.get("aisle", 0.0)), int(self.args.get("aisle_every", 0))
        swap = _along(parent)       # cell "height" runs along the parent's orientation
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
            for (x, y, w, h) in rest:
                out.append(Child(parent.x + y, parent.y + x, h, w, "empty") if swap
                           else Child(parent.x + x, parent.y + y, w, h, "empty"))
        return out


@register("assembly_line")
class AssemblyLine(Generator):
    """The main line across the parent: a strip of width ``line_width`` at a random position,
    ``material_width`` strips on both sides, then ``paths`` parallel lanes (forklift / STR)
    of ``path_width`` separated by ``path_spacing``; what is left becomes ``rest`` regions.
    ``direction``: "horizontal", "vertical" or "random" (line along x or y)."""

    slots = ("line", "material", "path", "rest")
    arguments = ('direction', 'line_width', 'material_width', 'path_spacing', 'path_width', 'paths')

    def check(self, where: str) -> None:
        a = self.args
        for k in ("line_width", "material_width", "path_width", "path_spacing"):
            if k in a:
                _range(a[k], f"{where}.args", k, positive=(k in ("line_width", "path_width")))
        if "paths" in a:
            lo, hi = _range(a["paths"], f"{where}.args", "paths", positive=False)
            if int(lo) != lo or int(hi) != hi:
                raise ConfigError(f"{where}.args.paths: expected whole numbers, got {a['paths']!r}")
        if a.get("direction", "random") not in ("horizontal", "vertical", "random"):
            raise ConfigError(f"{where}.args.direction: expected horizontal, vertical or random, got {a['direction']!r}")

    def check_fits(self, width: float, height: float, where: str) -> None:
        lw = self.args.get("line_width", 0)
        lw = max(lw) if isinstance(lw, list) else float(lw)
        if lw > max(width, height):
            raise ConfigError(f"{where}.args.line_width: a {lw} m line does not fit its parent ({width} x {height} m)")

    def bound(self, hall_w: float, hall_h: float) -> RegionBound:
        return RegionBound(2 * _largest(self.args.get("paths"), 2.0) + 8)

    def generate(self, parent: Region, *, rng: np.random.Generator) -> list[Child]:
        a = self.args
        direction = a.get("direction", "random")
        if direction == "random":
            direction = "horizontal" if rng.random() < 0.5 else "vertical"
        horiz = direction == "horizontal"
        span = parent.h if horiz else parent.w          # across the line
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
        above = side[(n_paths + 1) // 2:]
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
    def _band(parent: Region, horiz: bool, s0: float, w: float, slot: str, orient: str | None) -> Child:
        if horiz:
            return Child(parent.x, parent.y + s0, parent.w, w, slot, orient)
        return Child(parent.x + s0, parent.y, w, parent.h, slot, orient)


@register("random_rooms")
class RandomRooms(Generator):
    """``count: [min, max]`` rooms of ``width``/``height`` ranges placed without overlap, at
    least ``gap`` apart; gives up on a room after ``attempts`` tries and reports how many it
    placed (never loops forever)."""

    slots = ("room",)
    arguments = ('attempts', 'count', 'gap', 'height', 'width')

    def check(self, where: str) -> None:
        a = self.args
        _range(a.get("count", [1, 1]), f"{where}.args", "count", positive=True)
        _range(a.get("width", 1.0), f"{where}.args", "width")
        _range(a.get("height", 1.0), f"{where}.args", "height")

    def bound(self, hall_w: float, hall_h: float) -> RegionBound:
        n = _largest(self.args.get("count"), 1.0)
        return RegionBound(n, work=n * n * _largest(self.args.get("attempts"), 50.0) / 2 / 10)

    def generate(self, parent: Region, *, rng: np.random.Generator) -> list[Child]:
        a = self.args
        lo, hi = _range(a.get("count", [1, 1]), "", "count")
        want = int(rng.integers(int(lo), int(hi) + 1))
        wr, hr = _range(a.get("width", 1.0), "", "width"), _range(a.get("height", 1.0), "", "height")
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
    arguments = ('block', 'steps')

    def check(self, where: str) -> None:
        if float(self.args.get("block", 1.0)) <= 0 or int(self.args.get("steps", 1)) < 1:
            raise ConfigError(f"{where}.args: block must be > 0 and steps >= 1")

    def bound(self, hall_w: float, hall_h: float) -> RegionBound:
        b = float(self.args.get("block", 1.0))
        return RegionBound(min(_largest(self.args.get("steps"), 50.0) + 1, (max(hall_w, hall_h) / b) ** 2),
                           min_area_m2=b * b)

    def generate(self, parent: Region, *, rng: np.random.Generator) -> list[Child]:
        b = float(self.args.get("block", 1.0))
        nx, ny = int(parent.w // b), int(parent.h // b)
        if nx == 0 or ny == 0:
            return []
        grid = np.zeros((ny, nx), bool)
        i, j = ny // 2, nx // 2
        moves = np.array([[0, 1], [1, 0], [0, -1], [-1, 0]])
        for step in rng.integers(0, 4, int(self.args.get("steps", 50))):
            grid[i, j] = True
            i = int(np.clip(i + moves[step, 0], 0, ny - 1))
            j = int(np.clip(j + moves[step, 1], 0, nx - 1))
        grid[i, j] = True
        return [Child(parent.x + c0 * b, parent.y + r0 * b, (c1 - c0) * b, (r1 - r0) * b, "room")
                for r0, r1, c0, c1 in rectangles(grid)]


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
