"""From a ``Layout`` to a ``Scene``: each region with an asset group furnished (paper §3.3).

Each region draws an asset class from its group and a variant that fits its rectangle,
turned to face the region's orientation; assets are never stretched. The region type's
``fill`` says how the region is furnished: ``one`` asset in its middle (the default), a
``row`` along its long side or a ``grid`` of them ``spacing_m`` apart (at most ``count``),
a ``stack`` up to ``stack_m``; racks with a ``load`` carry, shelf by shelf, pallets,
stillages or KLTs, each its own instance of its own class. Every item keeps to its own cell
of the region, so items never interpenetrate. Options (the
strategy's ``scene`` section), each off unless asked for — and when off, no RNG draw:

* ``walls`` (bool), ``columns`` (spacing in m, 0 = none): the hall around the layout;
* ``stack`` (bool): pallets, KLTs and stillages stacked up to ``stack_height_m``;
* ``jitter``: ``{"position_m": σ, "yaw_rad": σ}`` Gaussian placement noise (kept inside);
* ``dropout`` (0–1): probability a region is left empty;
* ``color`` (bool): per-instance colour variation;
* ``clutter`` (0–1): probability a pallet carries a KLT;
* ``assets``: ``{class: [file or {"path", "variant", "units", "up"}, ...]}`` meshes that join
  the class's variants for this build (:func:`.assets.catalogue.load_asset`; a strategy
  file's relative paths are relative to its folder).

Every instance gets a material of its class (:mod:`.materials`), drawn from a generator
spawned from the scene's (``rng.spawn``): materials never shift the layout's draws.
"""

from __future__ import annotations

import logging
from functools import lru_cache
from typing import Any

import numpy as np

from ..validation.arguments import check_seed, expect
from ..errors import ConfigError, did_you_mean
from ..layout.model import Layout, Region
from ..scene_options import SceneOptions, scene_options
from .assets import library as lib
from .assets.catalogue import ASSETS, UNITS, Catalogue
from .materials import class_material
from .model import Mesh, Scene

log = logging.getLogger(__name__)

GROUPS: dict[str, list[str]] = {c: [c] for c in lib.VARIANTS}
GROUPS.update({"storage": ["pallet", "stillage", "klt"], "wall": [], "column": []})
YAW = {"up": 0.0, "left": np.pi / 2, "down": np.pi, "right": -np.pi / 2}
BASE_COLOR = {
    "pallet": (176, 136, 90),
    "rack": (40, 90, 170),
    "car": (200, 200, 205),
    "jack": (230, 120, 30),
    "forklift": (240, 190, 20),
    "dolly": (120, 120, 120),
    "klt": (40, 110, 200),
    "stillage": (90, 100, 90),
    "cabinet": (150, 160, 170),
    "conveyor": (110, 110, 115),
    "floor": (170, 170, 160),
    "wall": (215, 215, 210),
    "column": (180, 180, 175),
}


def _transform(yaw: float, x: float, y: float, z: float = 0.0) -> np.ndarray:
    return _turned(np.cos(yaw), np.sin(yaw), x, y, z)


def _turned(c: float, s: float, x: float, y: float, z: float) -> np.ndarray:
    """(4, 4) float64: a turn about z (cos ``c``, sin ``s``), then the translation (x, y, z)."""
    return np.array(
        (c, -s, 0.0, x, s, c, 0.0, y, 0.0, 0.0, 1.0, z, 0.0, 0.0, 0.0, 1.0), np.float64
    ).reshape(4, 4)


@lru_cache(maxsize=64)
def _hall_mesh(kind: str, *size: float) -> Mesh:
    """The hall's floor (width, depth), a wall (x, y, height: a box standing on z = 0) or a
    column, as a scene stores it, made once per process for each size (a strategy's scenes
    share their hall's size) and shared by the scenes, as the assets' meshes are."""
    if kind == "floor":
        return Mesh.from_trimesh(lib.floor(*size))
    if kind == "wall":
        sx, sy, height = size
        return Mesh.from_trimesh(lib.box([sx, sy, height], [0, 0, height / 2]))
    return Mesh.from_trimesh(lib.column())


