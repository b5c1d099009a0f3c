"""Rays as a sensor casts them, and exact ray casting against a scene.

:class:`Rays` describes a bundle: where the rays start, where they go, and how they lie on
a 2-D grid (the image plane of a pinhole camera, a lens's own pixels, an azimuth-elevation
grid of a spinning head or a panorama, or no grid: a plain list). :func:`cast_rays` meets
any rays with a scene exactly, in float64, through a bounding volume hierarchy
(:mod:`genie_gl.render.bvh`): per ray the distance, instance, semantic class, face and
normal of the nearest surface. A ray that meets nothing has distance 0 (the project's "no
return", as a depth of 0), instance 0, semantic 0, face -1 and a zero normal.

>>> hits = gg.cast_rays(scene, np.zeros(3), [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
>>> hits.distance, hits.instance
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ConfigError
from ..scene.model import Scene
from . import bundles
from .bundles import cast_binned, clusters, hit_records, unit_rows
from .bvh import build_nodes, cast_all, triangle_boxes

GRIDS = (
    "pinhole",
    "lens",
    "sphere",
    "azimuth_elevation",
    "list",
)  # how a bundle's rays lie on a 2-D grid


def _unit(directions: Any, what: str) -> np.ndarray:
    """(N, 3) float64 unit rows of ``directions`` (one row or many); a zero or non-finite row
    is refused."""
    d = np.asarray(directions, dtype=np.float64)
    d = d.reshape(1, -1) if d.ndim == 1 else d
    if d.ndim != 2 or d.shape[1] != 3:
        raise ConfigError(f"{what}: directions must have shape (N, 3), got {np.shape(directions)}")
    out = np.empty((len(d), 3))
    bad = unit_rows(np.ascontiguousarray(d), out) if len(d) else -1
    if bad >= 0:
        raise ConfigError(
            f"{what}: direction {bad} is zero or not finite; every ray needs a direction"
        )
    return out


def _origins(origins: Any, n: int, what: str) -> np.ndarray:
    """(3,) or (n, 3) float64 finite origins."""
    o = np.array(origins, dtype=np.float64)  # a copy: the record does not share the caller's
    if o.shape != (3,) and o.shape != (n, 3):
        raise ConfigError(f"{what}: origins must have shape (3,) or ({n}, 3), got {o.shape}")
    if not np.isfinite(o).all():
        raise ConfigError(f"{what}: an origin is not finite")
    return o


@dataclass(frozen=True, eq=False)
class Rays:
    """A bundle of rays and the 2-D grid it lies on.

    Attributes
    ----------
    origins : (3,) float64, one origin shared by every ray (a camera, a LiDAR head), or
        (N, 3) float64, one per ray; metres, world frame.
    directions : (N, 3) float64 unit vectors (normalised on construction), world frame.
    grid : str, how the rays are binned on a 2-D grid, one of :data:`GRIDS`: ``pinhole``
        (pixel centres of a pinhole image plane), ``lens`` (a distorted lens's pixels, where
        their rays cross the undistorted normalised plane), ``sphere`` (a lens past 180
        degrees, on the sphere of directions), ``azimuth_elevation`` (a spinning head or a
        360-degree panorama), ``list`` (no grid).
    shape : (rows, cols) of the grid, with rows * cols == N; None for a ``list``.
    ring : (N,) uint16 or None, the laser ring each ray belongs to.
    time : (N,) float64 or None, seconds since the start of the sweep.
    """

    origins: np.ndarray
    directions: np.ndarray
    grid: str = "list"
    shape: tuple[int, int] | None = None
    ring: np.ndarray | None = None
    time: np.ndarray | None = None

    def __post_init__(self) -> None:
        d = _unit(self.directions, "Rays")
        object.__setattr__(self, "directions", d)
        object.__setattr__(self, "origins", _origins(self.origins, len(d), "Rays"))
        if self.grid not in GRIDS:
            raise ConfigError(f"Rays: grid must be one of {', '.join(GRIDS)}, got {self.grid!r}")
        if self.grid == "list":
            if self.shape is not None:
                raise ConfigError("Rays: a plain list of rays has no grid shape (shape=None)")
        else:
            if (
                self.shape is None
                or len(self.shape) != 2
                or int(self.shape[0]) * int(self.shape[1]) != len(d)
            ):
                raise ConfigError(
                    f"Rays: a {self.grid} grid needs shape (rows, cols) with rows * cols == "
                    f"{len(d)}, "
                    f"got {self.shape}"
                )
            object.__setattr__(self, "shape", (int(self.shape[0]), int(self.shape[1])))
        for name, dtype in (("ring", np.uint16), ("time", np.float64)):
            v = getattr(self, name)
            if v is not None:
                v = np.asarray(v)
                if v.shape != (len(d),):
                    raise ConfigError(f"Rays: {name} must have shape ({len(d)},), got {v.shape}")
                object.__setattr__(self, name, v.astype(dtype))

    def __len__(self) -> int:
        return len(self.directions)

    @classmethod
    def azimuth_elevation(
        cls,
        origin: ArrayLike,
        azimuth_rad: ArrayLike,
        elevation_rad: ArrayLike,
        world_from_sensor: ArrayLike | None = None,
    ) -> "Rays":
        """The grid of every elevation (rows) by every azimuth (columns): x forward, y left, z
        up in the sensor frame (azimuth from x towards y, elevation up from the x-y plane),
        turned into the world by ``world_from_sensor`` (4, 4; its translation is ignored:
        ``origin`` is the world origin of the rays)."""
        az = np.asarray(azimuth_rad, np.float64).reshape(-1)
        el = np.asarray(elevation_rad, np.float64).reshape(-1)
        ce = np.cos(el)[:, None]
        d = np.stack(
            [
                ce * np.cos(az)[None, :],
                ce * np.sin(az)[None, :],
                np.broadcast_to(np.sin(el)[:, None], (len(el), len(az))),
            ],
            axis=-1,
        ).reshape(-1, 3)
        if world_from_sensor is not None:
            d = d @ np.asarray(world_from_sensor, np.float64)[:3, :3].T
        return cls(np.asarray(origin, np.float64), d, "azimuth_elevation", (len(el), len(az)))


@dataclass(frozen=True, eq=False)
class RayHits:
    """Per ray, the nearest surface it meets.

    Attributes
    ----------
    distance : (N,) float64, metres along the unit direction from the origin; 0 where the
        ray meets nothing (the project's "no return").
    instance : (N,) uint32, the instance id hit; 0 where none.
    semantic : (N,) uint16, its semantic class; 0 where none.
    face : (N,) int64, the face hit, an index into its instance's mesh faces; -1 where none.
    normal : (N, 3) float32, the unit normal of the face hit, world frame, turned to face the
        ray's origin; 0 where none.
    hit : (N,) bool, where the ray meets a surface (``distance > 0``).
    """

    distance: np.ndarray
    instance: np.ndarray
    semantic: np.ndarray
    face: np.ndarray
    normal: np.ndarray
    hit: np.ndarray

    def __post_init__(self) -> None:
        n = len(self.distance)
        for name, dtype, shape in (
            ("distance", np.float64, (n,)),
            ("instance", np.uint32, (n,)),
            ("semantic", np.uint16, (n,)),
            ("face", np.int64, (n,)),
            ("normal", np.float32, (n, 3)),
            ("hit", np.bool_, (n,)),
        ):
            v = getattr(self, name)
            if v.dtype != dtype or v.shape != shape:
                raise ConfigError(
                    f"RayHits.{name}: expected {np.dtype(dtype).name} {shape}, got {v.dtype} "
                    f"{v.shape}"
                )


class RayCaster:
    """A scene's triangles in the world frame (float64) and their hierarchy, built once.

    Parameters
    ----------
    scene : the scene; later changes to it are not seen (make another caster).
    """

    def __init__(self, scene: Scene) -> None:
        verts, tris, slots, faces = [], [], [], []
        base = 0
        ids, sems = [], []
        for s, inst in enumerate(scene.instances):
            m = scene.meshes[inst.mesh]
            T = np.asarray(inst.world_from_model, np.float64)
            v = m.vertices.astype(np.float64) @ T[:3, :3].T + T[:3, 3]
            f = m.faces.astype(np.int64)
            ok = (
                np.isfinite(v).all(axis=1)[f].all(axis=1)
            )  # faces with a non-finite corner are not drawn
            verts.append(v)
            tris.append(f[ok] + base)
            slots.append(np.full(int(ok.sum()), s, np.int32))
            faces.append(np.flatnonzero(ok).astype(np.int32))
            ids.append(inst.instance)
            sems.append(inst.semantic)
            base += len(v)
        self.vertices = np.ascontiguousarray(np.concatenate(verts) if verts else np.zeros((0, 3)))
        self.vertices[~np.isfinite(self.vertices)] = 0.0  # rows no kept face uses
        tri = np.concatenate(tris) if tris else np.zeros((0, 3), np.int64)
        self.slot = np.concatenate(slots) if slots else np.zeros(0, np.int32)
        self.face = np.concatenate(faces) if faces else np.zeros(0, np.int32)
        self.ids = np.array(ids + [0], np.uint32)  # per slot, and 0 after the last: no hit
        self.semantics = np.array(sems + [0], np.uint16)
        self.flat = np.ascontiguousarray(
            self.vertices[tri].reshape(-1, 9)
        )  # (n, 9) in the joined order
        self.triangles = len(tri)
        self._tri = tri
        self._hierarchy: tuple | None = None
        self._clusters: dict[int, np.ndarray] = {}  # cluster size -> cluster nodes
        self._stamp = _stamp(scene)

    def hierarchy(self) -> tuple:
        """(corners (n, 9) in leaf order, rank (n,) their triangle numbers, *nodes), built on
        first use."""
        if self._hierarchy is None:
            lo, hi = triangle_boxes(self.vertices, self._tri)
            order, *nodes = build_nodes(lo, hi)
            corners = np.ascontiguousarray(self.flat[order])
            self._hierarchy = (corners, order, *nodes)
        return self._hierarchy

    def cast(self, origins: ArrayLike, directions: ArrayLike) -> RayHits:
        """The nearest hit of every ray (see :func:`cast_rays`)."""
        d = _unit(directions, "cast_rays")
        o = _origins(origins, len(d), "cast_rays")
        one = o.ndim == 1
        o2 = np.ascontiguousarray(o.reshape(-1, 3))
        t = np.empty(len(d))
        k = np.empty(len(d), np.int64)
        cast_all(o2, one, d, *self.hierarchy(), t, k)
        return self.hits(t, k, d)

    def cast_bundle(self, rays: "Rays") -> RayHits:
        """The nearest hit of every ray of ``rays`` by :mod:`.bundles`' binned engine (see
        :func:`cast_bundle`)."""
        h = self.hierarchy()
        size = bundles.cluster_size(self.triangles, len(rays))
        if size not in self._clusters:
            self._clusters[size] = clusters(h, size)
        t, k = cast_binned(h, rays.origins, rays.directions, self._clusters[size])
        return self.hits(t, k, rays.directions)

    def hits(self, t: np.ndarray, k: np.ndarray, d: np.ndarray) -> RayHits:
        """The record of distances ``t`` (inf: none) and triangle numbers ``k`` (-1: none) of
        rays ``d``: the normal is the face's, turned against the ray."""
        n = len(t)
        dist, slot, face = np.empty(n), np.empty(n, np.int64), np.empty(n, np.int64)
        normal = np.empty((n, 3), np.float32)
        hit_records(
            t, k, d, self.flat, self.slot, self.face, len(self.ids) - 1, dist, slot, face, normal
        )
        return RayHits(dist, self.ids[slot], self.semantics[slot], face, normal, k >= 0)


