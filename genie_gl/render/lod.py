"""Level of detail: simplified meshes for instances that look small, an accuracy knob.

Off by default: the renderer draws every mesh as given and its frames are exact. With a
:class:`LevelOfDetail`, each mesh of at least ``min_faces`` faces gets one simplified copy
(quadric decimation by ``fast-simplification`` keeping ``keep`` of its faces, made once per
mesh at upload), and per frame an instance whose bounding sphere projects to less than
``below_px`` pixels across is drawn with that copy. The error this costs and the time it saves
are measured like every accuracy knob's, by ``genie bench accuracy``.

The copy is drawn with the instance's ids (and with back-face culling only when the mesh and
its copy are both closed), so only depth and silhouettes move, by about the geometric error of
the decimation as seen from the camera.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from ..scene.model import Mesh

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class LevelOfDetail:
    """When and how far to simplify.

    Attributes
    ----------
    below_px : float > 0, an instance whose bounding sphere is fewer pixels across than this
        (2 · f · radius / depth of its centre, f the larger focal length) uses the copy.
    keep : float in (0, 1), the fraction of a mesh's faces its copy keeps.
    min_faces : int >= 4, meshes with fewer faces get no copy.
    """

    below_px: float = 48.0
    keep: float = 0.1
    min_faces: int = 2000

    def __post_init__(self) -> None:
        if not (np.isfinite(self.below_px) and self.below_px > 0):
            raise ConfigError(
                f"LevelOfDetail below_px: expected a number of pixels > 0, got {self.below_px!r}"
            )
        if not 0.0 < float(self.keep) < 1.0:
            raise ConfigError(
                f"LevelOfDetail keep: expected a fraction of faces in (0, 1), got {self.keep!r}"
            )
        if int(self.min_faces) < 4:
            raise ConfigError(
                f"LevelOfDetail min_faces: expected at least 4, got {self.min_faces!r}"
            )


def simplified(mesh: Mesh, lod: LevelOfDetail) -> Mesh | None:
    """The copy of ``mesh`` that ``lod`` draws for small instances, or None when the mesh is
    too small to simplify or the decimation gives nothing usable."""
    if len(mesh.faces) < lod.min_faces:
        return None
    try:
        import fast_simplification
    except ImportError as exc:  # an extra: pip install "genie-gl[lod]"
        raise ConfigError(
            "level of detail needs fast-simplification: pip install fast-simplification"
        ) from exc
    v = np.asarray(mesh.vertices, np.float32)
    f = np.asarray(mesh.faces, np.int64)
    finite = np.isfinite(v).all(axis=1)
    if not finite.all():  # decimation of NaN vertices is undefined: simplify the rest
        f = f[finite[f].all(axis=1)]
    points, faces = fast_simplification.simplify(v, f, target_reduction=1.0 - float(lod.keep))
    if len(faces) < 4 or len(faces) >= len(f):
        return None
    faces = np.asarray(faces, np.int64)
    return Mesh(
        np.asarray(points, np.float32),
        faces.astype(np.uint32),
        closed=mesh.closed and _closed(faces),
    )


def _closed(faces: np.ndarray) -> bool:
    """True when every directed edge a->b of ``faces`` (F, 3) appears once and so does b->a
    (a closed, consistently wound surface: back faces may be culled)."""
    a, b = faces.reshape(-1), faces[:, [1, 2, 0]].reshape(-1)
    n = int(faces.max()) + 1
    key = np.sort(a * n + b)
    if (key[1:] == key[:-1]).any():
        return False
    return bool(np.array_equal(key, np.sort(b * n + a)))


def choose(
    lod: LevelOfDetail | None,
    has_copy: np.ndarray,
    centre_z: np.ndarray,
    radius: np.ndarray,
    K: np.ndarray,
) -> np.ndarray:
    """(Q,) bool: which of the visible instances (their meshes' ``has_copy``, camera-frame
    depth of their bounding spheres' centres ``centre_z`` in m, radii in m) draw the copy."""
    if lod is None or not has_copy.any():
        return np.zeros(len(radius), bool)
    f = max(float(K[0, 0]), float(K[1, 1]))
    # a sphere reaching the camera plane is never small
    across = np.where(centre_z > radius, 2.0 * f * radius / np.maximum(centre_z, 1e-12), np.inf)
    return has_copy & (across < float(lod.below_px))
