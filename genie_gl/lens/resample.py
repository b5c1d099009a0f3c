"""The compiled inner loop of lens resampling from view pixels (numba, cached on disk).

One pass over the lens pixels a pinhole view serves: gather the nearest view pixel's ids,
colour and normal, compute the depth along the pixel's own ray (nearest, perspective-correct
bilinear within one instance, or from the plane of the nearest pixel's triangle), apply the
sensor's range, and write the output buffers. :mod:`.distortion` prepares the per-pixel plan
once per camera model; this kernel runs per frame. (The exact mode, each pixel's own ray
intersected with the view's triangles, is :mod:`.ray_hits`.)
"""

from __future__ import annotations

import numpy as np

from ..jit import njit

NEAREST, BILINEAR, PLANE = 0, 1, 2
MODES = {"nearest": NEAREST, "bilinear": BILINEAR, "plane": PLANE}


@njit(cache=True, nogil=True, boundscheck=False)
def resample_view(
    mode,
    sel,
    flat,
    f00,
    ax,
    ay,
    px,
    py,
    dx,
    dy,
    zs,
    width,
    near,
    far,
    R,
    depth,
    inst,
    sem,
    rgb,
    normal,
    out_depth,
    out_inst,
    out_sem,
    out_rgb,
    out_normal,
):  # pragma: no cover
    """Write the samples of one view into the lens image.

    mode : NEAREST, BILINEAR or PLANE. sel (N,) int64: output pixel of each sample; flat (N,)
    int64: its nearest view pixel; f00 (N,) int64 and ax, ay (N,) float64: the top-left view
    pixel of its 2x2 neighbourhood and the weights; px, py (N,): the nearest view pixel's ray
    (view frame, z = 1); dx, dy (N,): the sample's own ray (view frame, z = 1); zs (N,) or (0,):
    camera-frame z per view-frame z along the ray; width: view width; near, far: the range;
    R (3, 3): camera_from_view. depth (M,) float32, inst (M,) uint32, sem (M,) uint16,
    rgb (M, 3) uint8 or (0, 3), normal (M, 3) float32 or (0, 3): the view's buffers; out_*:
    the lens image's (zero-filled), written where a sample has a return.
    """
    colour = rgb.shape[0] > 0 and out_rgb.shape[0] > 0
    normals = normal.shape[0] > 0
    scale = zs.shape[0] > 0
    for i in range(sel.shape[0]):
        j = flat[i]
        zn = np.float64(depth[j])
        if zn <= 0:
            continue
        ident = inst[j]
        z = zn
        if mode == BILINEAR:
            c0 = f00[i]
            c1, c2 = c0 + 1, c0 + width
            c3 = c2 + 1
            z0, z1, z2, z3 = depth[c0], depth[c1], depth[c2], depth[c3]
            if (
                z0 > 0
                and z1 > 0
                and z2 > 0
                and z3 > 0
                and inst[c0] == ident
                and inst[c1] == ident
                and inst[c2] == ident
                and inst[c3] == ident
            ):
                a, b = ax[i], ay[i]
                # 1/z is affine in a pinhole image across a plane: interpolate it, not z
                w = (1 - a) * (1 - b) / z0 + a * (1 - b) / z1 + (1 - a) * b / z2 + a * b / z3
                z = 1.0 / w
        elif mode == PLANE and normals:
            n0, n1, n2 = (
                np.float64(normal[j, 0]),
                np.float64(normal[j, 1]),
                np.float64(normal[j, 2]),
            )
            nd = n0 * dx[i] + n1 * dy[i] + n2
            if abs(nd) > 1e-6:
                t = zn * (n0 * px[i] + n1 * py[i] + n2) / nd
                if 0.5 * zn < t < 2.0 * zn:
                    z = t
        if scale:
            z *= zs[i]
        if z < near or z > far:
            continue
        o = sel[i]
        out_depth[o] = z
        out_inst[o] = ident
        out_sem[o] = sem[j]
        if colour:
            out_rgb[o, 0] = rgb[j, 0]
            out_rgb[o, 1] = rgb[j, 1]
            out_rgb[o, 2] = rgb[j, 2]
        if normals and out_normal.shape[0] > 0:
            m0, m1, m2 = normal[j, 0], normal[j, 1], normal[j, 2]
            out_normal[o, 0] = R[0, 0] * m0 + R[0, 1] * m1 + R[0, 2] * m2
            out_normal[o, 1] = R[1, 0] * m0 + R[1, 1] * m1 + R[1, 2] * m2
            out_normal[o, 2] = R[2, 0] * m0 + R[2, 1] * m1 + R[2, 2] * m2
