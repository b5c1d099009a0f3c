"""What the report card measures: the standard test scenes rendered through a profile and
measured with :mod:`genie_gl.card.metrics`.

:func:`measure` renders each test scene of :mod:`genie_gl.card.scenes` from the identity pose
with :func:`genie_gl.capture` (``frames`` frames of one pose: frame i's noise is drawn from
``SeedSequence([scene_seed, i])``, so the frames differ as repeated captures do). The same seed
gives the same measurements, value for value.

What is measured where (distances restricted to the profile's ``range`` effect, plus every
distance a reference figure names, and both ends of its distance range inside the profile's):

* walls at ``distances_m`` facing the camera, and at ``angles_deg`` at ``angle_distances_m``:
  the depth quality tool's metrics per frame (averaged over frames) and the temporal ones over
  the frames, all in the central ROI; for a stereo profile the sub-pixel RMS and, on the wall
  turned by ``banding_angle_deg``, the disparity banding histogram;
* steps at ``step_distances_m``: flying pixels within 3 px of the edge (a pixel more than
  max(4 sigma, 2 mm) from each surface, sigma that surface's temporal noise away from the edge),
  the edge's lateral noise and fill;
* bars at ``bars_distances_m`` and panels at ``panels_distances_m``: fill per bar and per
  material (truth masks from one ideal render of the scene).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any, Iterable

import numpy as np

from ..capture import capture, through_lens
from ..render import Renderer, shared_context
from ..sensors.camera import Sensor
from ..effects.noise import DepthNoise, RangeLimits
from . import metrics, scenes
from .references import METRICS, References

log = logging.getLogger(__name__)

EDGE_BAND_PX = 3  # flying pixels and edge fill are counted this close to the step
EDGE_CLEAR_PX = 10  # the step's noise is measured this far from its edge
FLYING_SIGMAS = 4.0
FLYING_FLOOR_M = 0.002
PANEL_ERODE_PX = 2
BANDING_BINS = 64


@dataclass(frozen=True)
class CardSettings:
    """What the card renders. Distances in metres, angles in degrees; ``frames`` frames per
    scene (>= 2, for the temporal metrics); ``roi_fraction`` the central ROI's share of width
    and height; ``seed`` seeds every scene (scene k draws from ``SeedSequence([seed, k])``)."""

    distances_m: tuple[float, ...] = (0.3, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0)
    angles_deg: tuple[float, ...] = (15.0, 30.0, 45.0, 60.0)
    angle_distances_m: tuple[float, ...] = (1.0, 2.0)
    banding_angle_deg: float = 30.0
    step_distances_m: tuple[float, ...] = (0.5, 1.0, 2.0)
    bars_distances_m: tuple[float, ...] = (1.0,)
    panels_distances_m: tuple[float, ...] = (1.0, 3.0)
    frames: int = 8
    roi_fraction: float = metrics.ROI_FRACTION
    seed: int = 0

    def __post_init__(self) -> None:
        if self.frames < 2:
            raise ValueError(
                "CardSettings.frames: need at least 2 frames for the temporal metrics, got "
                f"{self.frames}"
            )


@dataclass(frozen=True)
class Measurement:
    """One metric (a key of :data:`~genie_gl.card.references.METRICS`) at one condition:
    test scene, distance (m), angle (deg), part (a bar or panel name, else None), value in the
    metric's unit, and the frames it came from."""

    metric: str
    scene: str
    distance_m: float
    angle_deg: float
    part: str | None
    value: float
    frames: int


# -- the sensor's facts the card needs ----------------------------------------------------
def sensor_range(sensor: Sensor) -> tuple[float, float]:
    """[min, max] depth in metres of the profile's ``range`` effects (0, inf without one)."""
    lo, hi = 0.0, math.inf
    for e in sensor.effects:
        if isinstance(e, RangeLimits):
            lo, hi = max(lo, float(e.min_m)), min(hi, float(e.max_m))
    return lo, hi


