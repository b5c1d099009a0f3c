"""Which instances a frame draws, in one compiled pass over them (no numpy call per step:
at a few hundred instances the calls' overhead, not the arithmetic, was the cost)."""
from __future__ import annotations

import numpy as np
from numba import njit


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
            e = (model_from_world[s, i, 0] * eye_world[0] + model_from_world[s, i, 1] * eye_world[1]
                 + model_from_world[s, i, 2] * eye_world[2] + model_from_world[s, i, 3] * eye_world[3])
            eye[q, i] = e
            pad = 1e-6 * (1.0 + abs(hi[m, i] - lo[m, i]))
            inside &= (e >= lo[m, i] - pad) & (e <= hi[m, i] + pad)
        backcull[q] = closed[m] and not inside
    return eye, backcull
