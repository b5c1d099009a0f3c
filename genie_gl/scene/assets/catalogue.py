"""The asset catalogue: each class's built-in variants plus meshes users register from files.

A registered file is loaded once, converted to the library's convention (metres, Z up,
centred on x = y = 0, standing on z = 0) and joins its class's variants, so scene building
draws and fits it like a built-in asset (turned, never scaled).

>>> register_asset("pallet", "my/pallet.glb")        # glTF: metres, Y up
'pallet'
>>> register_asset("klt", "crate.obj", units="cm", variant="crate")
'crate'
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
import trimesh

from ...errors import ConfigError, did_you_mean
from ..model import Mesh
from ..usd import read_usd
from . import library as lib

log = logging.getLogger(__name__)

UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "ft": 0.3048}
USD_SUFFIXES = (".usd", ".usda", ".usdc")
# default up axis of each format: glTF is Y up by its specification; OBJ, PLY and STL
# declare none (Z up assumed); USD stages carry their own (``None``: read from the stage)
FORMATS: dict[str, str | None] = {
    ".obj": "z",
    ".glb": "y",
    ".ply": "z",
    ".stl": "z",
    **{s: None for s in USD_SUFFIXES},
}
_Y_TO_Z = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])  # +90 deg about x: (x, y, z) -> (x, -z, y)


def _meters_per_unit(units: str | float | None, path: Path) -> float | None:
    if units is None:
        return None
    if isinstance(units, str):
        if units not in UNITS:
            raise ConfigError(
                f"{path}: unknown units {units!r}{did_you_mean(units, UNITS)}; expected "
                f"one of {', '.join(UNITS)} or metres per unit as a number"
            )
        return UNITS[units]
    mpu = float(units)
    if not np.isfinite(mpu) or mpu <= 0:
        raise ConfigError(
            f"{path}: units must be a positive number of metres per unit, got {units!r}"
        )
    return mpu


def _read_trimesh(path: Path) -> tuple[np.ndarray, np.ndarray]:
    try:
        # force="mesh" concatenates a file's scene graph with each node's transform applied
        m = trimesh.load(str(path), force="mesh", process=False)
    except Exception as exc:  # trimesh's loaders raise IndexError, ValueError, KeyError, ...
        kind = path.suffix[1:].upper()
        raise ConfigError(
            f"{path}: could not read a {kind} mesh ({type(exc).__name__}: {exc})"
        ) from exc
    return np.asarray(m.vertices, dtype=np.float64), np.asarray(
        getattr(m, "faces", np.zeros((0, 3)))
    )


def _read_usd(path: Path, mpu: float | None, up: str | None) -> tuple[np.ndarray, np.ndarray]:
    scene = read_usd(path, meters_per_unit=mpu, up_axis=up)
    vs, fs, n = [], [], 0
    for inst in scene.instances:  # merge every placed mesh into one, in stage (world) coordinates
        mesh = scene.meshes[inst.mesh]
        T = inst.world_from_model
        vs.append(mesh.vertices.astype(np.float64) @ T[:3, :3].T + T[:3, 3])
        fs.append(mesh.faces.astype(np.int64) + n)
        n += len(mesh.vertices)
    return np.concatenate(vs), np.concatenate(fs)


@lru_cache(maxsize=64)
def _load(path: str, stamp: tuple[int, int], mpu: float | None, up: str | None) -> trimesh.Trimesh:
    p = Path(path)
    if p.suffix.lower() in USD_SUFFIXES:
        v, f = _read_usd(p, mpu, up)
    else:
        v, f = _read_trimesh(p)
        if not np.all(np.isfinite(v)):
            bad = int((~np.isfinite(v)).any(axis=1).sum())
            raise ConfigError(
                f"{p}: {bad} of {len(v)} vertices are NaN or Inf; expected finite coordinates"
            )
        v = v * (1.0 if mpu is None else mpu)
        if (up or FORMATS[p.suffix.lower()]) == "y":
            v = v @ _Y_TO_Z.T
    if len(f) == 0:
        raise ConfigError(
            f"{p}: holds no triangle faces (a point cloud?); expected a triangle mesh"
        )
    lo, hi = v.min(axis=0), v.max(axis=0)
    v = v - [
        (lo[0] + hi[0]) / 2,
        (lo[1] + hi[1]) / 2,
        lo[2],
    ]  # the library's origin: centred, on z = 0
    m = trimesh.Trimesh(v, f, process=True)
    if m.is_watertight and not m.is_volume:
        # a closed mesh has its back faces culled when rendered: its faces must point outwards
        trimesh.repair.fix_normals(m, multibody=True)
    return m


def load_asset(
    path: str | os.PathLike, *, units: str | float | None = None, up: str | None = None
) -> trimesh.Trimesh:
    """Load a mesh file (.obj .glb .ply .stl .usd .usda .usdc) in the library's convention.

    Parameters
    ----------
    path : the file; an OBJ/glTF scene is flattened with its node transforms, a USD stage
        with its references, payloads, variants and instancing (:func:`..usd.read_usd`).
    units : "m", "cm", "mm", "in", "ft" or metres per unit; ``None``: the file's own (USD's
        ``metersPerUnit``, else metres).
    up : "z" or "y"; ``None``: the file's own (USD's ``upAxis``, Y for glTF, else Z).

    Returns
    -------
    trimesh.Trimesh in metres, Z up, its bounding box centred on x = y = 0 with its bottom at
    z = 0. Raises ConfigError naming the file when it is missing, of an unknown format,
    empty, unreadable, without triangles or with non-finite vertices.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in FORMATS:
        raise ConfigError(
            f"{p}: unknown asset format {p.suffix or '(no extension)'!r}; expected one of "
            f"{', '.join(FORMATS)}"
        )
    if up is not None and up not in ("y", "z"):
        raise ConfigError(f"{p}: up must be 'y' or 'z', got {up!r}")
    mpu = _meters_per_unit(units, p)
    if not p.is_file():
        raise ConfigError(f"{p}: no such asset file")
    st = p.stat()
    if st.st_size == 0:
        raise ConfigError(f"{p}: the file is empty; expected a mesh ({suffix[1:].upper()})")
    return _load(str(p.resolve()), (st.st_mtime_ns, st.st_size), mpu, up)


