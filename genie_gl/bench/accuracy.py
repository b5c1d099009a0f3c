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
and ``accuracy.md`` (the table in Markdown); ``--budget-mm`` / ``--budget-px`` also write ``accuracy.yaml``, the fastest
setting within the budget, as an ``accuracy:`` block that ``genie dataset --accuracy`` reads.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError
from .knobs import KNOBS, PLACEMENT_DEFAULT, PLACEMENT_LEVELS, Case, Knob, Setting, exact_setting, levels

log = logging.getLogger(__name__)
PLACEMENT_CAMERAS = 12
ERROR_KEYS = ("depth_median_mm", "depth_p99_mm", "p2s_mean_mm", "id_pct", "silhouette_pct", "edge_px",
              "sampling_mm")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scene", default=None,
                   help="USD stage, or layout / strategy JSON (default: the built-in analytic case)")
    p.add_argument("--sensor", default=None, help="sensor profile or calibration (default: the built-in "
                                                   "rational-lens sensor; ideal_pinhole-like otherwise)")
    p.add_argument("--seed", type=int, default=0, help="seed of the layout, scene, placement and noise")
    views = p.add_mutually_exclusive_group()
    views.add_argument("--cameras", type=int, default=3, help="cameras placed over the scene (default 3)")
    views.add_argument("--poses", default=None, help="JSON list of 4x4 world_from_camera, or .npy (N, 4, 4)")
    p.add_argument("--repeats", type=int, default=5, help="timed passes per row after one warm-up (default 5)")
    p.add_argument("--budget-mm", type=float, default=None, help="depth error budget (p99, mm)")
    p.add_argument("--budget-px", type=float, default=None, help="silhouette budget (mean edge error, px)")
    p.add_argument("--knobs", default=None, help="comma-separated subset of knobs to run (default: all)")
    p.add_argument("--no-cache", action="store_true",
                   help="render the exact reference again (default: reuse OUT/cache/reference-*.npz of the same inputs)")


# -- the case -----------------------------------------------------------------------------------
def _takes(fn: Any, name: str) -> bool:
    import inspect

    return name in inspect.signature(fn).parameters


def _poses(path: str) -> list[np.ndarray]:
    p = Path(path)
    try:
        arr = np.load(p) if p.suffix == ".npy" else np.array(json.loads(p.read_text()), dtype=np.float64)
    except (OSError, ValueError) as exc:
        raise ConfigError(f"--poses {p}: cannot read poses ({exc})") from None
    arr = np.asarray(arr, dtype=np.float64)
    if arr.ndim != 3 or arr.shape[1:] != (4, 4) or not len(arr) or not np.isfinite(arr).all():
        raise ConfigError(f"--poses {p}: expected a list of finite 4x4 matrices, got shape {arr.shape}")
    return list(arr)