def stereo_baseline(sensor: Sensor) -> float | None:
    """The baseline (m) of the profile's stereo depth-noise model, None for other sensors."""
    for e in sensor.effects:
        if isinstance(e, DepthNoise) and e.model == "stereo":
            return e.baseline(sensor)
    return None


# -- measuring ------------------------------------------------------------------------------
class _Bench:
    """Renders test scenes of one sensor in one GL context."""

    def __init__(self, sensor: Sensor, settings: CardSettings, context: Any) -> None:
        self.sensor, self.settings, self.context = sensor, settings, context
        self.rays = np.asarray(sensor.rays(), np.float64)
        self.roi = metrics.central_roi(sensor.width, sensor.height, settings.roi_fraction)
        inside = np.zeros((sensor.height, sensor.width), bool)
        inside[self.roi] = True
        self.roi_mask = inside
        self.baseline = stereo_baseline(sensor)
        self.x_half_tan = float(np.nanmax(np.abs(self.rays[..., 0])))
        self.scene_index = 0

    def frames(self, ts: scenes.TestScene) -> tuple[np.ndarray, np.ndarray]:
        """(depth stack (N, H, W) float32, ideal instance map (H, W) uint32) of a scene."""
        seed = int(
            np.random.SeedSequence([self.settings.seed, self.scene_index]).generate_state(1)[0]
        )
        self.scene_index += 1
        frames = capture(
            ts.scene, self.sensor, [ts.pose] * self.settings.frames, seed=seed, context=self.context
        )
        with Renderer(ts.scene, context=self.context) as r:
            ideal = through_lens(r.render)(self.sensor, ts.pose, depth_only=True)
        return np.stack([f.depth for f in frames]), ideal.instance


def _m(
    metric: str, ts: scenes.TestScene, value: float, frames: int, part: str | None = None
) -> Measurement:
    return Measurement(
        metric, METRICS[metric][0], ts.distance_m, ts.angle_deg, part, float(value), frames
    )


