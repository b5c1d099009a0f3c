"""Trajectories on the free floor: routes between furnished regions, followed the way a
person or a robot moves.

A maker first finds a *route*, legs of free-cell centres (:mod:`.floor`), each a shortest
path over the free floor (which keeps to the middle of aisles):

* ``aisles``: a tour that covers the aisles: target cells on a lattice (``spacing_m``) of the
  free floor within sight of furnished regions, visited nearest first from a random start;
  targets the route has passed near are dropped.
* ``random``: a random walk: legs to random free cells between ``leg_m`` apart.
* ``waypoints``: through points given in a file (``x y`` per line, or a JSON list of pairs),
  each of which must be free floor.

Then the route is *followed* (:func:`follow`): straightened where the line of sight is free,
its corners rounded by arcs no tighter than the turning rate allows at walking speed (tighter
arcs at lower speed where space is short; a turn on the spot when nothing else fits), the
speed limited by the arcs and by the acceleration, and the times integrated. Every sample
lies on free floor, so the body never comes nearer than its radius to an asset.
"""

from __future__ import annotations

import json
import os

import numpy as np
from scipy.sparse import csgraph

from ..validation.arguments import check_seed, expect, finite_number
from ..errors import ConfigError, did_you_mean
from ..layout.model import Layout
from ..limits import MAX_DURATION_S
from ..resources import read_text
from ..scene.model import Scene
from .floor import SEE_M, FreeFloor, free_floor
from .follow import Motion, follow, motion_of
from .trajectory import Trajectory

PATHS = ("aisles", "random", "waypoints")


# -- routes -----------------------------------------------------------------------------------


class _Router:
    """Shortest paths over one free floor's graph."""

    def __init__(self, floor: FreeFloor) -> None:
        self.floor = floor
        self.G, self.index = floor.graph()
        rows, cols = np.nonzero(floor.free)
        self.xy = floor.centres(rows, cols)  # node -> cell centre
        self.near = floor.near_m[rows, cols]
        self.clear = floor.clearance_m[rows, cols]

    def node(self, xy: np.ndarray) -> int:
        row, col = self.floor.cells(np.asarray(xy)[None])
        return int(self.index[row[0], col[0]])

    def from_node(self, a: int) -> tuple[np.ndarray, np.ndarray]:
        return csgraph.dijkstra(self.G, indices=a, return_predecessors=True)

    @staticmethod
    def walk(pred: np.ndarray, b: int) -> list[int]:
        out = [b]
        while pred[out[-1]] >= 0:
            out.append(int(pred[out[-1]]))
        return out[::-1]


def _length(legs: list[np.ndarray]) -> float:
    return float(
        sum(np.linalg.norm(np.diff(xy, axis=0), axis=1).sum() for xy in legs if len(xy) > 1)
    )