@dataclass(frozen=True)
class Source:
    """Where a registered variant came from, for messages: the file, the units it was read in
    (as given, or the file's own) and metres per unit (None: the file's own)."""

    path: str
    units: str
    meters_per_unit: float | None


def units_text(units: str | float | None, path: str | os.PathLike) -> str:
    """The unit a file is read in, in words: ``mm``, ``0.5 m per unit``, or the file's own."""
    if units is None:
        return (
            "the stage's own metersPerUnit"
            if Path(path).suffix.lower() in USD_SUFFIXES
            else "metres: the file states no units"
        )
    return units if isinstance(units, str) else f"{float(units):g} m per unit"


class Catalogue:
    """Asset class -> variant names: the library's built-in variants, then registered meshes."""

    def __init__(self, *, segments: int | None = None) -> None:
        self._registered: dict[str, dict[str, trimesh.Trimesh]] = {}
        self._sources: dict[tuple[str, str], Source] = {}
        self._scene_meshes: dict[
            tuple[str, str], Mesh
        ] = {}  # registered variants as scenes store them
        self.segments = lib.check_segments(segments, "Catalogue")

    def register(
        self,
        cls: str,
        path: str | os.PathLike,
        *,
        variant: str | None = None,
        units: str | float | None = None,
        up: str | None = None,
    ) -> str:
        """Load ``path`` (see :func:`load_asset`) as a variant of ``cls``; return its name.

        The name is ``variant`` or the file's stem; it must not be one the class has already.
        """
        if cls not in lib.VARIANTS:
            raise ConfigError(
                f"{path}: unknown asset class {cls!r}{did_you_mean(cls, lib.VARIANTS)} "
                f"(known: {', '.join(sorted(lib.VARIANTS))})"
            )
        name = variant or Path(path).stem
        if name in self.variants(cls):
            raise ConfigError(
                f"{path}: asset class {cls!r} already has a variant {name!r}; "
                "pass variant= to name this one"
            )
        mesh = load_asset(path, units=units, up=up)
        self._registered.setdefault(cls, {})[name] = mesh
        self._sources[(cls, name)] = Source(
            str(path), units_text(units, path), _meters_per_unit(units, Path(path))
        )
        log.debug(
            "registered %s variant %r from %s (%.3f x %.3f x %.3f m)",
            cls,
            name,
            path,
            *mesh.extents,
        )
        return name

    def variants(self, cls: str) -> list[str]:
        """The variant names of ``cls``: built-in first, then registered in order."""
        return list(lib.VARIANTS[cls]) + list(self._registered.get(cls, {}))

    def source(self, cls: str, variant: str) -> Source | None:
        """Where a registered variant came from (None for a built-in one)."""
        return self._sources.get((cls, variant))

    def registered(self) -> dict[str, list[str]]:
        """The registered variant names of each class that has some."""
        return {c: list(v) for c, v in self._registered.items() if v}

    def mesh(self, cls: str, variant: str) -> trimesh.Trimesh:
        """The mesh of a variant (built-in ones are built once per process and tessellation,
        with this catalogue's ``segments`` per circle; registered meshes are used as loaded)."""
        registered = self._registered.get(cls, {})
        return (
            registered[variant] if variant in registered else lib.make(cls, variant, self.segments)
        )

    def scene_mesh(self, cls: str, variant: str) -> Mesh:
        """:meth:`mesh` as a scene stores it (:class:`~genie_gl.scene.model.Mesh`), converted
        once per process (built-in variants) or per catalogue (registered ones): the scenes
        built from it share the one object, as they share the trimesh it comes from."""
        registered = self._registered.get(cls, {})
        if variant not in registered:
            return _builtin_scene_mesh(cls, variant, self.segments if cls in lib.CURVED else None)
        mesh = self._scene_meshes.get((cls, variant))
        if mesh is None:
            mesh = self._scene_meshes[(cls, variant)] = Mesh.from_trimesh(registered[variant])
        return mesh

    def build_builtins(self) -> int:
        """Build every built-in variant now, at this catalogue's tessellation (into the
        per-process caches :meth:`mesh` and :meth:`scene_mesh` read); returns how many. A
        dataset worker's warm-up does this, so no scene pays for a variant's first build."""
        n = 0
        for cls, variants in lib.VARIANTS.items():
            for variant in variants:
                self.scene_mesh(cls, variant)
                n += 1
        return n

    def copy(self, *, segments: int | None = None) -> "Catalogue":
        """A catalogue with the same registrations; registering into it leaves this one as is.

        ``segments`` (segments per circle of the built-in curved assets) replaces this one's
        when given."""
        other = Catalogue(segments=self.segments if segments is None else segments)
        other._registered = {c: dict(v) for c, v in self._registered.items()}
        other._sources = dict(self._sources)
        return other

    def clear(self) -> None:
        """Forget every registered asset (the built-in variants stay)."""
        self._registered.clear()
        self._sources.clear()
        self._scene_meshes.clear()


@lru_cache(maxsize=None)
def _builtin_scene_mesh(cls: str, variant: str, segments: int | None) -> Mesh:
    return Mesh.from_trimesh(lib.make(cls, variant, segments))


ASSETS = Catalogue()


def register_asset(
    cls: str,
    path: str | os.PathLike,
    *,
    variant: str | None = None,
    units: str | float | None = None,
    up: str | None = None,
) -> str:
    """Register a mesh file as a variant of asset class ``cls`` for every later ``build_scene``.

    ``units`` and ``up`` as in :func:`load_asset`; returns the variant's name. Undo with
    ``ASSETS.clear()``. Registrations live in this process: a dataset made by worker
    processes takes its assets from the strategy's ``scene.assets`` instead.
    """
    return ASSETS.register(cls, path, variant=variant, units=units, up=up)
