"""Running settings on a case: side-by-side timing, error frames, the cached exact reference."""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
from tqdm import tqdm

from .. import __version__
from ..capture.lens import through_lens
from ..capture.serial import pose_rng
from ..capture.settings import apply_to_sensor, level_of_detail
from ..capture.supersample import supersampled
from ..cloud.unproject import unproject
from ..errors import ConfigError
from ..frame import Frame
from ..render import Renderer, create_context
from ..scene.materials import MaterialTable
from ..effects.geometry import pixel_rays, surface_normals
from ..effects.simulate import simulate
from . import analytic
from .knobs import Case, Setting, exact_setting

log = logging.getLogger(__name__)


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
        self._materials: dict = {}

    def _renderer(self, setting: Setting):
        """The renderer of the setting's scene (its tessellation), raster, depth precision and
        level of detail, as a capture with these settings makes it (the GL raster unless the
        setting asks for the CPU one: the depth precisions are GL's)."""
        acc = setting.accuracy
        raster = acc.raster or "gl"
        key = (acc.tessellation, raster, acc.depth_precision, acc.lod_px)
        if key not in self._renderers:
            if self._gl is None and raster == "gl":
                self._gl = create_context(None)
            scene = self.case.scene_for(acc.tessellation)
            self._renderers[key] = Renderer(
                scene,
                context=self._gl if raster == "gl" else None,
                depth_precision=acc.depth_precision,
                lod=level_of_detail(acc),
                raster=raster,
            )
            self._materials[key] = _materials(scene)
        return self._renderers[key]

    def close(self) -> None:
        for r in self._renderers.values():
            r.release()
        self._renderers = {}
        if self._gl is not None:
            self._gl.release()
            self._gl = None

    def _render_fn(self, setting: Setting):
        """The setting's render function, carrying its scene's material table (effects that
        read materials get the scene's, as in a capture)."""
        r = self._renderer(setting)
        fn = supersampled(through_lens(r.render), setting.accuracy.supersample)
        key = next(k for k, v in self._renderers.items() if v is r)
        return _WithMaterials(fn, self._materials[key])

    def time_many(self, settings: list[Setting]) -> None:
        """Time every setting not timed yet, side by side (see the class docstring)."""
        todo = list({s.key(): s for s in settings if s.key() not in self.timings}.values())
        if todo:
            self.timings.update(zip([s.key() for s in todo], self.side_by_side(todo)))

    def side_by_side(self, todo: list[Setting]) -> list[dict]:
        """Per setting, the median and IQR of each part's ms per frame, timed in turns."""
        jobs = [(s, self._render_fn(s), self._sensor(s, None)) for s in todo]
        bar = tqdm(
            total=len(jobs) * (self.repeats + 1),
            desc="timing settings in turns",
            unit="pass",
            disable=None,
            leave=False,
        )
        for s, render, sensor in jobs:  # warm-up: shaders, buffers, caches
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
            out.append({n: spread([c.get(n, 0.0) for c in runs]) for n in names})
        return out

    def _sensor(self, setting: Setting, mode: str | None):
        s = apply_to_sensor(scaled(self.case.sensor, setting.resolution), setting.accuracy)
        if mode == "analytic":
            return without(s, lambda e: True)
        if mode == "exact":
            return without(s, lambda e: getattr(e, "draws", False))
        return s

    def _pass(self, render, sensor, acc, normals: bool = False):
        """Every pose once: the frames, and the mean ms per frame of the render (all but the
        effects), of each effect (timed here, whatever simulate records), of the lens remap
        where simulate reports it apart, and of the unprojection."""
        materials = getattr(render, "materials", None)
        if normals:
            base = render

            def render(s, p, **kw):  # noqa: E306 - the reference's normals, for point-to-surface
                return base(s, p, **{**kw, "normals": True})

            if hasattr(base, "lens"):
                render.lens = lambda s, p, **kw: base.lens(s, p, **{**kw, "normals": True})
        clock: dict[str, float] = defaultdict(float)
        timed = dataclasses.replace(sensor, effects=tuple(Timed(e, clock) for e in sensor.effects))
        options = {"resample": acc.resample, "oversample": acc.oversample}
        if materials is not None:
            options["materials"] = materials
        frames, costs = [], defaultdict(float)
        for i, pose in enumerate(self.case.poses):
            clock.clear()
            t0 = time.perf_counter()
            f = simulate(
                timed,
                np.asarray(pose, np.float64),
                render=render,
                rng=pose_rng(self.seed, i),
                **options,
            )
            t1 = time.perf_counter()
            unproject(f)
            t2 = time.perf_counter()
            cost = dict(clock)
            lens = (f.meta or {}).get("cost_ms", {}).get("distortion")
            if lens is not None:
                cost["distortion"] = lens
            total = 1e3 * (t1 - t0)
            cost["render"] = total - sum(cost.values())
            cost["unprojection"] = 1e3 * (t2 - t1)
            cost["total"] = total + cost["unprojection"]
            for k, v in cost.items():
                costs[k] += v / len(self.case.poses)
            frames.append(f.replace(sensor=sensor) if f.sensor is timed else f)
        return frames, dict(costs)

    def run(self, setting: Setting, modes: tuple[str, ...], timed: bool = True) -> None:
        """Time ``setting`` (unless done, or not ``timed``) and make its error frames for each
        mode."""
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
                ideal, _ = self._pass(
                    render, without(sensor, lambda e: True), setting.accuracy, normals=True
                )
                frames = list(zip(frames, ideal))
            self.frames[(key, m)] = frames


