"""What the catalogue's surfaces are made of, and the per-instance material table effects read.

Every asset class maps to a material kind (painted steel, bare metal, wood, plastic, ...);
each kind gives ranges of the UsdPreviewSurface inputs, and the scene builder draws one
:class:`~genie_gl.scene.model.Material` per instance within them from the scene's Generator.

The ranges are typical physically-based-rendering figures, not measurements of particular
products [U: the values used by PBR material libraries, e.g. physicallybased.info and the
UsdPreviewSurface specification's guidance: dielectrics metallic 0, metals metallic 1,
plastics and paints ior ~1.5, glass 1.52, polycarbonate 1.58, concrete albedo ~0.3-0.5,
wood ~0.3-0.6, cardboard ~0.4-0.6]. Near-infrared albedo (what ToF and active stereo
sensors see) is taken to equal the visible one.

Per-pixel materials cost nothing unless an effect asks: :class:`MaterialTable` holds one row
per instance, and an effect looks its frame's instance-id buffer up in it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .model import DEFAULT_MATERIAL, Material, Scene


@dataclass(frozen=True)
class MaterialKind:
    """Ranges (lo, hi) of each input; colour ranges per channel (linear RGB)."""

    diffuse_lo: tuple[float, float, float]
    diffuse_hi: tuple[float, float, float]
    metallic: tuple[float, float]
    roughness: tuple[float, float]
    opacity: tuple[float, float] = (1.0, 1.0)
    ior: tuple[float, float] = (1.5, 1.5)

    def __post_init__(self) -> None:
        # per input after the colour (metallic, roughness, opacity, ior): what draw() gives
        # when its range holds one value (lo + 0 * u, rounded: the same for every draw u in
        # [0, 1)), else None; worked out once, not per instance
        object.__setattr__(
            self,
            "_fixed",
            tuple(
                round(float(r[0] + 0.0), 4) if r[0] == r[1] and math.isfinite(r[0]) else None
                for r in (self.metallic, self.roughness, self.opacity, self.ior)
            ),
        )

    def draw(self, rng: np.random.Generator) -> Material:
        """One material within the ranges (6 uniform draws, always, whatever the ranges).

        Plain float arithmetic, the same operations as the array form (``lo + (hi - lo) *
        clip(...)`` then ``np.round(col, 4)``, i.e. ``rint(x * 1e4) / 1e4``), so the same bits:
        it runs once per instance."""
        u0, u1, u2, u3, u4, u5 = rng.random(6).tolist()
        t = min(max(u0 + 0.1 * (u1 - 0.5), 0.0), 1.0)  # one shade for all channels keeps the hue
        lo, hi = self.diffuse_lo, self.diffuse_hi
        col = (
            round((lo[0] + (hi[0] - lo[0]) * t) * 10000.0) / 10000.0,
            round((lo[1] + (hi[1] - lo[1]) * t) * 10000.0) / 10000.0,
            round((lo[2] + (hi[2] - lo[2]) * t) * 10000.0) / 10000.0,
        )
        fixed = self._fixed
        return Material(
            col,
            *[
                f if f is not None else round(float(r[0] + (r[1] - r[0]) * u), 4)
                for f, r, u in (
                    (fixed[0], self.metallic, u2),
                    (fixed[1], self.roughness, u3),
                    (fixed[2], self.opacity, u4),
                    (fixed[3], self.ior, u5),
                )
            ],
        )


KINDS: dict[str, MaterialKind] = {
    # paint over steel: a dielectric coat, semi-gloss
    "painted_steel": MaterialKind((0.05, 0.12, 0.30), (0.15, 0.35, 0.65), (0.0, 0.0), (0.35, 0.6)),
    "painted_yellow": MaterialKind((0.55, 0.40, 0.02), (0.85, 0.65, 0.10), (0.0, 0.0), (0.35, 0.6)),
    "painted_orange": MaterialKind((0.55, 0.18, 0.02), (0.85, 0.35, 0.08), (0.0, 0.0), (0.35, 0.6)),
    "car_paint": MaterialKind((0.30, 0.30, 0.32), (0.80, 0.80, 0.82), (0.0, 0.6), (0.08, 0.25)),
    # bare, machined or galvanised metal: machine parts, conveyor rollers, stillages, dollies
    "bare_metal": MaterialKind((0.50, 0.50, 0.50), (0.75, 0.75, 0.75), (1.0, 1.0), (0.15, 0.4)),
    "galvanised": MaterialKind((0.55, 0.56, 0.56), (0.70, 0.71, 0.71), (1.0, 1.0), (0.35, 0.6)),
    "wood": MaterialKind((0.35, 0.25, 0.15), (0.60, 0.45, 0.30), (0.0, 0.0), (0.7, 0.9)),
    "cardboard": MaterialKind((0.40, 0.30, 0.18), (0.60, 0.48, 0.32), (0.0, 0.0), (0.8, 0.95)),
    "plastic": MaterialKind(
        (0.05, 0.20, 0.45), (0.20, 0.45, 0.80), (0.0, 0.0), (0.4, 0.7), ior=(1.46, 1.55)
    ),
    "concrete": MaterialKind((0.30, 0.30, 0.28), (0.50, 0.50, 0.47), (0.0, 0.0), (0.8, 0.95)),
    "matte_paint": MaterialKind((0.65, 0.65, 0.62), (0.85, 0.85, 0.82), (0.0, 0.0), (0.85, 1.0)),
    # safety glass (1.52) or polycarbonate (1.58) guards: clear, smooth
    "glass": MaterialKind(
        (0.85, 0.88, 0.88),
        (0.95, 0.97, 0.97),
        (0.0, 0.0),
        (0.02, 0.08),
        opacity=(0.05, 0.15),
        ior=(1.52, 1.58),
    ),
}

# asset class (catalogue and background) -> material kind
CLASS_KIND: dict[str, str] = {
    "pallet": "wood",
    "rack": "painted_steel",
    "car": "car_paint",
    "jack": "painted_orange",
    "forklift": "painted_yellow",
    "dolly": "galvanised",
    "klt": "plastic",
    "stillage": "galvanised",
    "cabinet": "painted_steel",
    "conveyor": "bare_metal",
    "machine": "bare_metal",
    "roller": "bare_metal",
    "box": "cardboard",
    "cardboard": "cardboard",
    "guard": "glass",
    "crate": "plastic",
    "tote": "plastic",
    "floor": "concrete",
    "wall": "matte_paint",
    "column": "concrete",
}


def class_material(cls: str, *, rng: np.random.Generator) -> Material:
    """A material for an instance of asset class ``cls`` (unknown classes: matte paint)."""
    return KINDS[CLASS_KIND.get(cls, "matte_paint")].draw(rng)


@dataclass(frozen=True, eq=False)
class MaterialTable:
    """One row per instance of a scene, sorted by instance id; row -1 is "no instance".

    Attributes
    ----------
    ids : (N,) uint32, sorted instance ids.
    albedo, metallic, roughness, opacity, ior : (N + 1,) float64; the last row (index -1)
        holds the default material (what pixels without an instance or material get).
    """

    ids: np.ndarray
    albedo: np.ndarray
    metallic: np.ndarray
    roughness: np.ndarray
    opacity: np.ndarray
    ior: np.ndarray

    @classmethod
    def from_scene(cls, scene: Scene) -> "MaterialTable":
        insts = sorted(scene.instances, key=lambda i: i.instance)
        mats = [i.material or DEFAULT_MATERIAL for i in insts] + [DEFAULT_MATERIAL]
        return cls(
            np.array([i.instance for i in insts], dtype=np.uint32),
            np.array([m.albedo for m in mats]),
            np.array([m.metallic for m in mats]),
            np.array([m.roughness for m in mats]),
            np.array([m.opacity for m in mats]),
            np.array([m.ior for m in mats]),
        )

    @classmethod
    def empty(cls) -> "MaterialTable":
        """No instance: every pixel reads as the default material."""
        return cls.from_scene(Scene())

    def rows(self, instance: np.ndarray) -> np.ndarray:
        """Row of each id in ``instance`` (any shape, uint32); -1 for 0 and unknown ids."""
        instance = np.asarray(instance)
        if len(self.ids) == 0:
            return np.full(instance.shape, -1, np.intp)
        if int(self.ids[-1]) < (1 << 20):  # small ids (the usual case): one gather from a table
            lut = self._lut()
            return lut[np.minimum(instance, len(lut) - 1)]
        k = np.searchsorted(self.ids, instance)
        k = np.minimum(k, len(self.ids) - 1)
        return np.where(self.ids[k] == instance, k, -1)

    def per_pixel(self, values: np.ndarray, instance: np.ndarray) -> np.ndarray:
        """``values`` (N + 1,: one per row, the default's last) looked up for every id of
        ``instance`` (any shape): one gather from an id-indexed table when ids are small."""
        values = np.asarray(values)
        instance = np.asarray(instance)
        if len(self.ids) and int(self.ids[-1]) < (1 << 20):
            by_id = values[self._lut()]
            return by_id[np.minimum(instance, len(by_id) - 1)]
        return values[self.rows(instance)]

    def _lut(self) -> np.ndarray:
        lut = self.__dict__.get("_lut_cache")
        if lut is None:
            lut = np.full(
                int(self.ids[-1]) + 2, -1, np.intp
            )  # the last entry: ids beyond the table
            lut[self.ids] = np.arange(len(self.ids))
            object.__setattr__(self, "_lut_cache", lut)
        return lut

    def reflective(self, instance: np.ndarray) -> np.ndarray:
        """(same shape) bool: metallic >= 0.5 or roughness <= 0.3 (see ``Material.reflective``)."""
        r = self.rows(instance)
        return (self.metallic[r] >= 0.5) | (self.roughness[r] <= 0.3)

    def any_reflective(self, ids: np.ndarray) -> bool:
        return bool(len(ids)) and bool(self.reflective(np.asarray(ids, np.uint32)).any())
