"""LiDAR scans: the beams of each revolution cast exactly, then the profile's effects.

One scan is one bundle of rays (:func:`cast_beams`, the only caller of the ray engine
here): the beams of one revolution, each firing from its own pose, plus the sub-rays of
their footprints when the profile's ``beam_divergence`` runs. Each hit becomes an echo
(:class:`~genie_gl.effects.lidar_base.Echoes`) with the surface's ids, incidence and
reflectance (its UsdPreviewSurface material); the effects the scene's plan keeps then map
the echoes, and the echoes become the scan's points (:class:`Scan`).

Randomness: each scan draws from its own generator, made from (seed, head, scan index), so
a scan is the same whichever worker makes it and whichever scans are made before it.
"""

from __future__ import annotations

import numpy as np

from ..jit import njit, prange
from ..render.rays import RayHits, Rays, cast_bundle
from ..scene.materials import MaterialTable
from ..scene.model import Scene
from ..sensors.beams import Beams
from ..effects.base import Decision
from ..effects.lidar_base import Echoes, LidarEffect, SceneMaterials
from ..sensors.scanner import Scanner
from .scan_record import Scan


def scene_materials(table: MaterialTable) -> SceneMaterials:
    """What the planner needs of the scene's materials."""
    n = len(table.ids)
    shiny = int(np.sum((table.metallic[:n] >= 0.5) & (table.roughness[:n] <= 0.3)))
    alb = table.albedo[:n] if n else np.zeros(1)
    return SceneMaterials(n, shiny, float(alb.min()), float(alb.max()))


def plan_scan(
    scene: Scene, scanner: Scanner, table: MaterialTable | None = None
) -> dict[str, Decision]:
    """Per effect of ``scanner``, whether it runs on ``scene`` and why."""
    mats = scene_materials(MaterialTable.from_scene(scene) if table is None else table)
    return {e.name: e.plan(mats, scanner) for e in scanner.effects}


def cast_beams(scene: Scene, origins: np.ndarray, directions: np.ndarray) -> RayHits:
    """The exact nearest hit of every ray ((B, 3) float64 each): one bundle, one cast,
    binned on an azimuth-elevation grid around the head (the origins of one revolution lie
    within a small ball), the same answer as :func:`~genie_gl.render.rays.cast_rays`."""
    return cast_bundle(scene, Rays(origins, directions))


@njit(cache=True, nogil=True, parallel=True, boundscheck=False)
def _incidence(normal, directions, rows, out_n, out_cos):  # pragma: no cover - compiled
    """Per row ``rows[j]`` of ``normal`` (n, 3) float32 and ``directions`` (n, 3): the normal
    in float64 into ``out_n[j]`` and |cos| of the angle between them, within [0, 1], into
    ``out_cos[j]``."""
    for j in prange(len(rows)):
        r = rows[j]
        nx, ny, nz = np.float64(normal[r, 0]), np.float64(normal[r, 1]), np.float64(normal[r, 2])
        out_n[j, 0], out_n[j, 1], out_n[j, 2] = nx, ny, nz
        c = abs((nx * directions[r, 0] + ny * directions[r, 1]) + nz * directions[r, 2])
        out_cos[j] = min(max(c, 0.0), 1.0)


def _echoes(
    hits: RayHits,
    directions: np.ndarray,
    parent: np.ndarray,
    table: MaterialTable,
    scanner: Scanner,
    footprint: LidarEffect | None = None,
) -> Echoes:
    """An echo per ray that hits within range (``parent``: each ray's beam); with a
    ``footprint`` (its sub-rays ``len(pattern)`` to a beam, beam-major), each beam's returns
    from its sub-rays' echoes instead (:meth:`~genie_gl.effects.lidar.BeamDivergence.returns`),
    built only for the echoes kept."""
    keep = hits.hit & (hits.distance <= scanner.max_range_m)
    idx = np.flatnonzero(keep)
    n = np.empty((len(idx), 3))
    cos = np.empty(len(idx))
    _incidence(hits.normal, np.ascontiguousarray(directions), idx, n, cos)
    rows = table.rows(hits.instance[idx])
    refl = table.albedo[rows]
    beam, ranges, intensity = parent[idx].astype(np.int64), hits.distance[idx], refl * cos
    if footprint is not None:
        w = footprint.pattern(scanner)[1]
        sel, ranges, intensity = footprint.returns(
            beam, ranges, intensity, w[idx % len(w)], scanner
        )
        idx, beam, n, cos, refl, rows = idx[sel], beam[sel], n[sel], cos[sel], refl[sel], rows[sel]
    m = len(idx)
    echoes = Echoes(
        beam,
        ranges,
        hits.instance[idx],
        hits.semantic[idx],
        n,
        cos,
        refl,
        table.metallic[rows],
        table.roughness[rows],
        intensity,
        np.ones(m, np.uint8),
        np.ones(m, np.uint8),
    )
    return echoes if footprint is None else echoes.renumbered()


def take_scan(
    scene: Scene,
    scanner: Scanner,
    beams: Beams,
    *,
    rng: np.random.Generator,
    table: MaterialTable | None = None,
    plan: dict[str, Decision] | None = None,
    head: str = "head",
    head_index: int = 0,
) -> Scan:
    """The scan of ``beams``: cast, echoes, the effects ``plan`` runs (default: the scene's
    plan)."""
    table = MaterialTable.from_scene(scene) if table is None else table
    plan = plan_scan(scene, scanner, table) if plan is None else plan
    running = [e for e in scanner.effects if plan.get(e.name, Decision(True, "")).run]
    footprint = next((e for e in running if e.casts_subrays), None)
    if footprint is None:
        hits = cast_beams(scene, beams.origins, beams.directions)
        echoes = _echoes(hits, beams.directions, np.arange(len(beams)), table, scanner)
    else:
        dirs = footprint.subrays(beams.directions, scanner)
        k = len(dirs) // max(len(beams), 1)
        hits = cast_beams(scene, np.repeat(beams.origins, k, axis=0), dirs)
        parent = np.repeat(np.arange(len(beams)), k)
        echoes = _echoes(hits, dirs, parent, table, scanner, footprint)
    for effect in running:
        if not effect.casts_subrays and len(echoes):
            echoes = effect.apply(echoes, scanner, rng=rng)
    b = echoes.beam
    world = beams.origins[b] + beams.directions[b] * echoes.range_m[:, None]
    sensor = beams.sensor_origins[b] + beams.sensor_directions[b] * echoes.range_m[:, None]
    return Scan(
        head,
        head_index,
        scanner,
        beams.index,
        beams.start_s,
        world,
        sensor,
        echoes.range_m,
        np.clip(echoes.intensity, 0.0, 1.0).astype(np.float32),
        beams.ring[b],
        beams.channel[b],
        beams.column[b],
        beams.time_s[b],
        beams.azimuth_rad[b],
        echoes.return_number,
        echoes.returns,
        echoes.semantic,
        echoes.instance,
        beams.firing_poses,
        len(beams),
        {name: (d.run, d.reason) for name, d in plan.items()},
    )