def wall_measurements(
    stack: np.ndarray,
    rays_xy: np.ndarray,
    roi: tuple[slice, slice],
    *,
    distance_m: float,
    angle_deg: float,
    focal_px: float,
    truth_m: np.ndarray | float,
    baseline_m: float | None = None,
    banding: bool = False,
) -> list[Measurement]:
    """The wall metrics of depth frames ``stack`` (N, H, W, metres) of a flat target whose
    plane crosses the optical axis at ``distance_m``, turned by ``angle_deg``: the depth
    quality tool's metrics per frame (averaged), the temporal ones over the frames, and with
    ``banding`` (and a baseline) the disparity banding; ``truth_m`` is the target's depth per
    pixel (H, W) or one number. Shared by the simulated card and a user's captures."""
    n, d = len(stack), float(distance_m)

    def m(metric: str, value: float, frames: int = n) -> Measurement:
        return Measurement(metric, "wall", d, float(angle_deg), None, float(value), frames)

    out = [m("fill_rate_pct", np.mean([metrics.fill_rate(z, roi) for z in stack]))]
    stats = []
    for z in stack:
        try:
            stats.append(
                metrics.plane_stats(
                    z, rays_xy, roi=roi, ground_truth_m=d, baseline_m=baseline_m, focal_px=focal_px
                )
            )
        except ValueError:
            pass
    if stats:
        rms = float(np.mean([s.plane_fit_rms_mm for s in stats]))
        out += [
            m("z_accuracy_pct", np.mean([s.z_accuracy_pct for s in stats]), len(stats)),
            m("plane_fit_rms_mm", rms, len(stats)),
            m("plane_fit_rms_pct", rms / (10.0 * d), len(stats)),
        ]
        if baseline_m is not None:
            out.append(
                m("subpixel_rms_px", np.mean([s.subpixel_rms_px for s in stats]), len(stats))
            )
    inside = np.zeros(stack.shape[1:], bool)
    inside[roi] = True
    try:
        t = metrics.temporal_stats(stack, inside, truth_m)
    except ValueError:
        t = None
    if t is not None:
        out += [
            m("temporal_noise_mm", t.noise_rms_mm),
            m("temporal_noise_pct", t.noise_rms_mm / (10.0 * d)),
            m("bias_mm", t.bias_mm),
            m("bias_pct", t.bias_mm / (10.0 * d)),
        ]
    if banding and baseline_m is not None:
        z = stack[:, inside].astype(np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            disparity = np.where(z > 0, focal_px * baseline_m / z, np.nan)
        if np.isfinite(disparity).any():
            b = metrics.disparity_banding(disparity, BANDING_BINS)
            out += [m("banding_occupied", b.occupied), m("banding_peak_ratio", b.peak_ratio)]
    return out


def _wall(bench: _Bench, ts: scenes.TestScene, banding: bool) -> list[Measurement]:
    stack, _ = bench.frames(ts)
    truth = ts.planes[scenes.WALL_ID].depth_along(bench.rays)
    return wall_measurements(
        stack,
        bench.rays,
        bench.roi,
        distance_m=ts.distance_m,
        angle_deg=ts.angle_deg,
        focal_px=float(bench.sensor.fx),
        truth_m=truth,
        baseline_m=bench.baseline,
        banding=banding,
    )


def _dilate_cols(mask: np.ndarray, px: int) -> np.ndarray:
    out = mask.copy()
    for k in range(1, px + 1):
        out[:, k:] |= mask[:, :-k]
        out[:, :-k] |= mask[:, k:]
    return out


def _erode(mask: np.ndarray, px: int) -> np.ndarray:
    out = mask.copy()
    for k in range(1, px + 1):
        out[k:] &= mask[:-k]
        out[:-k] &= mask[k:]
        out[:, k:] &= mask[:, :-k]
        out[:, :-k] &= mask[:, k:]
    return out


def _step(bench: _Bench, ts: scenes.TestScene) -> list[Measurement]:
    stack, ideal = bench.frames(ts)
    n, d = len(stack), ts.distance_m
    near_id = ideal == scenes.PANEL_ID
    edge = np.zeros_like(near_id)
    edge[:, :-1] = near_id[:, :-1] != near_id[:, 1:]
    rows = np.zeros(near_id.shape[0], bool)
    rows[bench.roi[0]] = True
    edge &= rows[:, None]
    if not edge.any():
        log.warning("report card: the step at %.2f m shows no edge in the ROI", d)
        return []
    band = _dilate_cols(edge, EDGE_BAND_PX)
    clear = ~_dilate_cols(edge, EDGE_CLEAR_PX) & rows[:, None]
    near = ts.planes[scenes.PANEL_ID].depth_along(bench.rays)
    far = ts.planes[scenes.WALL_ID].depth_along(bench.rays)
    truth = np.where(near_id, near, far)
    out = [_m("edge_fill_pct", ts, np.mean([metrics.fill_rate(z, mask=band) for z in stack]), n)]
    tol = []
    for surface in (near_id, ~near_id):  # each surface's own noise: stereo noise grows as z squared
        try:
            sigma = metrics.temporal_stats(stack, clear & surface, truth).noise_rms_mm / 1000.0
        except ValueError:
            sigma = 0.0
        tol.append(max(FLYING_SIGMAS * sigma, FLYING_FLOOR_M))
    counts = [metrics.flying_pixels(z, near, far, band, tol[0], tol[1]) for z in stack]
    valid = sum(v for _, v in counts)
    if valid:
        out.append(_m("flying_pixel_pct", ts, 100.0 * sum(c for c, _ in counts) / valid, n))
    r = np.flatnonzero(rows & near_id.any(axis=1))
    cols_with_edge = np.flatnonzero(edge.any(axis=0))
    cols = slice(
        max(0, int(cols_with_edge.min()) - 20),
        min(near_id.shape[1], int(cols_with_edge.max()) + 21),
    )
    split = d + scenes.STEP_M / 2
    pos = np.stack([metrics.edge_positions(z, r, cols, split) for z in stack])
    lat = metrics.lateral_noise_px(pos)
    if math.isfinite(lat):
        out.append(_m("lateral_noise_px", ts, lat, n))
    return out


def _parts(bench: _Bench, ts: scenes.TestScene) -> list[Measurement]:
    stack, ideal = bench.frames(ts)
    n = len(stack)
    out = []
    for iid, name in ts.parts.items():
        mask = ideal == iid
        if ts.kind == "panels":
            mask = _erode(mask, PANEL_ERODE_PX)
        if not mask.any():
            log.info(
                "report card: %s at %.2f m covers no pixel centre; not measured",
                name,
                ts.distance_m,
            )
            continue
        if ts.kind == "bars":
            zb = ts.planes[iid].depth_along(bench.rays)
            hit = [
                ((z > 0) & (np.abs(z - zb) < scenes.BAR_GAP_M / 2) & mask).sum() / mask.sum()
                for z in stack
            ]
            out.append(_m("bar_fill_pct", ts, 100.0 * float(np.mean(hit)), n, name))
        else:
            out.append(
                _m(
                    "panel_fill_pct",
                    ts,
                    np.mean([metrics.fill_rate(z, mask=mask) for z in stack]),
                    n,
                    name,
                )
            )
    return out


def _distances(
    grid: Iterable[float], lo: float, hi: float, extra: Iterable[float] = ()
) -> list[float]:
    inside = [float(d) for d in grid if lo - 1e-9 <= d <= hi + 1e-9]
    return sorted(set(inside) | {float(d) for d in extra})


def measure(
    sensor: Sensor,
    settings: CardSettings | None = None,
    *,
    references: References | None = None,
    context: Any = None,
) -> list[Measurement]:
    """Every measurement of the card for ``sensor`` (see the module docstring). ``context``:
    a GL context to render in (None: this process's shared one)."""
    settings = settings or CardSettings()
    ctx = context if context is not None else shared_context()
    bench = _Bench(sensor, settings, ctx)
    lo, hi = sensor_range(sensor)
    want: dict[tuple[str, float], set[float]] = {}
    for f in references.figures if references is not None else ():
        ends = (
            [f.distance_m]
            if f.distance_m is not None
            else [max(f.distance_range_m[0], lo), min(f.distance_range_m[1], hi)]
        )
        want.setdefault((f.scene, f.angle_deg), set()).update(
            d for d in ends if math.isfinite(d) and d > 0
        )
    out: list[Measurement] = []
    for d in _distances(settings.distances_m, lo, hi, want.get(("wall", 0.0), ())):
        out += _wall(bench, scenes.wall(d, 0.0), banding=False)
    for a in sorted(set(settings.angles_deg) | {a for (s, a) in want if s == "wall" and a > 0}):
        for d in _distances(settings.angle_distances_m, lo, hi, want.get(("wall", a), ())):
            out += _wall(
                bench, scenes.wall(d, a), banding=abs(a - settings.banding_angle_deg) < 1e-9
            )
    for d in _distances(settings.step_distances_m, lo, hi, want.get(("step", 0.0), ())):
        out += _step(bench, scenes.step(d))
    for d in _distances(settings.bars_distances_m, lo, hi, want.get(("bars", 0.0), ())):
        out += _parts(bench, scenes.bars(d, bench.x_half_tan))
    for d in _distances(settings.panels_distances_m, lo, hi, want.get(("panels", 0.0), ())):
        out += _parts(bench, scenes.panels(d, bench.x_half_tan))
    return out


__all__ = [
    "CardSettings",
    "Measurement",
    "measure",
    "sensor_range",
    "stereo_baseline",
    "wall_measurements",
]
