"""Sensor placement by a genetic algorithm over the layout's label raster (paper §3.4.1).

A sensor covers a disc of fixed radius on the floor; a chromosome is the list of the disc
centres (indices into candidate positions on a grid); fitness is the weighted area of the
union of the discs (weights per region type; background 0 by default). Elitism keeps the best
chromosome, so the best fitness never decreases across generations. The result becomes camera
poses: each camera at ``mount_height_m`` above its disc's centre, turned towards the weighted
centroid of what its disc covers and tilted down to it.

``fitness="visibility"`` counts what the cameras really see instead of discs: each candidate's
camera (the pose above) renders a low-resolution depth image of the scene (80x60 by default),
its returns are unprojected, and a raster cell of the disc counts as covered when a return
lands in it (on the floor or on whatever stands there). Racks and walls so shadow coverage,
and the field of view matters. The render comes in as a function (``Renderer(scene).render``),
so placement never imports the renderer.

Placement knows the sensor's range (its ``range`` effect): :func:`mount_for` picks the mount
height and the downward tilt so that the floor a camera covers lies within [min, max] range —
the highest mount (up to the usual 3.5 m and the ceiling) from which the top edge of the
image still meets the floor within 95 % of the maximum range, tilted as little as that
allows (the widest footprint), the disc radius the horizontal reach of that top edge. A
sensor whose range cannot reach the floor from any mount between ``min_mount_m`` and the
ceiling is refused with a one-line error, unless the caller gives ``mount_height_m``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from ..validation.arguments import check_seed, expect, finite_number, whole_number
from ..errors import ConfigError, did_you_mean
from ..layout.model import Layout, Region, RegionType
from ..limits import MAX_CAMERAS
from ..scene_options import scene_options
from . import disc_kernels as coverage
from ..motion.floor import furnished_rects, outside_rects
from ..sensors.camera import Sensor
from .bits import DiscBits, evolve
from ..sensors.pose import look_at

log = logging.getLogger(__name__)

FITNESS = ("circle", "visibility")
DEFAULT_MOUNT_M = 3.5  # above people and vehicles, below a typical hall's lights
DEFAULT_RADIUS_M = 6.0  # a sensor without a range: the disc of the paper's placement
MIN_MOUNT_M = 2.0  # lowest mount out of people's and forklifts' way [U: a site rule of thumb]
LOW_MOUNT_M = 1.5  # a camera mounted lower stands on free floor (it would sit inside furniture)
FREE_MARGIN_M = 0.25  # ... this far from any furnished region
DEFAULT_CEILING_M = 5.0  # hall height when the layout gives none (the scene stage's wall height)
CEILING_CLEARANCE_M = 0.2  # a camera hangs this far below the ceiling at most


@dataclass(frozen=True)
class Mount:
    """Where cameras go: height above the floor (m), downward tilt of the optical axis below
    the horizon (rad; None: look at the covered centroid), disc radius (m)."""

    height_m: float
    pitch_rad: float | None
    radius_m: float


def sensor_range(sensor) -> tuple[float, float] | None:
    """(min, max) range of the returns the sensor's effects let through (the first effect that
    bounds them, :meth:`Effect.range_m`: the ``range`` effect), or None when none does."""
    for eff in getattr(sensor, "effects", ()):
        bounds = eff.range_m()
        if bounds is not None:
            return bounds
    return None


def layout_ceiling(layout: Layout) -> float:
    """The hall's height: the strategy's wall height when it builds walls, else the default."""
    return ceiling_of(layout.meta.get("scene") if isinstance(layout.meta, dict) else None)


def ceiling_of(options: dict | None) -> float:
    """The hall's height from a strategy's scene options (``walls``, ``wall_height_m``): the
    wall height when it builds walls, else the default."""
    opts = scene_options(options, "scene options")
    return float(opts.wall_height_m) if opts.walls else DEFAULT_CEILING_M


def mount_for(
    sensor,
    *,
    ceiling_m: float = DEFAULT_CEILING_M,
    min_mount_m: float = MIN_MOUNT_M,
    mount_height_m: float | None = None,
    radius_m: float | None = None,
) -> Mount:
    """Mount height, tilt and disc radius that keep what ``sensor`` covers within its range.

    Raises ConfigError (one line) when no mount in [min_mount_m, ceiling_m] lets the range
    reach the floor, unless ``mount_height_m`` is given (then only the tilt is chosen).
    """
    rng = sensor_range(sensor)
    if rng is None:
        h = (
            DEFAULT_MOUNT_M
            if mount_height_m is None
            else finite_number(mount_height_m, "placement: mount_height_m", 0.0, 1e4, lo_open=True)
        )
        return Mount(h, None, DEFAULT_RADIUS_M if radius_m is None else float(radius_m))
    lo, hi = rng
    half_v = float(np.arctan2(sensor.height / 2, sensor.fy))
    reach = 0.95 * hi
    fit = reach * np.cos(half_v)  # straight down, the top edge meets the floor at `reach`
    if mount_height_m is None:
        h = min(DEFAULT_MOUNT_M, float(ceiling_m) - CEILING_CLEARANCE_M, 0.85 * fit)
        if h < min_mount_m:
            raise ConfigError(
                f"placement: sensor {sensor.name!r} (range {lo:g}-{hi:g} m, "
                f"{np.degrees(2 * half_v):.1f}° "
                f"vertical field) cannot see the floor from any mount between {min_mount_m:g} and "
                f"{ceiling_m:g} m (it needs a mount below {fit:.2f} m); give a mount height: "
                "--mount M (genie "
                f"capture, plan, dataset), mount_height_m= in the API"
            )
    else:
        h = finite_number(mount_height_m, "placement: mount_height_m", 0.0, 1e4, lo_open=True)
        if h > fit:
            log.warning(
                "placement: at %.2f m the floor lies beyond %s's %.2f m range", h, sensor.name, hi
            )
    # the least tilt whose top edge meets the floor within reach (90°: straight down)
    top = np.arcsin(min(1.0, h / reach))
    pitch = float(min(np.pi / 2, half_v + top))
    top_angle = pitch - half_v
    r = h / np.tan(top_angle) if top_angle > 1e-6 else h
    return Mount(h, pitch, float(r) if radius_m is None else float(radius_m))


@dataclass(frozen=True, eq=False)
class Placement:
    """What the search found: disc centres (n, 2) in metres, coverage share, fitness history."""

    centres: np.ndarray
    coverage: float
    history: list[float] = field(default_factory=list)


class CoverageProblem:
    """Weighted coverage of a label raster by discs at candidate positions."""

    def __init__(
        self,
        layout: Layout,
        radius_m: float,
        resolution_m: float = 0.5,
        step_m: float = 1.0,
        weights: dict[str, float] | None = None,
        free_floor: bool = False,
    ) -> None:
        if radius_m <= 0:
            raise ConfigError(f"placement: radius_m must be > 0, got {radius_m}")
        r = layout.label_raster(resolution_m)
        types = r.type_names
        w_type = np.array(
            [
                (weights or {}).get(t, 0.0 if layout.region_types[t].asset_group is None else 1.0)
                for t in types
            ]
            + [0.0]
        )
        self.weight = w_type[r.labels].ravel()  # label -1 -> last entry, 0
        H, W = r.labels.shape
        x0, y0 = r.origin_xy
        self.px = np.stack(
            np.meshgrid(
                x0 + (np.arange(W) + 0.5) * resolution_m, y0 + (np.arange(H) + 0.5) * resolution_m
            ),
            -1,
        ).reshape(-1, 2)
        bx, by, bw, bh = layout.bounds
        cx = np.arange(bx + step_m / 2, bx + bw, step_m)
        cy = np.arange(by + step_m / 2, by + bh, step_m)
        self.candidates = np.stack(np.meshgrid(cx, cy), -1).reshape(-1, 2)
        if (
            free_floor
        ):  # a low mount stands where nothing is furnished (not inside a rack or a stack)
            free = outside_rects(self.candidates, furnished_rects(layout), FREE_MARGIN_M)
            if free.any():
                self.candidates = self.candidates[free]
        keep = self.weight > 0
        self.px, self.weight = self.px[keep], self.weight[keep]
        self.shape, self.origin_xy, self.resolution_m = (H, W), (x0, y0), float(resolution_m)
        self.cell = np.full(H * W, -1, np.int64)  # raster cell (row-major) -> weighted index
        self.cell[np.flatnonzero(keep)] = np.arange(int(keep.sum()))
        # which weighted cells each candidate's disc covers, as a sparse matrix (CSR)
        self.indptr, self.indices = coverage.disc_cells(
            self.candidates[:, 0].copy(),
            self.candidates[:, 1].copy(),
            self.cell.reshape(H, W),
            float(x0),
            float(y0),
            float(resolution_m),
            float(radius_m),
        )
        self.total = float(self.weight.sum()) or 1.0
        self._stamp, self._mark = np.zeros(len(self.weight), np.int64), 0
        self._bits: tuple | None = None  # (indices they were made from, DiscBits or None)

    @property
    def cover(self) -> np.ndarray:
        """(candidates, weighted cells) bool: the discs as a dense matrix (for inspection)."""
        dense = np.zeros((len(self.candidates), len(self.weight)), bool)
        rows = np.repeat(np.arange(len(self.candidates)), np.diff(self.indptr))
        dense[rows, self.indices] = True
        return dense

    def set_cover(self, cover: np.ndarray) -> None:
        """Replace what each candidate covers by a dense (candidates, weighted cells) matrix."""
        rows, cols = np.nonzero(cover)
        self.indptr = np.r_[0, np.cumsum(np.bincount(rows, minlength=len(self.candidates)))].astype(
            np.int64
        )
        self.indices = cols.astype(np.int64)
        self._bits = None

    def disc_bits(self):
        """The discs as bit sets (:mod:`.placement_bits`: the same sums, word by word), or None
        when the weights are not whole numbers."""
        if self._bits is None or self._bits[0] is not self.indices:
            self._bits = (self.indices, DiscBits.of(self.indptr, self.indices, self.weight))
        return self._bits[1]

    def fitnesses(self, population: np.ndarray) -> np.ndarray:
        """Covered weight share of each chromosome (rows of candidate indices)."""
        bits = self.disc_bits()
        if bits is not None:
            return bits.fitnesses(population) / self.total
        w, self._mark = coverage.union_weights(
            np.ascontiguousarray(population, np.int64),
            self.indptr,
            self.indices,
            self.weight,
            self._stamp,
            self._mark,
        )
        return w / self.total

    def fitness(self, chrom: np.ndarray) -> float:
        return float(self.fitnesses(np.asarray(chrom).reshape(1, -1))[0])


class VisibilityProblem(CoverageProblem):
    """Weighted coverage by what each candidate camera sees in a low-resolution depth render.

    ``cover[k, j]`` is True when a return of candidate k's render lands in weighted cell j
    and j lies in k's disc (so visibility coverage never exceeds circle coverage); ``disc``
    keeps the circle model's cover, for comparison. Fitness, greedy and genetic search are those of
    :class:`CoverageProblem`.

    Parameters
    ----------
    render : ``render(sensor, pose, *, depth_only) -> Frame`` (e.g. ``Renderer(scene).render``).
    sensor : the camera (its pinhole K, scaled to fit ``size``); None: a 87°x68° pinhole.
    size : (width, height) bound of the low-resolution render, pixels.
    """

    def __init__(
        self,
        layout: Layout,
        radius_m: float,
        *,
        render,
        sensor=None,
        mount_height_m: float = 3.5,
        size: tuple[int, int] = (80, 60),
        resolution_m: float = 0.5,
        step_m: float = 1.0,
        weights: dict[str, float] | None = None,
        pitch_rad: float | None = None,
    ) -> None:
        super().__init__(layout, radius_m, resolution_m, step_m, weights)
        self.disc = self.cover
        self.view = low_resolution(sensor, size)
        self.poses = poses_from_centres(self, self.candidates, radius_m, mount_height_m, pitch_rad)
        cover = np.zeros_like(self.disc)
        for k, pose in enumerate(self.poses):
            depth = render(self.view, pose, depth_only=True).depth
            cover[k, self.seen(depth, pose)] = True
        self.set_cover(cover & self.disc)

    def seen(self, depth: np.ndarray, pose: np.ndarray) -> np.ndarray:
        """Weighted-cell indices hit by the returns of ``depth`` (the view's) taken at ``pose``."""
        v, u = np.nonzero(depth > 0)
        z = depth[v, u].astype(np.float64)
        x, y = self.view.rays()[v, u].T  # the camera model's pixel rays (genie_gl.camera)
        world = np.stack([x * z, y * z, z], 1) @ pose[:3, :3].T + pose[:3, 3]
        H, W = self.shape
        col = np.floor((world[:, 0] - self.origin_xy[0]) / self.resolution_m).astype(np.intp)
        row = np.floor((world[:, 1] - self.origin_xy[1]) / self.resolution_m).astype(np.intp)
        inside = (col >= 0) & (col < W) & (row >= 0) & (row < H)
        cells = self.cell[row[inside] * W + col[inside]]
        return np.unique(cells[cells >= 0])


def low_resolution(sensor, size: tuple[int, int]):
    """The pinhole camera of ``sensor`` scaled to fit in ``size`` (width, height)."""
    w_max, h_max = int(size[0]), int(size[1])
    if w_max < 2 or h_max < 2:
        raise ConfigError(f"placement: visibility size must be at least 2x2, got {size}")
    if sensor is None:  # a D435-like field of view
        return Sensor.pinhole(w_max, h_max, w_max / 2 / np.tan(np.radians(43.5)))
    s = min(w_max / sensor.width, h_max / sensor.height)
    w, h = max(2, int(round(sensor.width * s))), max(2, int(round(sensor.height * s)))
    K = sensor.K.copy()
    K[0, :] *= w / sensor.width
    K[1, :] *= h / sensor.height
    K[0, 2] = (sensor.cx + 0.5) * w / sensor.width - 0.5
    K[1, 2] = (sensor.cy + 0.5) * h / sensor.height - 0.5
    return Sensor(
        w, h, K, near_m=sensor.near_m, far_m=sensor.far_m, name=f"{sensor.name}-placement"
    )


def genetic_placement(
    problem: CoverageProblem,
    n: int,
    *,
    rng: np.random.Generator,
    population: int = 32,
    generations: int = 150,
    mutation: float = 0.05,
    seed_greedy: bool = True,
) -> Placement:
    """Maximise covered weight with ``n`` discs; tournament selection, uniform crossover,
    point mutation and one elite. ``seed_greedy`` puts the greedy solution in the first
    population, so the result is never worse than the greedy baseline."""
    m = len(problem.candidates)
    if n < 1 or m == 0:
        raise ConfigError(f"placement: need n >= 1 sensors and a non-empty layout (n={n})")
    pop = rng.integers(0, m, (population, n))
    if seed_greedy:
        pop[0] = greedy_indices(problem, n)
    fit = problem.fitnesses(pop)
    history = [float(fit.max())]
    pop = np.ascontiguousarray(pop, np.int64)
    bits = problem.disc_bits() if type(problem) is CoverageProblem else None
    if (
        bits is not None and generations > 0
    ):  # the generations compiled whole: the same draws, the same result
        pop, fit, best = evolve(
            rng,
            pop,
            fit,
            int(generations),
            m,
            float(mutation),
            bits.bits,
            bits.classes,
            bits.class_w,
            float(problem.total),
        )
        history += best.tolist()
        generations = 0
    for _ in range(generations):
        # the draws, in their order; the steps between them compiled (coverage.breed)
        a, b = rng.integers(0, population, (2, population))
        perm = rng.permutation(population)
        cross = rng.random((population, n))
        mutate = rng.random((population, n))
        draws = rng.integers(0, m, int(np.count_nonzero(mutate < mutation)))
        pop = coverage.breed(pop, fit, a, b, perm, cross, mutate, float(mutation), draws)
        fit = problem.fitnesses(pop)
        history.append(float(fit.max()))
    best = distinct(problem, pop[fit.argmax()])
    return Placement(problem.candidates[best], problem.fitness(best), history)


def distinct(problem: CoverageProblem, chosen: np.ndarray) -> np.ndarray:
    """``chosen`` candidate indices with every repeat replaced by an unused candidate, the one
    farthest from those kept (in order): two cameras never share a position. A repeat adds no
    coverage, so the covered weight never falls. With fewer candidates than cameras the
    repeats stay (:func:`poses_from_centres` then turns them apart)."""
    chosen = np.asarray(chosen, np.int64).copy()
    m = len(problem.candidates)
    _, first = np.unique(chosen, return_index=True)
    repeats = np.setdiff1d(np.arange(len(chosen)), first)
    if not len(repeats) or len(first) >= m:
        return chosen
    kept = chosen[np.sort(first)]
    used = kept.tolist()
    d = np.min(
        np.linalg.norm(problem.candidates[:, None, :] - problem.candidates[None, kept, :], axis=2),
        axis=1,
    )
    d[used] = -1.0
    for i in repeats:
        if len(used) >= m:  # every candidate used
            break
        k = int(np.argmax(d))
        chosen[i] = k
        used.append(k)
        d = np.minimum(d, np.linalg.norm(problem.candidates - problem.candidates[k], axis=1))
        d[used] = -1.0
    return chosen


def greedy_indices(problem: CoverageProblem, n: int) -> np.ndarray:
    """Candidate indices chosen greedily: each adds the most new weight."""
    bits = problem.disc_bits()
    if bits is not None:
        return bits.greedy(n)
    return coverage.greedy(int(n), problem.indptr, problem.indices, problem.weight)


def greedy_placement(problem: CoverageProblem, n: int) -> Placement:
    """Baseline: add, n times, the disc that covers the most new weight."""
    chosen = distinct(problem, greedy_indices(problem, n))
    return Placement(problem.candidates[chosen], problem.fitness(chosen))


def random_placement(problem: CoverageProblem, n: int, *, rng: np.random.Generator) -> Placement:
    """Baseline: n candidate positions drawn uniformly."""
    chosen = distinct(problem, rng.integers(0, len(problem.candidates), n))
    return Placement(problem.candidates[chosen], problem.fitness(chosen))


def poses_from_centres(
    problem: CoverageProblem,
    centres: np.ndarray,
    radius_m: float,
    mount_height_m: float,
    pitch_rad: float | None = None,
) -> list[np.ndarray]:
    """world_from_camera poses: above each centre, turned towards the weighted centroid it
    covers; tilted down to it, or by ``pitch_rad`` below the horizon when given. A centre
    given again (more cameras than candidate positions) is turned by a share of the full
    circle for each repeat, so no two cameras share a pose."""
    poses = []
    seen: dict[tuple[float, float], int] = {}
    for c in centres:
        repeat = seen.get((float(c[0]), float(c[1])), 0)
        seen[(float(c[0]), float(c[1]))] = repeat + 1
        if repeat:
            turn = (
                2 * np.pi * repeat / max(2, int(np.sum(np.all(np.asarray(centres) == c, axis=1))))
            )
        inside = ((problem.px - c) ** 2).sum(1) <= radius_m**2
        if inside.any():
            target = (problem.px[inside] * problem.weight[inside, None]).sum(0) / problem.weight[
                inside
            ].sum()
        else:
            target = c
        d = target - c
        if np.linalg.norm(d) < 0.3 * radius_m:  # nothing to turn to: look outwards at half radius
            d = np.array([1.0, 0.0]) if np.linalg.norm(d) < 1e-9 else d / np.linalg.norm(d)
            target = c + 0.5 * radius_m * d
        if repeat:  # the same view, turned about the vertical by a share of the circle
            d = target - c
            cs, sn = np.cos(turn), np.sin(turn)
            target = c + np.array([cs * d[0] - sn * d[1], sn * d[0] + cs * d[1]])
        if pitch_rad is not None:
            d = target - c
            d = d / max(float(np.linalg.norm(d)), 1e-12)
            if pitch_rad >= np.pi / 2 - 1e-9:  # straight down: keep the yaw through the up vector
                poses.append(
                    look_at([c[0], c[1], mount_height_m], [c[0], c[1], 0.0], up=(d[0], d[1], 0.0))
                )
                continue
            target = c + d * mount_height_m / np.tan(pitch_rad)
        poses.append(look_at([c[0], c[1], mount_height_m], [target[0], target[1], 0.0]))
    return poses


def place_sensors(
    layout: Layout,
    sensor=None,
    n: int = 8,
    seed: int = 0,
    *,
    radius_m: float | None = None,
    mount_height_m: float | None = None,
    method: str = "genetic",
    weights: dict[str, float] | None = None,
    fitness: str = "circle",
    render=None,
    visibility_size: tuple[int, int] = (80, 60),
    ceiling_m: float | None = None,
    min_mount_m: float = MIN_MOUNT_M,
) -> list[np.ndarray]:
    """Place ``n`` cameras over ``layout``; returns (4, 4) float64 world_from_camera poses.

    Mount height, tilt and disc radius come from the sensor's range (:func:`mount_for`, under
    ``ceiling_m``, default the layout's wall height or 5 m) unless given; a sensor without a
    range mounts at 3.5 m with 6 m discs, looking at what its disc covers.
    ``fitness`` is "circle" (discs of ``radius_m``) or "visibility" (what each camera sees in
    a ``visibility_size`` depth render made by ``render``, e.g. ``Renderer(scene).render``)::

        with gg.Renderer(scene) as r:
            poses = gg.place_sensors(layout, sensor, n=8, fitness="visibility", render=r.render)
    """
    expect(layout, Layout, "place_sensors: layout")
    if sensor is not None:
        expect(sensor, Sensor, "place_sensors: sensor")
    n = whole_number(n, "place_sensors: n", 1, MAX_CAMERAS)
    seed = check_seed(seed, "place_sensors: seed")
    mount = mount_for(
        sensor,
        ceiling_m=layout_ceiling(layout) if ceiling_m is None else float(ceiling_m),
        min_mount_m=min_mount_m,
        mount_height_m=mount_height_m,
        radius_m=radius_m,
    )
    radius_m, mount_height_m = mount.radius_m, mount.height_m
    if fitness == "circle":
        problem = CoverageProblem(
            layout, radius_m, weights=weights, free_floor=mount_height_m < LOW_MOUNT_M
        )
    elif fitness == "visibility":
        if render is None:
            raise ConfigError(
                "placement fitness 'visibility' needs render=, e.g. Renderer(scene).render"
            )
        problem = VisibilityProblem(
            layout,
            radius_m,
            render=render,
            sensor=sensor,
            mount_height_m=mount_height_m,
            size=visibility_size,
            weights=weights,
            pitch_rad=mount.pitch_rad,
        )
    else:
        raise ConfigError(
            f"placement fitness {fitness!r} is unknown{did_you_mean(fitness, FITNESS)}; "
            f"expected {' or '.join(FITNESS)}"
        )
    rng = np.random.default_rng(seed)
    if method == "genetic":
        result = genetic_placement(problem, n, rng=rng)
    elif method == "greedy":
        result = greedy_placement(problem, n)
    elif method == "random":
        result = random_placement(problem, n, rng=rng)
    else:
        raise ConfigError(
            f"placement method {method!r} is unknown; expected genetic, greedy or random"
        )
    return poses_from_centres(problem, result.centres, radius_m, mount_height_m, mount.pitch_rad)


def scene_poses(
    scene,
    sensor,
    n: int,
    seed: int = 0,
    *,
    mount_height_m: float | None = None,
    margin_m: float = 0.3,
) -> list[np.ndarray]:
    """Poses for a scene without its layout (e.g. a USD stage): placement over its floor (the
    bounding box's footprint, ``margin_m`` inside the walls), under its height as the ceiling,
    mounted for the sensor's range (:func:`mount_for`) — never outside the hall."""
    lo, hi = scene.bounds()
    if not np.all(np.isfinite(lo)):
        raise ConfigError("placement: the scene is empty")
    w, h = float(hi[0] - lo[0]), float(hi[1] - lo[1])
    m = min(margin_m, 0.25 * w, 0.25 * h)
    floor = Region(float(lo[0]) + m, float(lo[1]) + m, w - 2 * m, h - 2 * m, type="floor")
    layout = Layout.from_regions(
        [floor],
        {"floor": RegionType("floor", asset_group="floor")},
        (float(lo[0]), float(lo[1]), w, h),
    )
    height = float(hi[2] - lo[2])
    ceiling = height if height > MIN_MOUNT_M + 0.5 else DEFAULT_CEILING_M
    step = max(0.25, min(1.0, min(w, h) / 4))
    mount = mount_for(sensor, ceiling_m=ceiling, mount_height_m=mount_height_m)
    problem = CoverageProblem(layout, mount.radius_m, resolution_m=step / 2, step_m=step)
    result = genetic_placement(problem, n, rng=np.random.default_rng(seed), generations=40)
    poses = poses_from_centres(
        problem, result.centres, mount.radius_m, mount.height_m, mount.pitch_rad
    )
    for p in poses:  # the floor of a foreign stage need not lie at z = 0
        p[2, 3] += float(lo[2])
    return poses
