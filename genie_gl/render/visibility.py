"""Which instances a frame draws, in one compiled pass over them (no numpy call per step:
at a few hundred instances the calls' overhead, not the arithmetic, was the cost), and the
renderer's methods that ask it (:class:`Visibility`, for both rasters)."""

from __future__ import annotations

from collections.abc import Collection
from typing import NamedTuple

import numpy as np

from ..errors import ConfigError
from ..jit import njit
from .lod import choose
from .projection import frustum_planes, rigid_inverse


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def compose(camera_from_world, world_from_model, out):
    """out[n] = camera_from_world[:3] @ world_from_model[n], (N, 3, 4) float64, summed in
    the order of ``numpy.einsum("ij,njk->nik")`` (the same bits)."""
    for n in range(world_from_model.shape[0]):
        for i in range(3):
            for k in range(4):
                acc = 0.0
                for j in range(4):
                    acc += camera_from_world[i, j] * world_from_model[n, j, k]
                out[n, i, k] = acc


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def in_view(cfm, mesh, centre, radius, scale, planes, centre_z, radii):
    """(N,) bool: per instance, whether its mesh's bounding sphere (``centre[mesh]``,
    ``radius[mesh] * scale``) reaches inside every plane of the frustum (``planes``: (P, 4),
    inside where n·x + d >= 0); writes the sphere's camera-frame depth and radius."""
    n = cfm.shape[0]
    out = np.empty(n, np.bool_)
    for q in range(n):
        c = centre[mesh[q]]
        x = cfm[q, 0, 0] * c[0] + cfm[q, 0, 1] * c[1] + cfm[q, 0, 2] * c[2] + cfm[q, 0, 3]
        y = cfm[q, 1, 0] * c[0] + cfm[q, 1, 1] * c[1] + cfm[q, 1, 2] * c[2] + cfm[q, 1, 3]
        z = cfm[q, 2, 0] * c[0] + cfm[q, 2, 1] * c[1] + cfm[q, 2, 2] * c[2] + cfm[q, 2, 3]
        r = radius[mesh[q]] * scale[q]
        centre_z[q], radii[q] = z, r
        ok = True
        for p in range(planes.shape[0]):
            if planes[p, 0] * x + planes[p, 1] * y + planes[p, 2] * z + planes[p, 3] < -r:
                ok = False
                break
        out[q] = ok
    return out


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def eyes(model_from_world, slots, eye_world, lo, hi, mesh, closed):
    """The eye in each visible slot's model frame (Q, 3), and whether the slot is drawn with
    back-face culling: a closed mesh seen from outside its (slightly grown) box."""
    q_n = len(slots)
    eye = np.empty((q_n, 3))
    backcull = np.empty(q_n, np.bool_)
    for q in range(q_n):
        s = slots[q]
        m = mesh[q]
        inside = True
        for i in range(3):
            e = (
                model_from_world[s, i, 0] * eye_world[0]
                + model_from_world[s, i, 1] * eye_world[1]
                + model_from_world[s, i, 2] * eye_world[2]
                + model_from_world[s, i, 3] * eye_world[3]
            )
            eye[q, i] = e
            pad = 1e-6 * (1.0 + abs(hi[m, i] - lo[m, i]))
            inside &= (e >= lo[m, i] - pad) & (e <= hi[m, i] + pad)
        backcull[q] = closed[m] and not inside
    return eye, backcull


class Seen(NamedTuple):
    """The instances a frame draws (:meth:`Visibility._visible`), Q of the scene's N slots.

    Attributes
    ----------
    camera_from_model : (N, 3, 4) float64, per slot (drawn or not), composed in float64.
    slots : (Q,) int64, the visible slots, in slot order.
    mesh : (Q,) int64, the mesh each draws (its simplified copy with level of detail).
    backcull : (Q,) bool, drawn with back-face culling (a closed mesh seen from outside).
    eye : (Q, 3) float64, the camera centre in each one's model frame.
    planes : (P, 4) float64, the frustum's planes the instances were tested against.
    simplified : int, how many draw a simplified copy.
    """

    camera_from_model: np.ndarray
    slots: np.ndarray
    mesh: np.ndarray
    backcull: np.ndarray
    eye: np.ndarray
    planes: np.ndarray
    simplified: int


class Visibility:
    """The renderer's per-frame choice of instances (a base of
    :class:`~genie_gl.render.renderer.Renderer`, used by the GL and the exact raster alike):
    it reads the scene's upload and returns a :class:`Seen`, setting nothing."""

    def _visible(
        self,
        pose: np.ndarray,
        K: np.ndarray,
        W: int,
        H: int,
        near: float,
        only: Collection[int] | None,
    ) -> Seen | None:
        """The instances a frame draws, nothing in Python per instance (a :class:`Seen`), or
        None when none is visible."""
        if len(self._mesh) == 0:
            return None
        camera_from_world = rigid_inverse(pose)
        # float64 composition relative to the camera, then float32 (far scenes stay exact)
        n = len(self._mesh)
        cfm = np.empty((n, 3, 4))
        compose(camera_from_world, self._world_from_model, cfm)
        mesh = self._mesh
        planes = frustum_planes(K, W, H, near)
        centre_z, radii = np.empty(n), np.empty(n)
        visible = in_view(
            cfm, mesh, self._centre, self._radius, self._scale, planes, centre_z, radii
        )
        if only is not None:
            visible &= self._among(only)
        slots = np.flatnonzero(visible)
        if len(slots) == 0:
            return None
        m = mesh[slots]
        simplified = 0
        if self.lod is not None:
            small = choose(self.lod, self._copy_of[m] >= 0, centre_z[slots], radii[slots], K)
            m = np.where(small, self._copy_of[m], m)
            simplified = int(small.sum())
        # camera inside the (slightly grown) box of a closed mesh: draw both faces to see the inside
        eye, backcull = eyes(
            self._model_from_world,
            slots,
            np.ascontiguousarray(pose[:, 3], np.float64),
            self._lo,
            self._hi,
            m,
            self._closed,
        )
        return Seen(cfm, slots, m, backcull, eye, planes, simplified)

    def _among(self, only: Collection[int]) -> np.ndarray:
        """(N,) bool: which slots hold an instance whose id is in ``only``."""
        try:
            want = np.asarray(only if isinstance(only, np.ndarray) else list(only))
        except (TypeError, ValueError):
            want = np.zeros((0, 0))
        if want.ndim != 1 or (want.size and want.dtype.kind not in "iu"):
            raise ConfigError(
                "Renderer: only: expected a collection of instance ids (integers), got "
                f"{only!r:.60}"
            )
        want = want.astype(np.int64)
        if self._id_order is None:  # an id used twice
            return np.isin(self._ids, want)
        ids = self._ids[self._id_order]
        at = np.minimum(np.searchsorted(ids, want), max(len(ids) - 1, 0))
        mask = np.zeros(len(ids), bool)
        if len(ids):
            mask[self._id_order[at[ids[at] == want]]] = True
        return mask