def _stamp(scene: Scene) -> tuple:
    """What tells a cached caster its scene changed: the number of instances and meshes and
    the identity of the last instance."""
    return (
        len(scene.instances),
        len(scene.meshes),
        id(scene.instances[-1]) if scene.instances else 0,
    )


_casters: "weakref.WeakKeyDictionary[Scene, RayCaster]" = weakref.WeakKeyDictionary()


def caster_of(scene: Scene) -> RayCaster:
    """The scene's cached caster, made afresh when the scene changed."""
    caster = _casters.get(scene)
    if caster is None or caster._stamp != _stamp(scene):
        caster = _casters[scene] = RayCaster(scene)
    return caster


def cast_bundle(scene: Scene, rays: Rays) -> RayHits:
    """The nearest surface of ``scene`` along every ray of a coherent bundle, exact in float64.

    The rays are binned on a grid of world azimuth and elevation (:mod:`.bundles`), each
    walking only the hierarchy's clusters of its cell: made for a spinning head's scan or a
    panorama, rays from one origin or from origins within a small ball; exact for any rays. The
    answer equals :func:`cast_rays`' bit for bit
    (distance, instance, face; the same tie rule).

    Parameters
    ----------
    scene : the scene.
    rays : the bundle (:class:`Rays`, any grid).

    Returns
    -------
    RayHits : as :func:`cast_rays`.
    """
    if not isinstance(rays, Rays):
        raise ConfigError(f"cast_bundle: rays must be a Rays record, got {type(rays).__name__}")
    return caster_of(scene).cast_bundle(rays)