def aisle_route(
    floor: FreeFloor,
    *,
    rng: np.random.Generator,
    spacing_m: float = 3.0,
    length_m: float | None = None,
) -> list[np.ndarray]:
    """The legs ((k, 2) each) of a route covering the aisles (see the module's docstring)."""
    r = _Router(floor)
    k = max(1, int(round(spacing_m / floor.resolution_m)))
    aisle = r.near <= SEE_M
    if not aisle.any():
        aisle = np.ones(len(r.xy), bool)
    rows, cols = floor.cells(r.xy)
    block = (rows // k) * (int(floor.shape[1]) // k + 1) + cols // k
    # per lattice block, the aisle cell farthest from obstacles (the middle of the aisle)
    order = np.lexsort((-r.clear, block))
    cand = order[aisle[order]]
    _, first = np.unique(block[cand], return_index=True)
    targets = np.sort(cand[first])
    cover = 0.75 * spacing_m
    current = int(targets[rng.integers(len(targets))])
    left = np.ones(len(targets), bool)
    legs: list[list[int]] = [[current]]
    while True:
        passed = r.xy[legs[-1]]
        near = np.zeros(len(targets), bool)
        for chunk in np.array_split(passed, max(1, len(passed) // 256)):
            d = np.linalg.norm(r.xy[targets][:, None] - chunk[None], axis=2).min(1)
            near |= d <= cover
        left &= ~near
        if not left.any() or (
            length_m is not None and _length([r.xy[g] for g in legs]) >= length_m
        ):
            break
        dist, pred = r.from_node(current)
        reach = np.where(left, dist[targets], np.inf)
        if not np.isfinite(reach).any():
            break
        goal = int(targets[int(np.argmin(reach))])
        legs.append(r.walk(pred, goal))
        current = goal
    return [r.xy[g] for g in legs if len(g) > 1] or [r.xy[legs[0]]]


def random_route(
    floor: FreeFloor,
    *,
    rng: np.random.Generator,
    length_m: float = 60.0,
    leg_m: tuple[float, float] = (3.0, 12.0),
) -> list[np.ndarray]:
    """The legs of a random walk of at least ``length_m`` (or as far as the floor allows)."""
    r = _Router(floor)
    current = int(rng.integers(len(r.xy)))
    legs: list[list[int]] = []
    while _length([r.xy[g] for g in legs]) < length_m:
        dist, pred = r.from_node(current)
        ok = np.flatnonzero((dist >= leg_m[0]) & (dist <= leg_m[1]))
        if not len(ok):
            ok = np.flatnonzero(np.isfinite(dist) & (dist > 0))
            if not len(ok):
                break
        goal = int(ok[rng.integers(len(ok))])
        legs.append(_Router.walk(pred, goal))
        current = goal
    return [r.xy[g] for g in legs] or [r.xy[[current]]]


def read_waypoints(path: str | os.PathLike) -> np.ndarray:
    """(n, 2) float64 waypoints from a file: ``x y`` (or ``x,y``) per line, ``#`` comments,
    or a JSON list of [x, y] pairs; metres in the world frame."""
    text = read_text(path, "waypoint list")
    if text.lstrip().startswith("["):
        try:
            pts = np.array(json.loads(text), dtype=np.float64)
        except (ValueError, TypeError) as exc:
            raise ConfigError(f"{path}: not a JSON list of [x, y] pairs ({exc})") from None
        if pts.ndim != 2 or pts.shape[1] != 2:
            raise ConfigError(
                f"{path}: expected a JSON list of [x, y] pairs, got shape {pts.shape}"
            )
    else:
        rows = []
        for n, line in enumerate(text.splitlines(), 1):
            line = line.split("#")[0].replace(",", " ").split()
            if not line:
                continue
            try:
                x, y = (float(v) for v in line)
            except ValueError:
                raise ConfigError(
                    f"{path}:{n}: expected two numbers 'x y' (metres), got {' '.join(line)!r}"
                ) from None
            rows.append((x, y))
        pts = np.array(rows, np.float64).reshape(-1, 2)
    return check_waypoints(pts, str(path))


def check_waypoints(pts: np.ndarray, source: str) -> np.ndarray:
    """``pts`` (n, 2) when they are at least two waypoints, all finite; one line naming the
    first NaN or infinite one (1-based) otherwise."""
    bad = (
        np.flatnonzero(~np.isfinite(pts).all(axis=1))
        if pts.ndim == 2 and pts.shape[1:] == (2,)
        else []
    )
    if len(bad):
        k = int(bad[0])
        raise ConfigError(
            f"{source}: waypoint {k + 1} ({pts[k, 0]:g}, {pts[k, 1]:g}) is not a finite point; "
            f"expected x y in metres ({len(bad)} of the {len(pts)} waypoints are NaN or infinite)"
        )
    if pts.ndim != 2 or pts.shape[1:] != (2,) or len(pts) < 2:
        raise ConfigError(
            f"{source}: expected at least two waypoints (x y in metres), got {len(pts)}"
        )
    return pts


def waypoint_route(
    floor: FreeFloor, waypoints: np.ndarray, *, source: str = "waypoints"
) -> list[np.ndarray]:
    """The legs of a route through ``waypoints`` (each on free floor) by shortest paths."""
    r = _Router(floor)
    wp = np.asarray(waypoints, np.float64)
    ok = floor.is_free(wp)
    for k in np.flatnonzero(~ok)[:1]:
        d = np.linalg.norm(r.xy - wp[k], axis=1)
        near = r.xy[int(np.argmin(d))]
        raise ConfigError(
            f"{source}: waypoint {k + 1} ({wp[k, 0]:g}, {wp[k, 1]:g}) is not free floor (outside "
            "the "
            f"hall, or within {floor.body_radius_m:g} m of an asset); the nearest free point is "
            f"({near[0]:.2f}, {near[1]:.2f})"
        )
    nodes = [r.node(p) for p in wp]
    legs = []
    for k, (a, b) in enumerate(zip(nodes, nodes[1:])):
        dist, pred = r.from_node(a)
        if not np.isfinite(dist[b]):
            raise ConfigError(
                f"{source}: no way on the free floor from waypoint {k + 1} to waypoint {k + 2}"
            )
        legs.append(r.xy[_Router.walk(pred, b)])
    # the exact first and last points: each lies in its cell, so the step to its centre is free
    legs[0] = np.concatenate([wp[:1], legs[0]])
    legs[-1] = np.concatenate([legs[-1], wp[-1:]])
    return legs


def path_kind(path: str | os.PathLike, option: str = "--path") -> str:
    """The kind of a path option's value: ``aisles``, ``random``, or ``waypoints`` (an existing
    file); anything else is a one-line :class:`ConfigError` naming the option (did-you-mean)."""
    if str(path) in PATHS[:2]:
        return str(path)
    if os.path.isfile(path):
        return "waypoints"
    raise ConfigError(
        f"{option} {str(path)!r}: expected aisles, random or a waypoints file (no such file)"
        f"{did_you_mean(str(path), PATHS[:2])}"
    )


def route(
    floor: FreeFloor,
    path: str = "aisles",
    *,
    rng: np.random.Generator,
    waypoints=None,
    length_m: float | None = None,
    spacing_m: float = 3.0,
) -> list[np.ndarray]:
    """The legs ((k, 2) each, shortest paths over free cells) of a route of kind ``path`` (one
    of PATHS) on ``floor``; ``waypoints``: an (n, 2) array or a file (``waypoints`` only)."""
    if path == "aisles":
        return aisle_route(floor, rng=rng, spacing_m=spacing_m, length_m=length_m)
    if path == "random":
        return random_route(floor, rng=rng, length_m=60.0 if length_m is None else length_m)
    if path == "waypoints":
        if waypoints is None:
            raise ConfigError(
                "path 'waypoints' needs waypoints: a file ('x y' per line) or an (n, 2) array"
            )
        source = "waypoints"
        if isinstance(waypoints, (str, os.PathLike)):
            source, waypoints = str(waypoints), read_waypoints(waypoints)
        try:
            pts = np.asarray(waypoints, np.float64)
        except (TypeError, ValueError):
            raise ConfigError(f"{source}: expected an (n, 2) array of waypoints (metres)") from None
        return waypoint_route(floor, check_waypoints(pts, source), source=source)
    raise ConfigError(
        f"path {path!r}: unknown{did_you_mean(str(path), PATHS)}; expected one of "
        f"{', '.join(PATHS)} "
        "(waypoints: give the file)"
    )


def make_trajectory(
    layout,
    scene=None,
    path: str = "aisles",
    *,
    seed: int = 0,
    motion: "str | Motion" = "person",
    waypoints=None,
    length_m: float | None = None,
    duration_s: float | None = None,
    spacing_m: float = 3.0,
    floor: FreeFloor | None = None,
) -> Trajectory:
    """A trajectory on the free floor of ``layout`` (and of ``scene``'s assets, when given).

    Parameters
    ----------
    path : "aisles" (a tour covering the aisles), "random" (a random walk) or "waypoints"
        (through ``waypoints``: a file or an (n, 2) array, metres).
    seed : the route's random choices (start, legs).
    motion : "person", "robot" or a :class:`~.motion.Motion` (speed, height, turning rate,
        acceleration, body radius).
    length_m : stop the route once it is this long (random walk: default 60 m).
    duration_s : keep the first this many seconds; a route that ends sooner is walked there
        and back until it lasts them.
    floor : a :class:`FreeFloor` already made for this layout/scene and motion's radius.
    """
    expect(layout, Layout, "make_trajectory: layout")
    if scene is not None:
        expect(scene, Scene, "make_trajectory: scene")
    seed = check_seed(seed, "make_trajectory: seed")
    if duration_s is not None:
        duration_s = finite_number(
            duration_s, "make_trajectory: duration_s", 0.0, MAX_DURATION_S, lo_open=True
        )
    if length_m is not None:
        length_m = finite_number(length_m, "make_trajectory: length_m", 0.0, 1e6, lo_open=True)
    m = motion_of(motion)
    if floor is None:
        floor = free_floor(layout, scene, body_radius_m=m.body_radius_m)
    elif floor.body_radius_m < m.body_radius_m:
        raise ConfigError(
            f"trajectory: the free floor keeps {floor.body_radius_m:g} m from assets, the motion "
            f"needs {m.body_radius_m:g} m"
        )
    if length_m is not None and not length_m > 0:
        raise ConfigError(f"trajectory: length_m must be > 0, got {length_m}")
    legs = route(
        floor,
        path,
        rng=np.random.default_rng(seed),
        waypoints=waypoints,
        length_m=length_m,
        spacing_m=spacing_m,
    )
    traj = follow(floor, legs, m, meta={"path": path, "seed": int(seed)})
    if duration_s is not None:
        if not duration_s > 0:
            raise ConfigError(f"trajectory: duration_s must be > 0, got {duration_s}")
        if traj.duration_s < duration_s:
            traj = _lasting(floor, legs, m, traj, duration_s)
        traj = traj.crop(duration_s)
    return traj


def _lasting(
    floor: FreeFloor, legs: list[np.ndarray], motion: Motion, once: Trajectory, duration_s: float
) -> Trajectory:
    """The route walked there and back (and there again, ...) until it lasts ``duration_s``:
    a route shorter than the time asked for is patrolled, not cut short (the meta's ``laps``
    counts the walks along it)."""
    back = [leg[::-1] for leg in legs[::-1]]
    laps = max(2, int(np.ceil(duration_s / max(once.duration_s, 1e-9))) + 1)
    while True:
        route = [leg for k in range(laps) for leg in (legs if k % 2 == 0 else back)]
        traj = follow(floor, route, motion, meta={**once.meta, "laps": laps})
        if traj.duration_s >= duration_s or laps > 4 * MAX_DURATION_S:
            return traj
        laps *= 2
