"""The base of every LiDAR effect, and the ``Echoes`` record effects map.

A scan is cast exactly (one bundle of rays per firing window); each beam's hit becomes an
*echo*: its range, the surface's ids, incidence and reflectance. A LiDAR effect maps the
echoes of a scan to the echoes the head would report. Effects are opt-in per profile
(``effects:`` in a ``*.lidar.yml``), listed in :mod:`.lidar_effects`, and planned per scene
as the camera effects are (:mod:`.effect`): :meth:`LidarEffect.plan` says from the scene's
materials whether the effect can change anything; one that cannot is skipped, costs nothing
and draws nothing, so the scan's bytes are those of a profile without it.

Only one effect casts more than the beams: a beam's footprint (``beam_divergence``) asks for
sub-rays through :meth:`LidarEffect.subrays`, cast in the same bundle as the beams.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Any, ClassVar

import numpy as np

from .base import Decision


@dataclass(frozen=True, eq=False)
class Echoes:
    """The returns of one scan, one row per echo (a beam has 0, 1 or 2).

    Attributes
    ----------
    beam : (M,) int64, the beam (index into the scan's beams) the echo belongs to.
    range_m : (M,) float64, distance from the beam's origin along its direction (m).
    instance : (M,) uint32; semantic : (M,) uint16.
    normal : (M, 3) float64, unit surface normal at the hit (world frame, facing the beam).
    cos_incidence : (M,) float64 in [0, 1], cosine of the angle between beam and normal.
    reflectance : (M,) float64 in [0, 1], the surface's diffuse albedo (its material).
    metallic, roughness : (M,) float64, the surface's UsdPreviewSurface inputs.
    intensity : (M,) float64, reflectivity as the head reports it: reflectance x cos(incidence)
        for a diffuse surface (range compensated, as Velodyne and Ouster calibrate it).
    return_number : (M,) uint8, 1-based within the beam's echoes, nearest first.
    returns : (M,) uint8, how many echoes the beam reported.
    """

    beam: np.ndarray
    range_m: np.ndarray
    instance: np.ndarray
    semantic: np.ndarray
    normal: np.ndarray
    cos_incidence: np.ndarray
    reflectance: np.ndarray
    metallic: np.ndarray
    roughness: np.ndarray
    intensity: np.ndarray
    return_number: np.ndarray
    returns: np.ndarray

    def __len__(self) -> int:
        return len(self.beam)

    def taken(self, rows: np.ndarray) -> "Echoes":
        """The echoes at ``rows`` (bool mask or indices), in that order, numbers as they are."""
        return replace(self, **{f.name: getattr(self, f.name)[rows] for f in fields(self)})

    def select(self, keep: np.ndarray) -> "Echoes":
        """The echoes where ``keep`` (bool mask or indices); return numbers recounted."""
        return self.taken(keep).renumbered()

    def renumbered(self) -> "Echoes":
        """Return numbers and counts recomputed per beam (echoes of a beam sorted by range)."""
        if not len(self):
            return self
        b, r = self.beam, self.range_m
        if np.any((b[1:] < b[:-1]) | ((b[1:] == b[:-1]) & (r[1:] < r[:-1]))):
            return self.taken(np.lexsort((r, b))).renumbered()  # sorted by (beam, range)
        first = np.r_[True, self.beam[1:] != self.beam[:-1]]
        starts = np.flatnonzero(first)
        counts = np.diff(np.r_[starts, len(self.beam)])
        number = np.arange(len(self.beam)) - np.repeat(starts, counts) + 1
        return replace(
            self,
            return_number=number.astype(np.uint8),
            returns=np.repeat(counts, counts).astype(np.uint8),
        )


@dataclass(frozen=True)
class SceneMaterials:
    """What the planner knows of a scene's surfaces before a scan: the fraction of its
    instances that are metal (metallic >= 0.5) and mirror-smooth, the lowest albedo."""

    instances: int
    shiny_metal: int
    min_albedo: float
    max_albedo: float


class LidarEffect:
    """Base class: ``apply(echoes, scanner, *, rng)`` returns the echoes the head reports.

    ``draws``: whether it takes draws from ``rng`` (their count scales with the echoes it
    touches, none when none). ``casts_subrays``: the effect is a beam's footprint and has
    the footprint's hooks, ``pattern``, ``subrays``, ``returns`` and ``combine`` (only
    ``beam_divergence``).
    """

    name: ClassVar[str] = ""
    draws: ClassVar[bool] = False
    casts_subrays: ClassVar[bool] = False

    def apply(self, echoes: Echoes, scanner: Any, *, rng: np.random.Generator) -> Echoes:
        raise NotImplementedError

    def plan(self, scene: SceneMaterials, scanner: Any) -> Decision:
        """Before the scan: whether the effect runs on this scene, and why."""
        if scene.instances == 0:
            return Decision(False, "nothing in the scene to return an echo")
        return Decision(True, "runs on every echo")

    def params(self) -> dict[str, Any]:
        return (
            {f.name: getattr(self, f.name) for f in fields(self)}
            if hasattr(self, "__dataclass_fields__")
            else {}
        )
