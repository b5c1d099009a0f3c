"""LiDAR effects (LIDAR.md §9.6), and the one list of them: :data:`LIDAR_EFFECTS`.

- ``range_noise``: Gaussian along the beam, sigma = ``sigma_m`` + ``sigma_per_m`` x range,
  then rounded to ``resolution_m`` (the head's range step: VLP-16 2 mm, Ouster RNG19 1 mm);
- ``blind_zone``: no echo nearer than ``min_m`` (default: the profile's minimum range);
- ``dropout``: no echo where the received power is too low, on mirror-like metal away from
  its specular lobe, and at grazing incidence. Power falls as reflectance x cos(incidence) /
  range², so the farthest echo of a surface is ``reference_range_m`` x sqrt(reflectance x
  cos / ``reference_reflectance``) (Ouster: 120 m at 80 %, 40 m at 10 %: sqrt(10/80) x 120 =
  42 m, LIDAR.md §9.6); a metal (metallic >= 0.5, roughness <= ``metal_max_roughness``)
  returns only within ``metal_lobe_deg`` of its normal [U: magnitudes are engineering
  figures]; beyond ``grazing_deg`` incidence no echo comes back;
- ``beam_divergence``: a beam is a cone of full angle ``divergence_mrad`` (default: the
  profile's), sampled by sub-rays (a centre and ``rings`` rings of 6, 12, ... weighted by a
  Gaussian whose half maximum lies on the cone); sub-ray hits within ``separation_m`` of
  each other merge into one echo at their weighted mean range (a mixed pixel), farther
  apart they are separate echoes (Velodyne reports two echoes only >= 1 m apart, VLS-128
  manual, LIDAR.md §9.6). The head's return mode then keeps the strongest, the last, or
  both (dual: the last, and the strongest of the others).

Every effect here but ``range_noise`` is deterministic; ``range_noise`` draws one normal per
echo it touches from ``rng``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from ..errors import ConfigError, did_you_mean
from .base import Decision
from .lidar_base import Echoes, LidarEffect, SceneMaterials
from .lidar_kernels import DUAL, LAST, STRONGEST, footprint_returns, subray_directions

RETURN_MODES = {"strongest": STRONGEST, "last": LAST, "dual": DUAL}


@dataclass(frozen=True)
class RangeNoise(LidarEffect):
    name = "range_noise"
    draws = True
    sigma_m: float = 0.0
    sigma_per_m: float = 0.0
    resolution_m: float = 0.0

    def plan(self, scene: SceneMaterials, scanner: Any) -> Decision:
        if self.sigma_m == 0 and self.sigma_per_m == 0 and self.resolution_m == 0:
            return Decision(False, "no noise and no range step")
        return super().plan(scene, scanner)

    def apply(self, echoes: Echoes, scanner: Any, *, rng: np.random.Generator) -> Echoes:
        r = echoes.range_m
        if self.sigma_m or self.sigma_per_m:
            r = r + rng.standard_normal(len(r)) * (self.sigma_m + self.sigma_per_m * r)
        if self.resolution_m:
            r = np.round(r / self.resolution_m) * self.resolution_m
        keep = r > 0
        return (
            replace(echoes, range_m=r).select(keep)
            if not keep.all()
            else replace(echoes, range_m=r)
        )


@dataclass(frozen=True)
class BlindZone(LidarEffect):
    name = "blind_zone"
    min_m: float | None = None

    def limit(self, scanner: Any) -> float:
        return float(scanner.min_range_m if self.min_m is None else self.min_m)

    def plan(self, scene: SceneMaterials, scanner: Any) -> Decision:
        if self.limit(scanner) <= 0:
            return Decision(False, "no blind zone (minimum range 0)")
        return super().plan(scene, scanner)

    def apply(self, echoes: Echoes, scanner: Any, *, rng: np.random.Generator) -> Echoes:
        keep = echoes.range_m >= self.limit(scanner)
        return echoes if keep.all() else echoes.select(keep)


@dataclass(frozen=True)
class Dropout(LidarEffect):
    name = "dropout"
    reference_reflectance: float = 0.8
    reference_range_m: float | None = None
    metal_max_roughness: float = 0.3
    metal_lobe_deg: float = 15.0
    grazing_deg: float = 85.0

    def plan(self, scene: SceneMaterials, scanner: Any) -> Decision:
        return super().plan(scene, scanner)

    def apply(self, echoes: Echoes, scanner: Any, *, rng: np.random.Generator) -> Echoes:
        ref_range = float(
            scanner.max_range_m if self.reference_range_m is None else self.reference_range_m
        )
        power = np.clip(
            echoes.reflectance * echoes.cos_incidence / self.reference_reflectance, 0.0, None
        )
        weak = echoes.range_m > ref_range * np.sqrt(power)
        mirror = (
            (echoes.metallic >= 0.5)
            & (echoes.roughness <= self.metal_max_roughness)
            & (echoes.cos_incidence < math.cos(math.radians(self.metal_lobe_deg)))
        )
        grazing = echoes.cos_incidence < math.cos(math.radians(self.grazing_deg))
        lost = weak | mirror | grazing
        return echoes.select(~lost) if lost.any() else echoes


@dataclass(frozen=True)
class BeamDivergence(LidarEffect):
    name = "beam_divergence"
    casts_subrays = True
    divergence_mrad: float | None = None
    rings: int = 1
    separation_m: float = 1.0

    def half_angle(self, scanner: Any) -> float:
        full = (
            self.divergence_mrad * 1e-3
            if self.divergence_mrad is not None
            else scanner.beam_divergence_rad
        )
        if full is None:
            raise ConfigError(
                f"{scanner.profile or scanner.name}: beam_divergence: the profile gives no "
                "beam_divergence_mrad; set divergence_mrad on the effect"
            )
        return 0.5 * float(full)

    def plan(self, scene: SceneMaterials, scanner: Any) -> Decision:
        if self.half_angle(scanner) == 0 or self.rings == 0:
            return Decision(False, "a beam of no width")
        return super().plan(scene, scanner)

    def pattern(self, scanner: Any) -> tuple[np.ndarray, np.ndarray]:
        """(K, 2) angular offsets (rad) of the sub-rays across the cone, the centre first,
        and their (K,) weights (a Gaussian at half maximum on the cone's edge)."""
        h = self.half_angle(scanner)
        offs, w = [np.zeros(2)], [1.0]
        for r in range(1, self.rings + 1):
            rho = h * r / self.rings
            a = np.arange(6 * r) * (2 * np.pi / (6 * r))
            offs += list(rho * np.column_stack([np.cos(a), np.sin(a)]))
            w += [0.5 ** ((r / self.rings) ** 2)] * (6 * r)
        return np.array(offs), np.array(w)

    def subrays(self, directions: np.ndarray, scanner: Any) -> np.ndarray:
        """(B*K, 3) float64 unit directions of each beam's sub-rays, beam-major: the beam's
        own direction first (bit for bit), then d + tan(a) u + tan(b) v normalised for each
        offset (a, b) of :meth:`pattern`, u and v unit and square to d."""
        offs, _ = self.pattern(scanner)
        d = np.ascontiguousarray(directions, dtype=np.float64)
        out = np.empty((len(d) * len(offs), 3))
        subray_directions(d, np.ascontiguousarray(np.tan(offs)), out)
        return out

    def returns(
        self,
        beam: np.ndarray,
        range_m: np.ndarray,
        intensity: np.ndarray,
        weight: np.ndarray,
        scanner: Any,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The returns of each beam from its sub-rays' echoes (rows: ``beam`` (M,), ``range_m``,
        ``intensity``, and ``weight`` the sub-ray's in :meth:`pattern`): (rows (R,), the
        strongest echo of each return kept, beam by beam; its range, the strength-weighted mean
        of its group's; its intensity, the group's share of the beam's energy times its
        reflectivity), per the head's return mode."""
        order = None
        if np.any(beam[1:] < beam[:-1]):  # rows come in beam order from a scan
            order = np.argsort(beam, kind="stable")
            beam, range_m, intensity, weight = (
                beam[order],
                range_m[order],
                intensity[order],
                weight[order],
            )
        strength = weight * (intensity + 1e-9)
        rows, ranges, strengths = footprint_returns(
            beam, range_m, strength, self.separation_m, RETURN_MODES[scanner.returns]
        )
        rows = rows if order is None else order[rows]
        return rows, ranges, strengths / self.pattern(scanner)[1].sum()

    def combine(self, sub: Echoes, weight: np.ndarray, scanner: Any) -> Echoes:
        """One beam's echoes from its sub-rays' hits (``sub.beam``: the beam; ``weight``:
        each row's weight), per the head's return mode (:meth:`returns`)."""
        if not len(sub):
            return sub
        rows, ranges, intensity = self.returns(
            sub.beam, sub.range_m, sub.intensity, weight, scanner
        )
        return replace(sub.taken(rows), range_m=ranges, intensity=intensity).renumbered()

    def apply(self, echoes: Echoes, scanner: Any, *, rng: np.random.Generator) -> Echoes:
        return echoes  # its work is done around the cast (subrays, combine)


LIDAR_EFFECTS: dict[str, type[LidarEffect]] = {
    c.name: c for c in (RangeNoise, BlindZone, Dropout, BeamDivergence)
}


def build_lidar_effects(specs: list[Any], where: str) -> tuple[LidarEffect, ...]:
    """Effects from a profile's ``effects:`` list of ``{type: name, ...params}``."""
    if not isinstance(specs, (list, tuple)):
        raise ConfigError(
            f"{where}: effects: expected a list of {{type: name, ...}}, got {specs!r:.60}"
        )
    out = []
    for i, spec in enumerate(specs):
        if not isinstance(spec, dict) or "type" not in spec:
            raise ConfigError(
                f"{where}: effects[{i}]: expected a mapping with a 'type', got {spec!r:.60}"
            )
        kind = spec["type"]
        cls = LIDAR_EFFECTS.get(kind)
        if cls is None:
            raise ConfigError(
                f"{where}: effects[{i}].type {kind!r}: unknown LiDAR effect"
                f"{did_you_mean(str(kind), LIDAR_EFFECTS)}; expected one of "
                f"{', '.join(LIDAR_EFFECTS)}"
            )
        known = [f.name for f in fields(cls)]
        params = {k: v for k, v in spec.items() if k != "type"}
        for k, v in params.items():
            if k not in known:
                raise ConfigError(
                    f"{where}: effects[{i}].{k}: not a parameter of {kind}{did_you_mean(k, known)} "
                    f"(its parameters: {', '.join(known) or 'none'})"
                )
            if (
                isinstance(v, bool)
                or (v is not None and not isinstance(v, (int, float)))
                or (v is not None and (not math.isfinite(v) or v < 0))
            ):
                raise ConfigError(
                    f"{where}: effects[{i}].{k}: expected a number >= 0, got {v!r:.40}"
                )
            if k == "rings" and (not isinstance(v, int) or v > 4):
                raise ConfigError(
                    f"{where}: effects[{i}].rings: expected a whole number of rings 0-4, got "
                    f"{v!r:.40}"
                )
        if kind in [type(e).name for e in out]:
            raise ConfigError(f"{where}: effects[{i}]: {kind} is listed twice")
        out.append(cls(**params))
    return tuple(out)