def _footprint(bounds: np.ndarray, yaw: float) -> tuple[float, float]:
    ext = bounds[1] - bounds[0]
    if abs(np.sin(yaw)) > 0.5:
        return float(ext[1]), float(ext[0])
    return float(ext[0]), float(ext[1])


class SceneBuilder:
    def __init__(
        self, layout: Layout, options: SceneOptions, assets: Catalogue, *, rng: np.random.Generator
    ) -> None:
        self.layout, self.opt, self.rng, self.assets = layout, options, rng, assets
        self.scene = Scene(metadata={"layout": layout.meta})
        self._keys: dict[tuple[str, str], str] = {}
        self._bounds: dict[tuple[str, str], np.ndarray] = {}
        self._centres: dict[tuple[str, str], np.ndarray] = {}
        self._turns: dict[float, tuple[Any, Any]] = {}  # yaw -> (np.cos(yaw), np.sin(yaw))
        # the options read per instance, read once (a pydantic attribute costs a microsecond)
        self._jitter = options.jitter if options.jitters else None
        self._vary_color = bool(options.color)
        # a child stream: drawing materials leaves the placement draws as they were
        self.material_rng = rng.spawn(1)[0]

    def bounds(self, cls: str, variant: str) -> np.ndarray:
        """(2, 3) bounds of a variant's mesh, read once (trimesh re-hashes the vertices to
        check its cache on every ``mesh.bounds``)."""
        b = self._bounds.get((cls, variant))
        if b is None:
            b = self._bounds[(cls, variant)] = np.array(
                self.assets.mesh(cls, variant).bounds, dtype=np.float64
            )
        return b

    def material(self, cls: str):
        return class_material(cls, rng=self.material_rng)

    def color(self, cls: str) -> tuple[int, int, int]:
        base = BASE_COLOR.get(cls, (160, 160, 160))
        if not self._vary_color:
            return base
        # per channel in plain floats (once per instance): the array form's operations and bits.
        # uniform(lo, hi) is lo + (hi - lo) * random() in numpy, one draw alike: written so, it
        # skips the scalar call's argument handling (3.5 us of ~4)
        gain, (e0, e1, e2) = (
            0.75 + (1.15 - 0.75) * self.rng.random(),
            self.rng.normal(0.0, 12.0, 3).tolist(),
        )
        return (
            int(min(max(base[0] * gain + e0, 0.0), 255.0)),
            int(min(max(base[1] * gain + e1, 0.0), 255.0)),
            int(min(max(base[2] * gain + e2, 0.0), 255.0)),
        )

    def add(self, cls: str, variant: str, T: np.ndarray, name: str) -> int:
        key = self._keys.get((cls, variant))
        if key is None:
            mesh = self.assets.scene_mesh(cls, variant)
            key = self._keys[(cls, variant)] = self.scene.add_mesh(mesh, name=f"{cls}_{variant}")
        return self.scene.add(
            key,
            T,
            semantic=lib.SEMANTIC[cls],
            color=self.color(cls),
            name=name,
            material=self.material(cls),
        )

    def background(self) -> None:
        x0, y0, w, h = self.layout.bounds
        self.scene.add(
            self.scene.add_mesh(_hall_mesh("floor", w, h), "floor"),
            _transform(0, x0, y0),
            semantic=0,
            color=BASE_COLOR["floor"],
            name="floor",
            material=self.material("floor"),
        )
        if self.opt.walls:
            t, H = 0.2, float(self.opt.wall_height_m)
            for i, (sx, sy, cx, cy) in enumerate(
                [
                    (w + 2 * t, t, w / 2, -t / 2),
                    (w + 2 * t, t, w / 2, h + t / 2),
                    (t, h, -t / 2, h / 2),
                    (t, h, w + t / 2, h / 2),
                ]
            ):
                self.scene.add(
                    self.scene.add_mesh(_hall_mesh("wall", sx, sy, H), f"wall_{i}"),
                    _transform(0, x0 + cx, y0 + cy),
                    semantic=0,
                    color=BASE_COLOR["wall"],
                    name=f"wall_{i}",
                    material=self.material("wall"),
                )
        spacing = float(self.opt.columns)
        if spacing > 0:
            key = self.scene.add_mesh(_hall_mesh("column"), "column")
            k = 0
            for cx in np.arange(spacing, w - 1e-6, spacing):
                for cy in (0.25, h - 0.25):
                    self.scene.add(
                        key,
                        _transform(0, x0 + cx, y0 + cy),
                        semantic=0,
                        color=BASE_COLOR["column"],
                        name=f"column_{k}",
                        material=self.material("column"),
                    )
                    k += 1

    def region(self, i: int, reg: Region) -> None:
        rtype = self.layout.region_types[reg.type]
        group = rtype.asset_group
        if not group:
            return
        if group not in GROUPS:
            raise ConfigError(
                f"region type {reg.type!r}: unknown asset group {group!r}"
                f"{did_you_mean(group, GROUPS)} (known: {', '.join(sorted(GROUPS))})"
            )
        classes = GROUPS[group]
        if not classes:
            return
        if self.opt.dropout and self.rng.random() < float(self.opt.dropout):
            return
        fill = rtype.fill or {}
        _check_load(reg.type, fill.get("load"))
        cls = classes[int(self.rng.integers(len(classes)))] if len(classes) > 1 else classes[0]
        choice = self._fit(cls, YAW[reg.orientation], reg.w, reg.h)
        if choice is None:
            log.debug(
                "region %d (%s, %.2f x %.2f m): no %s variant fits", i, reg.type, reg.w, reg.h, cls
            )
            return
        mode = fill.get("mode", "one")
        if mode in ("one", "stack"):
            self._place(cls, choice, reg, reg.type, i, fill)
            return
        for k, slot in enumerate(self._slots(reg, choice, fill, grid=mode == "grid")):
            self._place(cls, choice, slot, f"{reg.type}_s{k}", i, fill)

    def _fit(
        self, cls: str, yaw: float, w: float, h: float
    ) -> tuple[str, float, float, float] | None:
        """A variant of ``cls`` (in a random order) whose footprint fits w x h turned to
        ``yaw``, else a quarter turn; (variant, yaw, footprint along x, along y) or None."""
        variants = self.assets.variants(cls)
        order = [variants[k] for k in self.rng.permutation(len(variants))]
        for turn in (0.0, np.pi / 2):  # the region's facing first; a quarter turn if nothing fits
            for v in order:
                fw, fd = _footprint(self.bounds(cls, v), yaw + turn)
                if fw <= w + 1e-9 and fd <= h + 1e-9:
                    return v, yaw + turn, fw, fd
        return None

    def _slots(self, reg: Region, choice: tuple, fill: dict, grid: bool) -> list[Region]:
        """Cells of one item each: a row along the region's long side (or a grid), items
        ``spacing_m`` apart, at most ``count`` of them, the block at a random offset. A cell
        reaches half the spacing past its item, so neighbours' cells touch, never overlap."""
        _, _, fw, fd = choice
        s = _span(fill.get("spacing_m", 0.1), rng=self.rng)
        along_x = reg.w >= reg.h
        lay_x, lay_y = grid or along_x, grid or not along_x
        nx = max(1, int((reg.w + s + 1e-9) // (fw + s))) if lay_x else 1
        ny = max(1, int((reg.h + s + 1e-9) // (fd + s))) if lay_y else 1
        n = None
        if fill.get("count") is not None:
            lo, hi = (
                (fill["count"], fill["count"]) if isinstance(fill["count"], int) else fill["count"]
            )
            n = int(self.rng.integers(lo, hi + 1))
            if along_x:
                nx = min(nx, -(-n // ny))
            else:
                ny = min(ny, -(-n // nx))

        def cells(
            lay: bool, n: int, start: float, length: float, size: float
        ) -> list[tuple[float, float]]:
            if not lay:
                return [(start, start + length)]
            off = start + float(self.rng.uniform(0, max(0.0, length - n * size - (n - 1) * s)))
            out = []
            for k in range(n):  # centred on its item, at most half the spacing past it
                c = off + k * (size + s) + size / 2
                half = size / 2 + max(
                    0.0, min(s / 2, c - size / 2 - start, start + length - c - size / 2)
                )
                out.append((c - half, c + half))
            return out

        xs = cells(lay_x, nx, reg.x, reg.w, fw)
        ys = cells(lay_y, ny, reg.y, reg.h, fd)
        out = [
            Region(x0, y0, x1 - x0, y1 - y0, reg.type, reg.orientation)
            for y0, y1 in ys
            for x0, x1 in xs
        ]
        return out if n is None else out[:n]

    def _place(self, cls: str, choice: tuple, slot: Region, base: str, i: int, fill: dict) -> None:
        """One item (a stack, a loaded rack) in the middle of ``slot``, with the jitter the
        options ask for kept inside it. Instance names end in ``_<region index>_<layer>``."""
        v, yaw, fw, fd = choice
        cx, cy = slot.centre
        if self._jitter is not None:
            jit = self._jitter
            slack_x, slack_y = (slot.w - fw) / 2, (slot.h - fd) / 2
            cx += min(
                max(float(self.rng.normal(0, jit.position_m)), -slack_x), slack_x
            )  # np.clip's rule
            cy += min(max(float(self.rng.normal(0, jit.position_m)), -slack_y), slack_y)
            # a yaw turn must keep the turned footprint inside: only where there is room
            dyaw = float(self.rng.normal(0, jit.yaw_rad))
            diag = np.hypot(fw, fd) / 2
            if diag <= min(
                slot.w / 2 - abs(cx - slot.centre[0]), slot.h / 2 - abs(cy - slot.centre[1])
            ):
                yaw += dyaw
        height = float(self.bounds(cls, v)[1][2])
        layers = 1
        if cls in lib.STACKABLE and fill.get("stack_m") is not None:
            layers = max(1, int(_span(fill["stack_m"], rng=self.rng) // (height + 0.001)))
        elif self.opt.stack and cls in lib.STACKABLE:
            limit = float(self.opt.stack_height_m)
            max_layers = max(1, int(limit // height))
            layers = int(self.rng.integers(1, max_layers + 1))
        for k in range(layers):
            self._put(cls, v, yaw, cx, cy, k * (height + 0.001), f"{base}_{i}_{k}")
        if cls == "pallet" and self.opt.clutter and self.rng.random() < float(self.opt.clutter):
            self._put("klt", "6428", yaw, cx, cy, layers * (height + 0.001), f"{base}_{i}_klt")
        if cls == "rack" and fill.get("load"):
            self._load(v, yaw, cx, cy, fill["load"], base, i)

    def _put(self, cls: str, v: str, yaw: float, cx: float, cy: float, z: float, name: str) -> int:
        """An instance whose footprint centre lands on (cx, cy), turned by ``yaw``."""
        off = self._centre(cls, v)
        turn = self._turns.get(yaw) if yaw else None  # (0.0 and -0.0 are one key: not kept)
        if turn is None:  # the layers of a stack, a shelf's items: one turn, many instances
            turn = (np.cos(yaw), np.sin(yaw))
            if yaw:
                self._turns[yaw] = turn
        c, s = turn
        ox, oy = c * off[0] - s * off[1], s * off[0] + c * off[1]
        return self.add(cls, v, _turned(c, s, cx - ox, cy - oy, z), name)

    def _centre(self, cls: str, variant: str) -> np.ndarray:
        """(3,) float64: the middle of a variant's bounds."""
        off = self._centres.get((cls, variant))
        if off is None:
            b = self.bounds(cls, variant)
            off = self._centres[(cls, variant)] = (b[0] + b[1]) / 2
        return off

    def _load(
        self,
        variant: str,
        yaw: float,
        cx: float,
        cy: float,
        load: dict[str, float],
        base: str,
        i: int,
    ) -> None:
        """Each shelf of a built-in rack gets one class drawn from ``load``: as many of it
        side by side as the shelf holds (KLTs stacked to the shelf's clear height, pallets
        sometimes carrying a KLT), each its own instance of its own class."""
        shelves = lib.SHELVES.get("rack", {}).get(variant)
        if not shelves:
            return
        names = sorted(load)  # layout JSON sorts keys: the draw must not depend on their order
        p = np.array([load[k] for k in names], float)
        p /= p.sum()
        c, s = np.cos(yaw), np.sin(yaw)
        for lv, (z, clear, inner_w, depth) in enumerate(shelves):
            item = names[int(self.rng.choice(len(names), p=p))]
            if item == "empty":
                continue
            choice = self._fit(item, 0.0, inner_w, depth)
            if choice is None:
                continue
            v, turn, fw, _ = choice
            h = float(self.bounds(item, v)[1][2])
            if h > clear:
                continue
            gap = 0.05
            n_fit = max(1, int((inner_w + gap + 1e-9) // (fw + gap)))
            n = int(self.rng.integers(max(1, n_fit // 2), n_fit + 1))
            x0 = -(n * fw + (n - 1) * gap) / 2 + fw / 2
            layers = (
                int(self.rng.integers(1, int(clear // (h + 0.001)) + 1)) if item == "klt" else 1
            )
            for k in range(n):
                lx = x0 + k * (fw + gap)
                wx, wy = cx + c * lx, cy + s * lx
                for m in range(layers):
                    self._put(
                        item,
                        v,
                        yaw + turn,
                        wx,
                        wy,
                        z + m * (h + 0.001),
                        f"{base}_shelf{lv}n{k}m{m}_{i}_load",
                    )
                if item == "pallet" and h + 0.28 <= clear and self.rng.random() < 0.5:
                    self._put(
                        "klt",
                        "6428",
                        yaw,
                        wx,
                        wy,
                        z + h + 0.001,
                        f"{base}_shelf{lv}n{k}klt_{i}_load",
                    )


def _span(value, *, rng: np.random.Generator) -> float:
    """A value, or one drawn uniformly from a range [min, max]."""
    if isinstance(value, (int, float)):
        return float(value)
    lo, hi = value
    return float(lo) if lo == hi else float(rng.uniform(lo, hi))


def _check_load(rtype: str, load: dict | None) -> None:
    for cls in load or {}:
        if cls != "empty" and cls not in lib.VARIANTS:
            raise ConfigError(
                f"region type {rtype!r}: fill.load.{cls}: unknown asset class {cls!r}"
                f"{did_you_mean(cls, lib.VARIANTS)} (known: empty, "
                f"{', '.join(sorted(lib.VARIANTS))})"
            )


def _with_assets(spec: Any, base: Catalogue) -> Catalogue:
    """``base`` plus the ``assets`` option's files, registered into a copy."""
    if not spec:
        return base
    if not isinstance(spec, dict) or not all(isinstance(e, list) for e in spec.values()):
        raise ConfigError(f"scene.assets: expected {{class: [file, ...]}}, got {spec!r:.80}")
    cat = base.copy()
    for cls, entries in spec.items():
        for k, e in enumerate(entries):
            e = {"path": e} if isinstance(e, str) else e
            if (
                not isinstance(e, dict)
                or "path" not in e
                or set(e) - {"path", "variant", "units", "up"}
            ):
                raise ConfigError(
                    f"scene.assets.{cls}[{k}]: expected a file path or "
                    f'{{"path", "variant", "units", "up"}}, got {e!r:.80}'
                )
            try:
                cat.register(
                    cls, e["path"], variant=e.get("variant"), units=e.get("units"), up=e.get("up")
                )
            except ConfigError as exc:
                raise ConfigError(f"scene.assets.{cls}[{k}]: {exc}") from None
    return cat


def _fits(ext: np.ndarray, w: float, h: float) -> bool:
    """A footprint (x, y) fits a w x h region as it is or a quarter turn (as ``_fit`` tries)."""
    return bool(
        (ext[0] <= w + 1e-9 and ext[1] <= h + 1e-9) or (ext[1] <= w + 1e-9 and ext[0] <= h + 1e-9)
    )


def check_registered_fit(layout: Layout, cat: Catalogue, leaves: list[Region]) -> None:
    """Refuse a registered asset that fits none of the regions its class is drawn for in
    ``layout`` (it would never be used: a file in millimetres read as metres is the usual
    cause): one line naming the file, its size, the unit it was read in and the units that
    would make it fit. The shelves of racks whose regions carry a ``load`` count as places
    for the classes of the load."""
    sizes: dict[str, list[tuple[float, float]]] = {}
    regions: dict[str, int] = {}
    on_shelves: set[str] = set()
    shelves = [(w, d) for v in lib.SHELVES.get("rack", {}).values() for _, _, w, d in v]
    for reg in leaves:
        rtype = layout.region_types[reg.type]
        for cls in GROUPS.get(rtype.asset_group or "", []):
            sizes.setdefault(cls, []).append((reg.w, reg.h))
            regions[cls] = regions.get(cls, 0) + 1
        for cls in (rtype.fill or {}).get("load") or {}:
            if (
                cls != "empty"
                and cls not in on_shelves
                and "rack" in GROUPS.get(rtype.asset_group or "", [])
            ):
                sizes.setdefault(cls, []).extend(shelves)
                on_shelves.add(cls)
    for cls, variants in cat.registered().items():
        if cls not in sizes:
            continue
        for v in variants:
            ext = np.asarray(cat.mesh(cls, v).extents, np.float64)
            if any(_fits(ext, w, h) for w, h in sizes[cls]):
                continue
            src = cat.source(cls, v)
            w, h = max(sizes[cls], key=lambda r: r[0] * r[1])
            size = " x ".join(f"{e:.4g}" for e in ext)
            fix = "; no unit makes it fit: give a smaller asset or larger regions"
            if (
                src is not None
                and src.meters_per_unit is not None
                or (src is not None and "metres" in src.units)
            ):
                now = src.meters_per_unit or 1.0
                good = [
                    (u, ext * m / now)
                    for u, m in UNITS.items()
                    if m != now
                    and any(_fits(ext * m / now, rw, rh) for rw, rh in sizes[cls])
                    and (ext * m / now).max() >= 0.05
                ]
                if good:
                    fix = "; it fits in " + " or ".join(
                        f'"units": "{u}" ({" x ".join(f"{e:.3g}" for e in e2)} m)' for u, e2 in good
                    )
            where = f"the {regions.get(cls, 0)} regions that draw a {cls}" + (
                " nor a rack's shelf" if cls in on_shelves else ""
            )
            raise ConfigError(
                f"{src.path if src else v}: a {cls} asset of {size} m (read in "
                f"{src.units if src else 'metres'}) fits none of {where} (the largest "
                f"{w:.3g} x {h:.3g} m){fix}"
            )


def build_scene(
    layout: Layout,
    seed: int = 0,
    *,
    options: dict[str, Any] | None = None,
    rng: np.random.Generator | None = None,
    assets: Catalogue | None = None,
    segments: int | None = None,
) -> Scene:
    """Build the 3D scene of ``layout``: background, then one asset per region with a group.

    ``options`` defaults to the strategy's ``scene`` section stored in ``layout.meta``;
    ``assets`` (default: the registry :func:`register_asset` fills) gives each class's variants.
    ``segments`` (an integer >= 3): segments per full circle of every curved part of the
    built-in assets (the tessellation accuracy knob); None keeps each part's own count.
    Same layout, options, assets, seed and segments: the same scene (and the same USD bytes).
    """
    expect(layout, Layout, "build_scene: layout")
    seed = check_seed(seed, "build_scene: seed")
    segments = lib.check_segments(segments, "build_scene")
    opts = scene_options(
        layout.meta.get("scene", {}) if options is None else options,
        "build_scene options" if options is not None else "layout scene options",
    )
    cat = _with_assets(opts.asset_entries(), ASSETS if assets is None else assets)
    if segments is not None:
        cat = cat.copy(segments=segments)
    b = SceneBuilder(layout, opts, cat, rng=np.random.default_rng(seed) if rng is None else rng)
    leaves = layout.leaves()
    check_registered_fit(layout, cat, leaves)
    b.background()
    before = len(b.scene.instances)
    for i, reg in enumerate(leaves):
        b.region(i, reg)
    if len(b.scene.instances) == before:  # an empty hall is a result nobody asked for: say so
        grouped = sum(1 for r in leaves if layout.region_types[r.type].asset_group)
        why = (
            f"none of its {len(leaves)} regions has an asset_group"
            if not grouped
            else f"its {grouped} regions with an asset group are all too small for their assets "
            "(or dropped out)"
        )
        log.warning(
            "build_scene: no asset placed: the layout of %s holds floor and walls only (%s)",
            layout.meta.get("strategy", "its strategy"),
            why,
        )
    return b.scene