def _materials(scene):
    """The scene's material table."""
    return MaterialTable.from_scene(scene)


class _WithMaterials:
    """A render function that also carries the material table of the scene it renders."""

    def __init__(self, fn, materials) -> None:
        self.fn, self.materials = fn, materials
        if hasattr(
            fn, "lens"
        ):  # a supersampled render: the exact lens mode supersamples through the lens
            self.lens = fn.lens

    def __call__(self, *a, **kw):
        return self.fn(*a, **kw)


class Timed:
    """An effect that adds the milliseconds of each of its runs to ``clock["effect:<name>"]``;
    everything else (name, needs, check, skip, parameters) is the effect's own."""

    def __init__(self, effect, clock: dict) -> None:
        self._effect, self._clock = effect, clock

    def __getattr__(self, name: str):
        return getattr(self._effect, name)

    def apply(self, frame, *, rng, **kw):
        t = time.perf_counter()
        try:
            return self._effect.apply(frame, rng=rng, **kw)
        finally:
            self._clock[f"effect:{self._effect.name}"] += 1e3 * (time.perf_counter() - t)


def spread(v: list[float]) -> dict[str, float]:
    """Median and interquartile range of ``v``."""
    q1, med, q3 = np.percentile(v, [25, 50, 75])
    return {"median": float(med), "iqr": float(q3 - q1)}


def cache_key(case: Case, setting: Setting, seed: int) -> str:
    """What the exact reference depends on: the scene file's bytes (or the built-in scene's
    code), the sensor (size, K, lens, effects and their parameters), the poses, the seed, the
    exact setting and the package version."""
    h = hashlib.sha256()
    if case.kind == "builtin":
        h.update(Path(analytic.__file__).read_bytes())
    else:
        h.update(Path(case.source).read_bytes())
    s = case.sensor
    h.update(
        repr(
            (
                s.width,
                s.height,
                s.K.tobytes(),
                s.dist.tobytes(),
                s.near_m,
                s.far_m,
                s.effects,
                _sensor_fields(s),
                seed,
                setting.key(),
                __version__,
            )
        ).encode()
    )
    for pose in case.poses:
        h.update(np.asarray(pose, np.float64).tobytes())
    return h.hexdigest()[:20]


def _sensor_fields(s) -> list[tuple[str, str]]:
    """The sensor's fields beside the camera and its effects, those set, as text."""
    fields = {
        "stereo": None if s.stereo is None else (s.stereo.baseline_m, s.stereo.R, s.stereo.T),
        "accuracy": s.accuracy,
        "calibration": s.calibration,
        "profile": s.profile,
        "reprojection_error_px": s.reprojection_error_px,
    }
    return sorted((k, str(v)) for k, v in fields.items() if v is not None)


def references(runner: Runner, cache: Path | None = None) -> dict[str, list[dict]]:
    """The reference of each mode: "exact" (the most exact setting, rendered once and kept in
    ``cache``, a folder, for the next run with the same inputs) and, for the built-in case,
    "analytic"."""
    case = runner.case
    exact = exact_setting(case)
    path = None if cache is None else cache / f"reference-{cache_key(case, exact, runner.seed)}.npz"
    if path is not None and path.exists():
        with np.load(path) as z:
            sensor = runner._sensor(exact, "exact")
            pairs = []
            for i, pose in enumerate(case.poses):
                f = Frame(z[f"depth{i}"], z[f"instance{i}"], z[f"semantic{i}"], None, sensor, pose)
                ideal = Frame(
                    z[f"idepth{i}"],
                    z[f"iinstance{i}"],
                    z[f"isemantic{i}"],
                    None,
                    sensor,
                    pose,
                    z[f"inormal{i}"],
                )
                pairs.append((f, ideal))
        runner.frames[(exact.key(), "reference")] = pairs
        log.info("reference read from %s", path)
    else:
        runner.run(exact, ("reference",), timed=False)
        if path is not None:
            arrays = {}
            for i, (f, ideal) in enumerate(runner.frames[(exact.key(), "reference")]):
                arrays |= {
                    f"depth{i}": f.depth,
                    f"instance{i}": f.instance,
                    f"semantic{i}": f.semantic,
                    f"idepth{i}": ideal.depth,
                    f"iinstance{i}": ideal.instance,
                    f"isemantic{i}": ideal.semantic,
                    f"inormal{i}": surface_normals(ideal).astype(np.float32),
                }
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(f".{path.stem}.tmp.npz")
            np.savez_compressed(tmp, **arrays)
            tmp.replace(path)
    refs = {
        "exact": [
            {
                "depth": f.depth,
                "instance": f.instance,
                "semantic": f.semantic,
                "normal": surface_normals(ideal).astype(np.float32),
            }  # as cached
            for f, ideal in runner.frames[(exact.key(), "reference")]
        ]
    }
    if case.kind == "builtin":
        rays = pixel_rays(case.sensor)
        refs["analytic"] = []
        for pose in case.poses:
            if not np.allclose(pose, np.eye(4)):
                raise ConfigError(
                    "the built-in case's analytic truth is for the identity pose: give no --poses"
                )
            refs["analytic"].append(analytic.truth(case.sensor, rays))
    return refs