def content_poses(scene, n: int, *, distance_m: float = 4.0, height_m: float = 3.0) -> list[np.ndarray]:
    """``n`` views of a scene with no layout, aimed at its objects: the centres of labelled
    instances (semantic > 0; all when none is) spread by farthest-point sampling from the one
    nearest the middle, each seen from ``distance_m`` further out and ``height_m`` above it."""
    from ..sensors.pose import look_at

    inst = [i for i in scene.instances if i.semantic > 0] or list(scene.instances)
    if not inst:
        raise ConfigError("--scene: the stage has no geometry to look at")
    centres = []
    for i in inst:
        b = scene.meshes[i.mesh].bounds
        c = (b[0] + b[1]) / 2 if np.all(np.isfinite(b)) else np.zeros(3)
        centres.append(i.world_from_model[:3, :3] @ c + i.world_from_model[:3, 3])
    centres = np.array(centres)
    lo, hi = scene.bounds()
    mid = (lo + hi) / 2
    chosen = [int(np.argmin(np.linalg.norm(centres[:, :2] - mid[:2], axis=1)))]
    dist = np.linalg.norm(centres - centres[chosen[0]], axis=1)
    while len(chosen) < min(n, len(centres)):
        chosen.append(int(np.argmax(dist)))
        dist = np.minimum(dist, np.linalg.norm(centres - centres[chosen[-1]], axis=1))
    poses = []
    for k in range(n):
        t = centres[chosen[k % len(chosen)]]
        out = t[:2] - mid[:2]
        angle = np.arctan2(out[1], out[0]) if np.linalg.norm(out) > 1e-6 else 0.0
        angle += 2 * np.pi * (k // len(chosen)) / max(1, -(-n // len(chosen)))
        eye = [t[0] + distance_m * np.cos(angle), t[1] + distance_m * np.sin(angle), lo[2] + height_m + t[2] - lo[2]]
        poses.append(look_at(eye, t))
    return poses


def make_case(args: argparse.Namespace) -> Case:
    """The scene, sensor and poses the rows run on."""
    from ..sensors import load_sensor

    if args.cameras is not None and args.cameras < 1:
        raise ConfigError(f"--cameras: expected >= 1, got {args.cameras}")
    if args.repeats < 1:
        raise ConfigError(f"--repeats: expected >= 1, got {args.repeats}")
    if args.scene is None:
        from . import analytic

        sensor = analytic.sensor() if args.sensor is None else load_sensor(args.sensor)
        poses = _poses(args.poses) if args.poses else [np.eye(4)]
        return Case("builtin", "built-in analytic scene (wall, floor, box, sphere)", sensor, poses,
                    lambda t: analytic.scene(analytic.DEFAULT_SEGMENTS if t is None else t), tessellation_supported=True)
    sensor = load_sensor(args.sensor or "ideal_pinhole")
    path = Path(args.scene)
    if not path.exists():
        from ..resources import resolve

        path = Path(resolve(args.scene, "layouts", (".json",)))
    if path.suffix.lower() in (".usd", ".usda", ".usdc", ".usdz"):
        from ..scene import usd

        supported = _takes(usd.read_usd, "segments")

        def usd_scene(t: int | None):
            return usd.read_usd(path, segments=t) if (supported and t is not None) else usd.read_usd(path)

        scene0 = usd_scene(None)
        poses = _poses(args.poses) if args.poses else content_poses(scene0, args.cameras)
        return Case("usd", str(path), sensor, poses, _cached(usd_scene, scene0), tessellation_supported=supported)
    if path.suffix.lower() != ".json":
        raise ConfigError(f"--scene {path}: expected a USD stage (.usd/.usda/.usdc) or a layout / strategy JSON")
    from ..layout import Layout, generate_layout
    from ..scene import build_scene
    from ..sensors import place_sensors

    data = json.loads(path.read_text())
    layout = Layout.from_json(path) if isinstance(data, dict) and "nodes" in data else generate_layout(path, seed=args.seed)
    supported = _takes(build_scene, "segments")

    def built(t: int | None):
        if supported and t is not None:
            return build_scene(layout, seed=args.seed, segments=t)
        return build_scene(layout, seed=args.seed)

    poses = _poses(args.poses) if args.poses else place_sensors(layout, sensor, n=args.cameras, seed=args.seed)
    return Case("strategy", str(path), sensor, poses, _cached(built, built(None)), layout=layout,
                tessellation_supported=supported)


def _cached(fn, first):
    memo = {None: first}

    def get(t):
        if t not in memo:
            memo[t] = fn(t)
        return memo[t]
    return get


# -- running a setting ---------------------------------------------------------------------------
def scaled(sensor, r: float):
    """``sensor`` at ``r`` times its resolution (pixel centres kept at integers)."""
    if r == 1:
        return sensor
    W, H = max(2, int(round(sensor.width * r))), max(2, int(round(sensor.height * r)))
    sx, sy = W / sensor.width, H / sensor.height
    K = sensor.K.copy()
    K[0, :2] *= sx
    K[1, 1] *= sy
    K[0, 2] = (sensor.cx + 0.5) * sx - 0.5
    K[1, 2] = (sensor.cy + 0.5) * sy - 0.5
    return dataclasses.replace(sensor, width=W, height=H, K=K, name=f"{sensor.name}@{r:g}x")


def without(sensor, drop):
    return dataclasses.replace(sensor, effects=tuple(e for e in sensor.effects if not drop(e)))


class Runner:
    """Runs settings on a case; caches timings per setting and error frames per (setting, mode).

    Settings are timed side by side (:meth:`time_many`): after one warm-up pass each, the
    repeats go round the settings in turn, each round starting one setting later, so a slow
    spell of a shared machine falls on every row alike. One GL context serves every renderer
    (one per scene variant and renderer option); :meth:`close` frees them.
    """

    def __init__(self, case: Case, repeats: int, seed: int) -> None:
        self.case, self.repeats, self.seed = case, repeats, seed
        self.timings: dict = {}
        self.frames: dict = {}
        self._gl = None
        self._renderers: dict = {}

    def _renderer(self, setting: Setting):
        from ..render import Renderer, create_context
        from ..render.supersample import renderer_options

        opts = renderer_options(setting.accuracy)
        key = (setting.accuracy.tessellation, tuple(sorted(opts.items())))
        if key not in self._renderers:
            if self._gl is None:
                self._gl = create_context(None)
            scene = self.case.scene_for(setting.accuracy.tessellation)
            self._renderers[key] = Renderer(scene, context=self._gl, **opts)
        return self._renderers[key]

    def close(self) -> None:
        for r in self._renderers.values():
            r.release()
        self._renderers = {}
        if self._gl is not None:
            self._gl.release()
            self._gl = None

    def _render_fn(self, setting: Setting):
        from ..render.supersample import supersampled

        return supersampled(self._renderer(setting).render, setting.accuracy.supersample)

    def time_many(self, settings: list[Setting]) -> None:
        """Time every setting not timed yet, side by side (see the class docstring)."""
        todo = list({s.key(): s for s in settings if s.key() not in self.timings}.values())
        if todo:
            self.timings.update(zip([s.key() for s in todo], self.side_by_side(todo)))

    def side_by_side(self, todo: list[Setting]) -> list[dict]:
        """Per setting, the median and IQR of each part's ms per frame, timed in turns."""
        from tqdm import tqdm

        jobs = [(s, self._render_fn(s), self._sensor(s, None)) for s in todo]
        bar = tqdm(total=len(jobs) * (self.repeats + 1), desc="timing settings in turns", unit="pass",
                   disable=None, leave=False)
        for s, render, sensor in jobs:              # warm-up: shaders, buffers, caches
            self._pass(render, sensor, s.accuracy)
            bar.update()
        per: dict = {s.key(): [] for s in todo}
        for k in range(self.repeats):
            for j in range(len(jobs)):
                s, render, sensor = jobs[(j + k) % len(jobs)]
                per[s.key()].append(self._pass(render, sensor, s.accuracy)[1])
                bar.update()
        bar.close()
        out = []
        for runs in per.values():
            names = sorted({n for c in runs for n in c})
            out.append({n: _spread([c.get(n, 0.0) for c in runs]) for n in names})
        return out

    def _sensor(self, setting: Setting, mode: str | None):
        from ..accuracy import apply_to_sensor

        s = apply_to_sensor(scaled(self.case.sensor, setting.resolution), setting.accuracy)
        if mode == "analytic":
            return without(s, lambda e: True)
        if mode == "exact":
            return without(s, lambda e: getattr(e, "draws", False))
        return s

    def _pass(self, render, sensor, acc, normals: bool = False):
        from ..accuracy import frame_cost, simulate_options
        from ..cloud.unproject import unproject
        from ..render.batch import pose_rng
        from ..sensors.simulate import simulate

        if normals:
            base = render

            def render(s, p, **kw):  # noqa: E306 - the reference's normals, for point-to-surface
                return base(s, p, **{**kw, "normals": True})
        frames, costs = [], defaultdict(float)
        for i, pose in enumerate(self.case.poses):
            t0 = time.perf_counter()
            f = simulate(sensor, np.asarray(pose, np.float64), render=render, rng=pose_rng(self.seed, i),
                         **simulate_options(simulate, acc))
            t1 = time.perf_counter()
            unproject(f)
            t2 = time.perf_counter()
            cost = frame_cost(f.meta or {})
            total = 1e3 * (t1 - t0)
            cost["render"] = total - sum(v for k, v in cost.items() if k != "render")
            cost["unprojection"] = 1e3 * (t2 - t1)
            cost["total"] = total + cost["unprojection"]
            for k, v in cost.items():
                costs[k] += v / len(self.case.poses)
            frames.append(f)
        return frames, dict(costs)

    def run(self, setting: Setting, modes: tuple[str, ...], timed: bool = True) -> None:
        """Time ``setting`` (unless done, or not ``timed``) and make its error frames for each mode."""
        if timed:
            self.time_many([setting])
        key = setting.key()
        for m in modes:
            if (key, m) in self.frames:
                continue
            render = self._render_fn(setting)
            sensor = self._sensor(setting, "exact" if m == "reference" else m)
            frames, _ = self._pass(render, sensor, setting.accuracy)
            if m == "reference":
                ideal, _ = self._pass(render, without(sensor, lambda e: True), setting.accuracy, normals=True)
                frames = list(zip(frames, ideal))
            self.frames[(key, m)] = frames


def _spread(v: list[float]) -> dict[str, float]:
    q1, med, q3 = np.percentile(v, [25, 50, 75])
    return {"median": float(med), "iqr": float(q3 - q1)}


def cache_key(case: Case, setting: Setting, seed: int) -> str:
    """What the exact reference depends on: the scene file's bytes (or the built-in scene's
    code), the sensor (size, K, lens, effects and their parameters), the poses, the seed, the
    exact setting and the package version."""
    import hashlib

    from .. import __version__

    h = hashlib.sha256()
    if case.kind == "builtin":
        from . import analytic

        h.update(Path(analytic.__file__).read_bytes())
    else:
        h.update(Path(case.source).read_bytes())
    s = case.sensor
    h.update(repr((s.width, s.height, s.K.tobytes(), s.dist.tobytes(), s.near_m, s.far_m, s.effects,
                   sorted((k, str(v)) for k, v in s.meta.items()), seed, setting.key(), __version__)).encode())
    for pose in case.poses:
        h.update(np.asarray(pose, np.float64).tobytes())
    return h.hexdigest()[:20]


def references(runner: Runner, cache: Path | None = None) -> dict[str, list[dict]]:
    """The reference of each mode: "exact" (the most exact setting, rendered once and kept in
    ``cache``, a folder, for the next run with the same inputs) and, for the built-in case,
    "analytic"."""
    from ..frame import Frame
    from ..sensors.geometry import pixel_rays, surface_normals

    case = runner.case
    exact = exact_setting(case)
    path = None if cache is None else cache / f"reference-{cache_key(case, exact, runner.seed)}.npz"
    if path is not None and path.exists():
        with np.load(path) as z:
            sensor = runner._sensor(exact, "exact")
            pairs = []
            for i, pose in enumerate(case.poses):
                f = Frame(z[f"depth{i}"], z[f"instance{i}"], z[f"semantic{i}"], None, sensor, pose)
                ideal = Frame(z[f"idepth{i}"], z[f"iinstance{i}"], z[f"isemantic{i}"], None, sensor, pose,
                              z[f"inormal{i}"])
                pairs.append((f, ideal))
        runner.frames[(exact.key(), "reference")] = pairs
        log.info("reference read from %s", path)
    else:
        runner.run(exact, ("reference",), timed=False)
        if path is not None:
            arrays = {}
            for i, (f, ideal) in enumerate(runner.frames[(exact.key(), "reference")]):
                arrays |= {f"depth{i}": f.depth, f"instance{i}": f.instance, f"semantic{i}": f.semantic,
                           f"idepth{i}": ideal.depth, f"iinstance{i}": ideal.instance,
                           f"isemantic{i}": ideal.semantic, f"inormal{i}": ideal.normal}
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(f".{path.stem}.tmp.npz")
            np.savez_compressed(tmp, **arrays)
            tmp.replace(path)
    refs = {"exact": [{"depth": f.depth, "instance": f.instance, "semantic": f.semantic,
                       "normal": surface_normals(ideal)} for f, ideal in runner.frames[(exact.key(), "reference")]]}
    if case.kind == "builtin":
        from . import analytic

        rays = pixel_rays(case.sensor)
        refs["analytic"] = []
        for pose in case.poses:
            if not np.allclose(pose, np.eye(4)):
                raise ConfigError("the built-in case's analytic truth is for the identity pose: give no --poses")
            refs["analytic"].append(analytic.truth(case.sensor, rays))
    return refs


# -- the bench --------------------------------------------------------------------------------
def row_for(runner: Runner, knob: Knob | None, value: Any, setting: Setting, mode: str, refs: dict) -> dict:
    from .accuracy_errors import compare, pool

    runner.run(setting, (mode,))
    parts = [compare(f, ref, runner.case.sensor) for f, ref in zip(runner.frames[(setting.key(), mode)], refs[mode])]
    return {"knob": knob.name if knob else "budget", "title": knob.title if knob else "budget pick",
            "level": knob.label(value) if knob else setting.accuracy.label(), "value": value,
            "resolution": setting.resolution, "settings": setting.accuracy.to_dict(),
            "is_default": setting.key() == Setting().key(),
            "reference": {"analytic": "analytic truth", "exact": "exact setting"}[mode],
            "available": True, "time_ms": runner.timings[setting.key()], "errors": pool(parts)}


def noise_rows(runner: Runner) -> list[dict]:
    """σ measured against the model's, per depth-noise effect of the sensor."""
    from .accuracy_errors import noise_check

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
    from ..sensors.placement import CoverageProblem, genetic_placement, greedy_placement

    problem = CoverageProblem(case.layout, 6.0)
    n = max(len(case.poses), PLACEMENT_CAMERAS)   # a few cameras leave a search nothing to find
    rows = []
    for gens, popn in PLACEMENT_LEVELS:
        ts, cov = [], 0.0
        for _ in range(min(repeats, 3) + 1):
            t = time.perf_counter()
            res = (greedy_placement(problem, n) if gens == 0 else
                   genetic_placement(problem, n, rng=np.random.default_rng(seed), population=popn, generations=gens))
            ts.append(time.perf_counter() - t)
            cov = res.coverage
        rows.append({"generations": gens, "population": popn, "label": "greedy" if gens == 0 else f"{gens}x{popn}",
                     "is_default": (gens, popn) == PLACEMENT_DEFAULT, "coverage_pct": 100.0 * cov,
                     "cameras": n, "seconds": _spread(ts[1:])})
    return rows


def run(args: argparse.Namespace) -> int:
    case = make_case(args)
    chosen = KNOBS
    if args.knobs:
        names = [s.strip() for s in args.knobs.split(",") if s.strip()]
        unknown = [n for n in names if n not in {k.name for k in KNOBS}]
        if unknown:
            raise ConfigError(f"--knobs: unknown {', '.join(unknown)}; expected some of "
                              f"{', '.join(k.name for k in KNOBS)}")
        chosen = tuple(k for k in KNOBS if k.name in names)
    runner = Runner(case, args.repeats, args.seed)
    try:
        return _run(args, case, chosen, runner)
    finally:
        runner.close()


def _run(args: argparse.Namespace, case: Case, chosen: tuple[Knob, ...], runner: Runner) -> int:
    from .accuracy_budget import pick
    from .accuracy_plot import pareto, plot

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
            rows.append(row_for(runner, knob, value, knob.setting(value), mode, refs) | {"level": label})
    result: dict[str, Any] = {
        "case": {"kind": case.kind, "source": case.source, "sensor": case.sensor.name,
                 "effects": [e.name for e in case.sensor.effects], "cameras": len(case.poses),
                 "repeats": args.repeats, "seed": args.seed,
                 "size": [case.sensor.width, case.sensor.height],
                 "reference": ("analytic truth for geometric knobs, the exact setting for effect knobs"
                               if case.kind == "builtin" else "the exact setting: " + exact_setting(case).accuracy.label())},
        "rows": rows, "noise": noise_rows(runner),
        "placement": placement_rows(case, args.repeats, args.seed) if case.layout is not None else [],
    }
    result["pareto"] = pareto(rows)
    if args.budget_mm is not None or args.budget_px is not None:
        result["budget"] = pick(runner, rows, refs, args.budget_mm, args.budget_px, row_for)
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
        from ..accuracy import AccuracySettings, write_accuracy

        b = result["budget"]
        write_accuracy(out / "accuracy.yaml", AccuracySettings(**b["settings"]), comment=b["comment"])
        print(f"budget: {b['comment'].splitlines()[0]} -> {out / 'accuracy.yaml'}")
    print(f"wrote {out / 'accuracy.json'} and {out / 'accuracy.png'} ({result['wall_s']:.0f} s)")
    return 0


def _json(o: Any) -> Any:
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(type(o).__name__)


def markdown(result: dict) -> str:
    """The rows as a Markdown table (what ``accuracy.md`` holds, for a README or a report)."""
    out = ["| knob | level | ms/frame (IQR) | render ms | effects ms | dz p99 mm | p2s mm | id % | sil % | "
           "edge px | gap mm | reference |", "|" + " --- |" * 12]
    for r in result["rows"]:
        if not r["available"]:
            out.append(f"| {r['title']} | — | unavailable: {r['reason']} |" + " |" * 9)
            continue
        t, e = r["time_ms"], r["errors"]
        eff = sum(v["median"] for k, v in t.items() if k.startswith("effect:") or k == "distortion")
        out.append(f"| {r['title']} | {r['level']}{' (default)' if r['is_default'] else ''} | "
                   f"{t['total']['median']:.0f} ({t['total']['iqr']:.0f}) | {t['render']['median']:.0f} | {eff:.0f} | "
                   f"{e['depth_p99_mm']:.2f} | {e['p2s_mean_mm']:.2f} | {e['id_pct']:.2f} | {e['silhouette_pct']:.1f} | "
                   f"{e['edge_px']:.3f} | {e['sampling_mm']:.2f} | {r['reference']} |")
    return "\n".join(out) + "\n"


def print_table(result: dict) -> None:
    c = result["case"]
    print(f"accuracy on {c['source']}, sensor {c['sensor']} {c['size'][0]}x{c['size'][1]} "
          f"({', '.join(c['effects']) or 'no effects'}), {c['cameras']} cameras, {c['repeats']} repeats")
    print(f"reference: {c['reference']}; errors with noise off (noise checked below)")
    parts = sorted({k for r in result["rows"] if r["available"] for k in r["time_ms"]
                    if k.startswith("effect:") or k == "distortion"})
    names = [k.split(":", 1)[-1][:9] for k in parts]
    head = (f"{'knob':<30}{'level':>8}{'ms/frame':>9}{'IQR':>6}{'render':>7}" + "".join(f"{n:>10}" for n in names)
            + f"{'unproj':>7}{'dz med':>7}{'dz p99':>7}{'p2s':>6}{'id %':>6}{'sil %':>6}{'edge px':>8}{'gap mm':>7}  ref")
    print(head)
    print("-" * len(head))
    for r in result["rows"]:
        if not r["available"]:
            print(f"{r['title']:<30}{'—':>8}  unavailable: {r['reason']}")
            continue
        t, e = r["time_ms"], r["errors"]
        mark = " *" if r["is_default"] else ""
        cells = "".join(f"{t[k]['median'] if k in t else 0.0:>10.1f}" for k in parts)
        print(f"{r['title']:<30}{r['level'] + mark:>8}{t['total']['median']:>9.1f}{t['total']['iqr']:>6.1f}"
              f"{t['render']['median']:>7.1f}{cells}{t['unprojection']['median']:>7.1f}"
              f"{e['depth_median_mm']:>7.3f}{e['depth_p99_mm']:>7.2f}{e['p2s_mean_mm']:>6.2f}{e['id_pct']:>6.2f}"
              f"{e['silhouette_pct']:>6.1f}{e['edge_px']:>8.3f}{e['sampling_mm']:>7.2f}  {r['reference']}")
    print("(* default; ms: median per frame over repeats, IQR its spread, then the median ms of the render and "
          "of each effect; dz: |depth error| mm where ids agree; "
          "p2s: mean point-to-surface mm; id %: pixels whose instance differs; sil %: on silhouettes; "
          "edge px: mean silhouette displacement; gap mm: median distance from the reference surface to the cloud)")
    for n in result["noise"]:
        cells = ", ".join(f"z {b['z_m']:.2f} m: {b['measured_mm']:.2f} vs {b['model_mm']:.2f} mm" for b in n["bins"])
        print(f"noise {n['effect']} {n['model']}: measured σ vs model σ — {cells}")
    for p in result["placement"]:
        print(f"placement {p['label']:>8} ({p['cameras']} cameras): coverage {p['coverage_pct']:.2f} % in "
              f"{1e3 * p['seconds']['median']:.1f} ms (IQR {1e3 * p['seconds']['iqr']:.1f}){' *' if p['is_default'] else ''}")
    if "budget" in result:
        print(f"budget pick: {result['budget']['comment'].splitlines()[0]}")