def cast_rays(
    scene: Scene, origins: ArrayLike | Rays, directions: ArrayLike | None = None
) -> RayHits:
    """The nearest surface of ``scene`` along every ray, exact in float64.

    Parameters
    ----------
    scene : the scene (its hierarchy is built on the first call and kept while the scene
        lives and keeps its instances).
    origins : (3,) one origin for every ray, or (N, 3); metres, world frame. Or a
        :class:`Rays` record (then no ``directions``): one on an ``azimuth_elevation`` grid
        is cast by :func:`cast_bundle` (the same answer).
    directions : (N, 3) or (3,); normalised here (a zero or non-finite one is refused).

    Returns
    -------
    RayHits : per ray distance (0: no hit), instance, semantic, face, normal and hit. A ray
        through an edge or vertex that triangles share hits (no ray slips between them);
        hits at one float64 distance go to the instance earlier in ``scene.instances``, then
        the lower face. A hit must lie strictly in front of the origin (distance > 0).
    """
    if isinstance(origins, Rays):
        if directions is not None:
            raise ConfigError("cast_rays: given a Rays record, pass no directions")
        return (
            cast_bundle(scene, origins)
            if origins.grid == "azimuth_elevation"
            else caster_of(scene).cast(origins.origins, origins.directions)
        )
    if directions is None:
        raise ConfigError("cast_rays: directions are missing (or pass one Rays record)")
    return caster_of(scene).cast(origins, directions)
