"""The ``Scene``: a library of meshes stored once, and instances of them placed in the world.

This is the contract between the scene stage and the renderer (DESIGN.md): the renderer
uploads each :class:`Mesh` once and draws its instances, instanced.

Precision: world position lives in the float64 instance transforms, never in float32
vertices. A mesh given with vertices far from its own origin (a part baked at 1e5 m) is
recentred on the way in, before the float32 cast: ``Mesh.origin`` keeps the float64 offset and
:meth:`Scene.add` composes it into the instance's transform. Degenerate input never reaches
the renderer as a traceback: a transform with a zero, non-finite or singular scale is refused
with an error naming the instance (or dropped and counted, ``degenerate="drop"``), and faces
with non-finite vertices or zero area are counted by :meth:`Scene.report` (the renderer
skips them).
"""

from __future__ import annotations

import hashlib
import logging
import math
import struct
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..validation.arguments import MAX_COORD_M
from ..errors import ConfigError

log = logging.getLogger(__name__)

_FLOAT32X7 = struct.Struct("=7f")  # a material's seven inputs as float32
RECENTRE_RATIO = 4.0  # vertices whose centre lies farther than this many radii out are recentred


@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh in its own (model) frame, in metres.

    Attributes
    ----------
    vertices : (V, 3) float32
    faces : (F, 3) uint32, indices into ``vertices``; counter-clockwise seen from outside.
    normals : (V, 3) float32 or None, unit vertex normals.
    colors : (V, 3) uint8 or None, per-vertex colours.
    closed : bool, True when the mesh is watertight (the renderer may cull back faces).
    origin : (3,) float64, where the vertices' frame lies in the frame they were given in: zero,
        unless they were given far from their own origin (more than ``RECENTRE_RATIO`` times
        their radius and 1 m away), then their bounding-box centre rounded to 1 mm, removed in
        float64 before the float32 cast. ``Scene.add`` composes it into the instance transform.
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None = None
    colors: np.ndarray | None = None
    closed: bool = False
    origin: np.ndarray | None = None

    def __post_init__(self) -> None:
        given = np.asarray(self.vertices)
        origin = (
            np.zeros(3) if self.origin is None else np.asarray(self.origin, np.float64).reshape(3)
        )
        if given.ndim == 2 and given.shape[1] == 3 and len(given) and self.origin is None:
            v64 = given.astype(np.float64)
            finite = np.isfinite(v64).all(axis=1)
            if finite.any():
                lo, hi = v64[finite].min(axis=0), v64[finite].max(axis=0)
                far = float(max(np.abs(lo).max(), np.abs(hi).max()))
                if far > MAX_COORD_M:
                    raise ConfigError(
                        f"mesh vertices: a coordinate of {far:.3g} m, beyond {MAX_COORD_M:g} m "
                        "(absurd "
                        "coordinates; check the file's units)"
                    )
                centre, radius = (lo + hi) / 2, float(np.linalg.norm(hi - lo)) / 2
                if np.linalg.norm(centre) > max(RECENTRE_RATIO * radius, 1.0):
                    origin = np.round(centre, 3)
                    given = v64 - origin
        object.__setattr__(self, "origin", origin)
        v = np.ascontiguousarray(given, dtype=np.float32)
        f = np.ascontiguousarray(self.faces)
        if v.ndim != 2 or v.shape[1] != 3:
            raise ConfigError(f"mesh vertices: expected shape (V, 3), got {v.shape}")
        if f.size == 0:
            f = f.reshape(0, 3)
        if f.ndim != 2 or f.shape[1] != 3:
            raise ConfigError(f"mesh faces: expected shape (F, 3) triangles, got {f.shape}")
        if f.size and (f.min() < 0 or f.max() >= len(v)):
            raise ConfigError(
                f"mesh faces: index out of range [0, {len(v)}) (min {f.min()}, max {f.max()})"
            )
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "faces", f.astype(np.uint32))
        if self.normals is not None:
            n = np.ascontiguousarray(self.normals, dtype=np.float32)
            if n.shape != v.shape:
                raise ConfigError(f"mesh normals: expected shape {v.shape}, got {n.shape}")
            object.__setattr__(self, "normals", n)
        if self.colors is not None:
            c = np.ascontiguousarray(self.colors)
            if c.ndim != 2 or len(c) != len(v) or c.shape[1] not in (3, 4):
                raise ConfigError(f"mesh colors: expected shape ({len(v)}, 3), got {c.shape}")
            object.__setattr__(self, "colors", np.ascontiguousarray(c[:, :3], dtype=np.uint8))

    @classmethod
    def from_trimesh(cls, mesh: Any) -> "Mesh":
        """Build from a ``trimesh.Trimesh`` (vertex colours kept when it has them)."""
        colors = None
        visual = getattr(mesh, "visual", None)
        if visual is not None and getattr(visual, "kind", None) == "vertex":
            colors = np.asarray(visual.vertex_colors)[:, :3]
        return cls(
            vertices=np.asarray(mesh.vertices),
            faces=np.asarray(mesh.faces),
            colors=colors,
            closed=bool(mesh.is_watertight) if len(mesh.faces) else False,
        )

    def digest(self) -> str:
        """A content hash: equal geometry gives an equal digest (used to store meshes once)."""
        h = hashlib.blake2b(digest_size=12)
        for a in (self.vertices, self.faces, self.normals, self.colors, self.origin):
            h.update(b"-" if a is None else a.tobytes())
        h.update(b"c" if self.closed else b"o")
        return h.hexdigest()

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) float64: min and max corner; NaN when the mesh is empty."""
        if len(self.vertices) == 0:
            return np.full((2, 3), np.nan)
        v = self.vertices.astype(np.float64)
        return np.stack([np.nanmin(v, axis=0), np.nanmax(v, axis=0)])


@dataclass(frozen=True)
class Material:
    """The UsdPreviewSurface inputs sensor effects read (nothing else does).

    Attributes
    ----------
    diffuse_color : (3,) floats in [0, 1], linear RGB albedo (``inputs:diffuseColor``).
    metallic : 0 (dielectric) .. 1 (bare metal) (``inputs:metallic``).
    roughness : 0 (mirror) .. 1 (matte) (``inputs:roughness``).
    opacity : 0 (clear) .. 1 (opaque) (``inputs:opacity``).
    ior : index of refraction (``inputs:ior``).

    The defaults are UsdPreviewSurface's own (a matte grey dielectric): what a prim without a
    bound material is read as.
    """

    diffuse_color: tuple[float, float, float] = (0.18, 0.18, 0.18)
    metallic: float = 0.0
    roughness: float = 0.5
    opacity: float = 1.0
    ior: float = 1.5

    def __post_init__(self) -> None:
        # values held at float32 precision, as USD stores them: a round trip is exact. One
        # pack to float32 and back rounds all seven as np.float32 does (a C cast); anything it
        # cannot take (a string, a wrong length, an overflow) goes the slow way, to its message.
        try:
            *c, metallic, roughness, opacity, ior = _FLOAT32X7.unpack(
                _FLOAT32X7.pack(
                    *self.diffuse_color, self.metallic, self.roughness, self.opacity, self.ior
                )
            )
        except (struct.error, OverflowError, TypeError):
            self._check_slowly()
            return
        if (
            0.0 <= c[0] <= 1.0
            and 0.0 <= c[1] <= 1.0
            and 0.0 <= c[2] <= 1.0
            and 0.0 <= metallic <= 1.0
            and 0.0 <= roughness <= 1.0
            and 0.0 <= opacity <= 1.0
            and 1.0 <= float(self.ior) <= 5.0
        ):
            object.__setattr__(self, "diffuse_color", tuple(c))
            object.__setattr__(self, "metallic", metallic)
            object.__setattr__(self, "roughness", roughness)
            object.__setattr__(self, "opacity", opacity)
            object.__setattr__(self, "ior", ior)
            return
        self._check_slowly()

    def _check_slowly(self) -> None:
        """Each value on its own: rounded to float32 and checked, the first bad one named."""
        c = tuple(float(np.float32(x)) for x in self.diffuse_color)
        if len(c) != 3 or not all(0.0 <= x <= 1.0 for x in c):
            raise ConfigError(
                f"material diffuse_color: expected 3 values in [0, 1], got {self.diffuse_color!r}"
            )
        for name in ("metallic", "roughness", "opacity"):
            v = float(np.float32(getattr(self, name)))
            if not 0.0 <= v <= 1.0:
                raise ConfigError(f"material {name}: expected a value in [0, 1], got {v}")
            object.__setattr__(self, name, v)
        if not 1.0 <= float(self.ior) <= 5.0:
            raise ConfigError(f"material ior: expected 1 <= ior <= 5, got {self.ior}")
        object.__setattr__(self, "diffuse_color", c)
        object.__setattr__(self, "ior", float(np.float32(self.ior)))

    @property
    def albedo(self) -> float:
        """Mean diffuse reflectance (the grey a ToF sensor's near-infrared light sees)."""
        return float(sum(self.diffuse_color) / 3.0)

    @property
    def reflective(self) -> bool:
        """True for surfaces that reflect specularly enough to matter to active sensors:
        metallic >= 0.5 or roughness <= 0.3 (see :mod:`genie_gl.scene.materials`)."""
        return self.metallic >= 0.5 or self.roughness <= 0.3


DEFAULT_MATERIAL = Material()


@dataclass(frozen=True, eq=False)
class Instance:
    """One placed copy of a library mesh.

    Attributes
    ----------
    mesh : str, key into ``Scene.meshes``.
    world_from_model : (4, 4) float64, rigid (or similar) transform.
    semantic : int, class id (DESIGN.md label map), fits uint16.
    instance : int, unique within the scene, > 0, fits uint32.
    color : (3,) uint8, the colour the renderer shades with.
    name : str, a human-readable name (the USD prim name when written).
    material : Material or None (None: no material bound; read as ``DEFAULT_MATERIAL``).
    """

    mesh: str
    world_from_model: np.ndarray
    semantic: int
    instance: int
    color: tuple[int, int, int]
    name: str = ""
    material: Material | None = None


def _as_transform(transform: Any, check: bool = True) -> np.ndarray:
    t = np.eye(4) if transform is None else np.array(transform, dtype=np.float64)
    if t.shape == (3,):
        m = np.eye(4)
        m[:3, 3] = t
        t = m
    if t.shape != (4, 4):
        raise ConfigError(
            f"transform: expected a (4, 4) matrix or a (3,) translation, got {t.shape}"
        )
    if check and not np.all(np.isfinite(t)):
        raise ConfigError("transform: contains NaN or Inf")
    x, y, z = t[:3, 3].tolist()
    if (
        (abs(x) > MAX_COORD_M or abs(y) > MAX_COORD_M or abs(z) > MAX_COORD_M)
        and x == x
        and y == y
        and z == z
    ):
        raise ConfigError(
            f"transform: translation {t[:3, 3].tolist()} m is beyond {MAX_COORD_M:g} m (absurd "
            "coordinates)"
        )
    return t


def degenerate_reason(t: np.ndarray) -> str | None:
    """Why the (4, 4) transform ``t`` cannot place geometry, or None when it can: a NaN or Inf,
    a zero scale, a singular (flattening) linear part, or a projective last row. (Plain Python
    arithmetic: it runs once per instance, and scenes have hundreds of thousands.)"""
    (a, b, c, x), (d, e, f, y), (g, h, i, z), last = t.tolist()
    if not all(map(math.isfinite, (a, b, c, x, d, e, f, y, g, h, i, z, *last))):
        return "its transform contains NaN or Inf"
    if abs(last[0]) + abs(last[1]) + abs(last[2]) + abs(last[3] - 1) > 1e-12:
        return f"its transform's last row is {last}, expected [0, 0, 0, 1]"
    scale = [
        math.sqrt(a * a + d * d + g * g),
        math.sqrt(b * b + e * e + h * h),
        math.sqrt(c * c + f * f + i * i),
    ]
    if min(scale) == 0:
        return f"its transform has a zero scale ({[round(v, 6) for v in scale]})"
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    if abs(det) <= 1e-12 * scale[0] * scale[1] * scale[2]:
        return (
            "its transform is singular (it flattens the mesh; scale "
            f"{[round(v, 6) for v in scale]})"
        )
    return None


def face_defects(mesh: "Mesh") -> tuple[np.ndarray, np.ndarray]:
    """(F,) bool masks of ``mesh``'s faces with a non-finite vertex, and of finite faces with
    zero area (the faces the renderer skips)."""
    if len(mesh.faces) == 0:
        return np.zeros(0, bool), np.zeros(0, bool)
    tri = mesh.vertices.astype(np.float64)[mesh.faces]
    finite = np.isfinite(tri).all(axis=(1, 2))
    with np.errstate(invalid="ignore"):
        area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    return ~finite, finite & ~(area2 > 0)


def _translation(offset: np.ndarray | None) -> np.ndarray:
    t = np.eye(4)
    if offset is not None:
        t[:3, 3] = offset
    return t


def _palette(instance: int) -> tuple[int, int, int]:
    # A deterministic, well-spread colour per instance id (golden-ratio hue walk).
    h = (instance * 0.618033988749895) % 1.0
    i, f = int(h * 6), (h * 6) % 1.0
    s, v = 0.55, 0.9
    p, q, t = v * (1 - s), v * (1 - s * f), v * (1 - s * (1 - f))
    rgb = [(v, t, p), (q, v, p), (p, v, t), (p, q, v), (t, p, v), (v, p, q)][i % 6]
    return tuple(int(round(255 * c)) for c in rgb)  # type: ignore[return-value]


def _whole(value: Any, what: str) -> int:
    """``value`` as an int when it is a whole number (3 or 3.0), else a ConfigError naming
    ``what`` (int() would cut 1.5 to 1 and fail on a string with a TypeError or ValueError)."""
    try:
        whole = int(value)
        exact = whole == value
    except (TypeError, ValueError, OverflowError):
        exact = False
    if not exact:
        raise ConfigError(f"scene.add: {what} must be a whole number, got {value!r}")
    return whole


@dataclass(eq=False)
class Scene:
    """Meshes stored once by name, and the instances that place them in the world (Z up, metres).

    >>> scene = Scene()
    >>> iid = scene.add(trimesh.creation.box((1, 1, 1)), np.eye(4), semantic=1)
    """

    meshes: dict[str, Mesh] = field(default_factory=dict)
    instances: list[Instance] = field(default_factory=list)
    metadata: dict[str, Any] = field(default_factory=dict)
    _digests: dict[str, str] = field(default_factory=dict, repr=False)
    _ids: set[int] | None = field(default=None, repr=False)
    _max_id: int = field(
        default=0, repr=False
    )  # the largest of ``_ids``: the next free id is one more
    dropped: list[str] = field(default_factory=list, repr=False)

    def add_mesh(self, mesh: Any, name: str | None = None) -> str:
        """Store a mesh (``Mesh``, ``trimesh.Trimesh`` or ``(vertices, faces)``); return its key.

        A mesh equal to one already stored is not stored again: its existing key is returned.
        """
        m = _as_mesh(mesh)
        digest = m.digest()
        if digest in self._digests:
            return self._digests[digest]
        key = name or f"mesh_{len(self.meshes):04d}"
        if key in self.meshes:
            key = f"{key}_{len(self.meshes):04d}"
        self.meshes[key] = m
        self._digests[digest] = key
        return key

    def add(
        self,
        mesh: Any,
        transform: Any = None,
        *,
        semantic: int = 0,
        instance: int | None = None,
        color: tuple[int, int, int] | None = None,
        name: str = "",
        degenerate: str = "raise",
        where: str = "",
        material: Material | None = None,
    ) -> int:
        """Place ``mesh`` (a key of ``meshes``, a ``Mesh``, a trimesh, or ``(V, F)`` arrays).

        Returns the instance id: ``instance`` if given (must be unused, 1..2**32-1), else the
        next free id. A transform with a zero, non-finite or singular scale is refused with a
        ConfigError naming the instance (``degenerate="raise"``), or skipped and counted in
        :meth:`report` (``degenerate="drop"``; then 0 is returned). ``where`` names the
        instance in those messages (a USD prim path; default: ``name``).
        """
        key = mesh if isinstance(mesh, str) else self.add_mesh(mesh)
        if key not in self.meshes:
            raise ConfigError(f"scene.add: no mesh named {key!r} in the scene")
        t = _as_transform(transform, check=False)
        if (why := degenerate_reason(t)) is not None:
            who = (
                where or name or (f"instance {instance}" if instance is not None else f"mesh {key}")
            )
            if degenerate == "drop":
                self.dropped.append(f"{who}: {why}")
                log.warning("scene: dropped %s: %s", who, why)
                return 0
            raise ConfigError(
                f"scene.add: {who!r}: {why}; fix or remove it (or add it with degenerate='drop')"
            )
        origin = self.meshes[key].origin
        transform = t if not (origin[0] or origin[1] or origin[2]) else t @ _translation(origin)
        used = self._used_ids
        if instance is None:
            instance = self._max_id + 1
        iid, sem = _whole(instance, "instance id"), _whole(semantic, "semantic id")
        if not 0 < iid < 2**32:
            raise ConfigError(f"scene.add: instance id must be in 1..2**32-1, got {instance}")
        if iid in used:
            raise ConfigError(f"scene.add: instance id {instance} is already used")
        if not 0 <= sem < 2**16:
            raise ConfigError(f"scene.add: semantic id must be in 0..65535, got {semantic}")
        if material is not None and not isinstance(material, Material):
            raise ConfigError(
                f"scene.add: material must be a genie_gl.Material, got {type(material).__name__}"
            )
        col = _palette(iid) if color is None else tuple(map(int, color[:3]))
        self.instances.append(Instance(key, transform, sem, iid, col, name, material))  # type: ignore[arg-type]
        used.add(iid)
        if iid > self._max_id:
            self._max_id = iid
        return iid

    def report(self) -> dict[str, Any]:
        """What the scene holds and what of it cannot be drawn: instances dropped for a
        degenerate transform (with why), and faces skipped for non-finite vertices or zero
        area (counted over the instances that draw them)."""
        per_mesh = {k: face_defects(m) for k, m in self.meshes.items()}
        uses: dict[str, int] = {}
        for inst in self.instances:
            uses[inst.mesh] = uses.get(inst.mesh, 0) + 1
        nonfinite = sum(int(per_mesh[k][0].sum()) * n for k, n in uses.items())
        zero_area = sum(int(per_mesh[k][1].sum()) * n for k, n in uses.items())
        return {
            "instances": len(self.instances),
            "meshes": len(self.meshes),
            "triangles": sum(len(self.meshes[k].faces) * n for k, n in uses.items()),
            "dropped_instances": len(self.dropped),
            "dropped": list(self.dropped),
            "faces_nonfinite": nonfinite,
            "faces_zero_area": zero_area,
        }

    @property
    def _used_ids(self) -> set[int]:
        """The instance ids in use (rebuilt, with their maximum, when ``instances`` was
        changed from outside)."""
        if self._ids is None or len(self._ids) != len(self.instances):
            self._ids = {i.instance for i in self.instances}
            self._max_id = max(self._ids, default=0)
        return self._ids

    def bounds(self) -> np.ndarray:
        """(2, 3) float64 world-space bounding box of all instances (NaN when empty)."""
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        for inst in self.instances:
            b = self.meshes[inst.mesh].bounds
            if not np.all(np.isfinite(b)):
                continue
            corners = np.array([[x, y, z, 1.0] for x in b[:, 0] for y in b[:, 1] for z in b[:, 2]])
            w = corners @ inst.world_from_model.T
            lo, hi = np.minimum(lo, w[:, :3].min(0)), np.maximum(hi, w[:, :3].max(0))
        if not np.all(np.isfinite(lo)):
            return np.full((2, 3), np.nan)
        return np.stack([lo, hi])

    def __len__(self) -> int:
        return len(self.instances)


def _as_mesh(mesh: Any) -> Mesh:
    if isinstance(mesh, Mesh):
        return mesh
    if isinstance(mesh, tuple) and len(mesh) == 2:
        return Mesh(vertices=mesh[0], faces=mesh[1])
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        return Mesh.from_trimesh(mesh)
    raise ConfigError(
        f"scene: cannot use a {type(mesh).__name__} as a mesh; expected genie_gl.Mesh, "
        "trimesh.Trimesh or (vertices, faces)"
    )
