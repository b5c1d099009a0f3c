"""Implicit USD gprims (Sphere, Cube, Cylinder, Cone, Capsule) as triangle meshes.

Shapes follow the UsdGeom schemas: centred on the prim's origin, the long axis along
``axis`` ("X", "Y" or "Z"); a Cone's apex at +height/2; a Capsule's ``height`` is the length
of its cylinder (the caps add a radius at each end). ``segments`` is the number of segments
per circle (an accuracy knob: the facets of a circle of radius r lie within
r·(1 − cos(π/segments)) of it). Faces wind counter-clockwise seen from outside, so the meshes
are closed and may have their back faces culled.
"""

from __future__ import annotations

import numpy as np
import trimesh

from ..errors import ConfigError
from .model import Mesh

# rotation taking the Z axis of the trimesh primitives onto the gprim's axis
_AXIS = {
    "Z": np.eye(3),
    "X": np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0.0]]),
    "Y": np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0.0]]),
}


def tessellate(
    kind: str,
    segments: int,
    *,
    radius: float = 1.0,
    height: float = 2.0,
    size: float = 2.0,
    axis: str = "Z",
) -> Mesh:
    """A closed triangle mesh of gprim ``kind`` with ``segments`` (>= 3) segments per circle."""
    if segments < 3:
        raise ConfigError(f"gprim tessellation: segments must be >= 3, got {segments}")
    if axis not in _AXIS:
        raise ConfigError(f"gprim {kind}: axis must be X, Y or Z, got {axis!r}")
    for name, v in (("radius", radius), ("height", height), ("size", size)):
        if not (np.isfinite(v) and v >= 0):
            raise ConfigError(f"gprim {kind}: {name} must be a finite number >= 0, got {v}")
    if kind == "Sphere":
        m = trimesh.creation.uv_sphere(radius=radius, count=[max(2, segments // 2) + 1, segments])
    elif kind == "Cube":
        m = trimesh.creation.box(extents=(size, size, size))
    elif kind == "Cylinder":
        m = trimesh.creation.cylinder(radius=radius, height=height, sections=segments)
    elif kind == "Cone":
        m = trimesh.creation.cone(radius=radius, height=height, sections=segments)
        m.apply_translation((0, 0, -height / 2))  # trimesh: base at z = 0; USD: centred
    elif kind == "Capsule":
        m = trimesh.creation.capsule(height=height, radius=radius, count=[segments, segments])
    else:
        raise ConfigError(
            f"gprim: unknown kind {kind!r}; expected Sphere, Cube, Cylinder, Cone or Capsule"
        )
    v = np.asarray(m.vertices) @ _AXIS[axis].T
    return Mesh(v, np.asarray(m.faces), closed=True)
