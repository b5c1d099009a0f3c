"""From a ``Layout`` to a ``Scene``: one asset per region with an asset group (paper §3.3).

Each region draws an asset class from its group and a variant that fits its rectangle,
turned to face the region's orientation; assets are never stretched. Options (the
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
from typing import Any

import numpy as np

from ..errors import ConfigError, did_you_mean
from ..layout.model import Layout, Region
from ..scene_options import check_scene_options
from .assets import library as lib
from .assets.catalogue import ASSETS, Catalogue
from .materials import class_material
from .model import Scene

log = logging.getLogger(__name__)

GROUPS: dict[str, list[str]] = {c: [c] for c in lib.VARIANTS}
GROUPS.update({"storage": ["pallet", "stillage", "klt"], "wall": [], "column": []})
YAW = {"up": 0.0, "left": np.pi / 2, "down": np.pi, "right": -np.pi / 2}
BASE_COLOR = {"pallet": (176, 136, 90), "rack": (40, 90, 170), "car": (200, 200, 205), "jack": (230, 120, 30),
              "forklift": (240, 190, 20), "dolly": (120, 120, 120), "klt": (40, 110, 200),
              "stillage": (90, 100, 90), "cabinet": (150, 160, 170), "conveyor": (110, 110, 115),
              "floor": (170, 170, 160), "wall": (215, 215, 210), "column": (180, 180, 175)}


def _transform(yaw: float, x: float, y: float, z: float = 0.0) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    T = np.eye(4)
    T[:2, :2] = [[c, -s], [s, c]]
    T[:3, 3] = [x, y, z]
    return T


def _footprint(mesh, yaw: float) -> tuple[float, float]:
    ext = mesh.bounds[1] - mesh.bounds[0]
    if abs(np.sin(yaw)) > 0.5:
        return float(ext[1]), float(ext[0])
    return float(ext[0]), float(ext[1])


class SceneBuilder:
    def __init__(self, layout: Layout, options: dict[str, Any], assets: Catalogue, *,
                 rng: np.random.Generator) -> None:
        self.layout, self.opt, self.rng, self.assets = layout, options, rng, assets
        self.scene = Scene(metadata={"layout": layout.meta})
        self._keys: dict[tuple[str, str], str] = {}
        # a child stream: drawing materials leaves the placement draws as they were
        self.material_rng = rng.spawn(1)[0]

    def material(self, cls: str):
        return class_material(cls, rng=self.material_rng)

    def color(self, cls: str) -> tuple[int, int, int]:
        base = np.array(BASE_COLOR.get(cls, (160, 160, 160)), float)
        if self.opt.get("color"):
            base = base * self.rng.uniform(0.75, 1.15) + self.rng.normal(0, 12, 3)
        return tuple(int(c) for c in np.clip(base, 0, 255))

    def add(self, cls: str, variant: str, T: np.ndarray, name: str) -> int:
        key = self._keys.get((cls, variant))
        if key is None:
            mesh = self.assets.mesh(cls, variant)
            key = self._keys[(cls, variant)] = self.scene.add_mesh(mesh, name=f"{cls}_{variant}")
        return self.scene.add(key, T, semantic=lib.SEMANTIC[cls], color=self.color(cls), name=name,
                              material=self.material(cls))

    def background(self) -> None:
        x0, y0, w, h = self.layout.bounds
        f = lib.floor(w, h)
        self.scene.add(self.scene.add_mesh(f, "floor"), _transform(0, x0, y0), semantic=0,
                       color=BASE_COLOR["floor"], name="floor", material=self.material("floor"))
        if self.opt.get("walls"):
            t, H = 0.2, float(self.opt.get("wall_height_m", 5.0))
            for i, (sx, sy, cx, cy) in enumerate([(w + 2 * t, t, w / 2, -t / 2), (w + 2 * t, t, w / 2, h + t / 2),
                                                  (t, h, -t / 2, h / 2), (t, h, w + t / 2, h / 2)]):
                m = lib.box([sx, sy, H], [0, 0, H / 2])
                self.scene.add(self.scene.add_mesh(m, f"wall_{i}"), _transform(0, x0 + cx, y0 + cy),
                               semantic=0, color=BASE_COLOR["wall"], name=f"wall_{i}",
                               material=self.material("wall"))
        spacing = float(self.opt.get("columns", 0) or 0)
        if spacing > 0:
            key = self.scene.add_mesh(lib.column(), "column")
            k = 0
            for cx in np.arange(spacing, w - 1e-6, spacing):
                for cy in (0.25, h - 0.25):
                    self.scene.add(key, _transform(0, x0 + cx, y0 + cy), semantic=0,
                                   color=BASE_COLOR["column"], name=f"column_{k}",
                                   material=self.material("column"))
                    k += 1

    def region(self, i: int, reg: Region) -> None:
        rtype = self.layout.region_types[reg.type]
        group = rtype.asset_group
        if not group:
            return
        if group not in GROUPS:
            raise ConfigError(f"region type {reg.type!r}: unknown asset group {group!r}"
                              f"{did_you_mean(group, GROUPS)} (known: {', '.join(sorted(GROUPS))})")
        classes = GROUPS[group]
        if not classes:
            return
        if self.opt.get("dropout") and self.rng.random() < float(self.opt["dropout"]):
            return
        cls = classes[int(self.rng.integers(len(classes)))] if len(classes) > 1 else classes[0]
        yaw = YAW[reg.orientation]
        variants = self.assets.variants(cls)
        order = [variants[k] for k in self.rng.permutation(len(variants))]
        choice = None
        for turn in (0.0, np.pi / 2):  # the region's facing first; a quarter turn if nothing fits
            for v in order:
                fw, fd = _footprint(self.assets.mesh(cls, v), yaw + turn)
                if fw <= reg.w + 1e-9 and fd <= reg.h + 1e-9:
                    choice = (v, yaw + turn, fw, fd)
                    break
            if choice:
                break
        if choice is None:
            log.debug("region %d (%s, %.2f x %.2f m): no %s variant fits", i, reg.type, reg.w, reg.h, cls)
            return
        v, yaw, fw, fd = choice
        cx, cy = reg.centre
        jit = self.opt.get("jitter")
        if jit:
            slack_x, slack_y = (reg.w - fw) / 2, (reg.h - fd) / 2
            cx += float(np.clip(self.rng.normal(0, jit.get("position_m", 0.0)), -slack_x, slack_x))
            cy += float(np.clip(self.rng.normal(0, jit.get("position_m", 0.0)), -slack_y, slack_y))
            # a yaw turn must keep the turned footprint inside: only where there is room
            dyaw = float(self.rng.normal(0, jit.get("yaw_rad", 0.0)))
            diag = np.hypot(fw, fd) / 2
            if diag <= min(reg.w / 2 - abs(cx - reg.centre[0]), reg.h / 2 - abs(cy - reg.centre[1])):
                yaw += dyaw
        mesh = self.assets.mesh(cls, v)
        # assets are centred in x, y by construction (bounds centre): correct any offset
        off = (mesh.bounds[0] + mesh.bounds[1]) / 2
        c, s = np.cos(yaw), np.sin(yaw)
        ox, oy = c * off[0] - s * off[1], s * off[0] + c * off[1]
        layers = 1
        height = float(mesh.bounds[1][2])
        if self.opt.get("stack") and cls in lib.STACKABLE:
            limit = float(self.opt.get("stack_height_m", 1.6))
            max_layers = max(1, int(limit // height))
            layers = int(self.rng.integers(1, max_layers + 1))
        for k in range(layers):
            self.add(cls, v, _transform(yaw, cx - ox, cy - oy, k * (height + 0.001)), f"{reg.type}_{i}_{k}")
        if cls == "pallet" and self.opt.get("clutter") and self.rng.random() < float(self.opt["clutter"]):
            self.add("klt", "6428", _transform(yaw, cx - ox, cy - oy, layers * (height + 0.001)), f"{reg.type}_{i}_klt")


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
            if not isinstance(e, dict) or "path" not in e or set(e) - {"path", "variant", "units", "up"}:
                raise ConfigError(f"scene.assets.{cls}[{k}]: expected a file path or "
                                  f'{{"path", "variant", "units", "up"}}, got {e!r:.80}')
            try:
                cat.register(cls, e["path"], variant=e.get("variant"), units=e.get("units"),
                             up=e.get("up"))
            except ConfigError as exc:
                raise ConfigError(f"scene.assets.{cls}[{k}]: {exc}") from None
    return cat


def build_scene(layout: Layout, seed: int = 0, *, options: dict[str, Any] | None = None,
                rng: np.random.Generator | None = None, assets: Catalogue | None = None) -> Scene:
    """Build the 3D scene of ``layout``: background, then one asset per region with a group.

    ``options`` defaults to the strategy's ``scene`` section stored in ``layout.meta``;
    ``assets`` (default: the registry :func:`register_asset` fills) gives each class's variants.
    Same layout, options, assets and seed: the same scene (and the same USD bytes).
    """
    opts = check_scene_options(layout.meta.get("scene", {}) if options is None else options,
                               "build_scene options" if options is not None else "layout scene options")
    cat = _with_assets(opts.get("assets"), ASSETS if assets is None else assets)
    b = SceneBuilder(layout, opts, cat, rng=np.random.default_rng(seed) if rng is None else rng)
    b.background()
    for i, reg in enumerate(layout.leaves()):
        b.region(i, reg)
    return b.scene
