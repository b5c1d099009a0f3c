"""Closed primitive parts (boxes, cylinders, lofts) that assets are assembled from.

Every part is a watertight trimesh; an asset is the concatenation of disjoint or touching
parts, so it stays watertight (each edge shared by two faces) and the renderer may cull
its back faces.
"""

from __future__ import annotations

import numpy as np
import trimesh


def box(size, centre) -> trimesh.Trimesh:
    """Axis-aligned box of ``size`` (x, y, z) metres centred at ``centre``."""
    m = trimesh.creation.box(extents=np.asarray(size, float))
    m.apply_translation(np.asarray(centre, float))
    return m


def box_min(size, corner) -> trimesh.Trimesh:
    """Box of ``size`` whose minimum corner is ``corner``."""
    size, corner = np.asarray(size, float), np.asarray(corner, float)
    return box(size, corner + size / 2)


def cylinder(
    radius: float, length: float, centre, axis: str = "z", sections: int = 16
) -> trimesh.Trimesh:
    """Closed cylinder along ``axis`` ('x', 'y' or 'z')."""
    m = trimesh.creation.cylinder(radius=radius, height=length, sections=sections)
    if axis == "x":
        m.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    elif axis == "y":
        m.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    m.apply_translation(np.asarray(centre, float))
    return m


def loft(
    stations: np.ndarray,
    half_width: np.ndarray,
    z_bottom: np.ndarray,
    z_top: np.ndarray,
    ring: int = 16,
    exponent: float = 2.5,
) -> trimesh.Trimesh:
    """A closed body lofted through super-elliptic cross-sections along x.

    stations : (n,) x positions; half_width, z_bottom, z_top : (n,) section extents. Each
    section is |y/a|^e + |(z - zc)/b|^e = 1; the ends are capped.
    """
    n = len(stations)
    t = np.linspace(0, 2 * np.pi, ring, endpoint=False)
    c, s = np.cos(t), np.sin(t)
    ce = np.sign(c) * np.abs(c) ** (2 / exponent)
    se = np.sign(s) * np.abs(s) ** (2 / exponent)
    verts = []
    for i in range(n):
        a = half_width[i]
        zc, b = (z_top[i] + z_bottom[i]) / 2, (z_top[i] - z_bottom[i]) / 2
        verts.append(np.stack([np.full(ring, stations[i]), a * ce, zc + b * se], axis=1))
    v = np.concatenate(
        verts
        + [
            [[stations[0], 0, (z_top[0] + z_bottom[0]) / 2]],
            [[stations[-1], 0, (z_top[-1] + z_bottom[-1]) / 2]],
        ]
    )
    faces = []
    for i in range(n - 1):
        for k in range(ring):
            a0, a1 = i * ring + k, i * ring + (k + 1) % ring
            b0, b1 = a0 + ring, a1 + ring
            faces += [[a0, b0, b1], [a0, b1, a1]]
    c0, c1 = n * ring, n * ring + 1
    for k in range(ring):
        faces.append([c0, (k + 1) % ring, k])
        last = (n - 1) * ring
        faces.append([c1, last + k, last + (k + 1) % ring])
    m = trimesh.Trimesh(v, np.array(faces), process=False)
    trimesh.repair.fix_normals(m)
    return m


def assemble(parts: list[trimesh.Trimesh]) -> trimesh.Trimesh:
    """Concatenate parts into one mesh (no merging of vertices across parts)."""
    return trimesh.util.concatenate(parts)
