"""Compiled per-pixel loops of the sensor effects (numba, cached on disk).

Each kernel does in one pass what the numpy version did in a dozen full-frame temporaries;
the effects keep the model (and its docstring), these keep the arithmetic. Random draws come
from the caller's ``numpy.random.Generator``: either drawn by numpy beforehand (``draws``), or
drawn inside the loop from the Generator itself (the ``*_rng`` kernels: numba's
``Generator.standard_normal`` runs numpy's ziggurat on the same bit generator, so the values
and the generator's state afterwards are the same as ``rng.standard_normal(n)`` gives, about
three times faster, with no (n,) array in between; tests check it value for value).
"""

from __future__ import annotations

import math

import numpy as np

# the stereo shadow's loops live beside it (one topic, one module); named here as well
from ..jit import njit
from .shadow_kernels import casts_shadow, scanline_shadow, shadow_mask  # noqa: F401


@njit(cache=True, nogil=True)
def has_step(depth, jump):  # pragma: no cover - compiled
    """True when two valid 4-neighbours differ in depth by more than ``jump``."""
    H, W = depth.shape
    for v in range(H):
        for u in range(W):
            z = depth[v, u]
            if z <= 0:
                continue
            if u + 1 < W:
                n = depth[v, u + 1]
                if n > 0 and abs(n - z) > jump:
                    return True
            if v + 1 < H:
                n = depth[v + 1, u]
                if n > 0 and abs(n - z) > jump:
                    return True
    return False


@njit(cache=True, nogil=True)
def stereo_noise(depth, draws, fb, sigma_d, step):  # pragma: no cover - compiled
    """z + N·z²σ_d/(f·b) per valid pixel (``draws`` in row-major order of the valid pixels),
    then disparity quantised to ``step`` px (0: none); (new depth float32, pixels lost)."""
    H, W = depth.shape
    out = np.zeros((H, W), np.float32)
    k = 0
    lost = 0
    for v in range(H):
        for u in range(W):
            z = np.float64(depth[v, u])
            if z <= 0:
                continue
            noisy = z + draws[k] * (z * z * sigma_d / fb)
            k += 1
            if step > 0:
                disp = fb / max(noisy, 1e-6)
                disp = np.round(disp / step) * step
                noisy = fb / max(disp, 1e-12) if disp > 0 else 0.0
            if noisy > 0:
                out[v, u] = np.float32(noisy)
            if not np.float32(noisy) > 0:
                out[v, u] = 0
                lost += 1
    return out, lost


@njit(cache=True, nogil=True)
def _normals_in_row(depth, v, rng, out):  # pragma: no cover - compiled
    """``out[u]``: one ``rng.standard_normal()`` per valid pixel of row ``v``, left to right
    (row by row, the values of ``rng.standard_normal(n_valid)``); untouched where there is
    no return."""
    for u in range(depth.shape[1]):
        if depth[v, u] > 0:
            out[u] = rng.standard_normal()


@njit(cache=True, nogil=True)
def stereo_noise_rng(depth, rng, fb, sigma_d, step):  # pragma: no cover - compiled
    """:func:`stereo_noise` drawing its normals from ``rng``, one per valid pixel in row-major
    order: the same values as ``stereo_noise(depth, rng.standard_normal(n_valid), ...)``;
    (new depth, pixels lost, pixels whose depth changed). Each row's draws come first, then
    the model over the row in a branch-free pass the compiler vectorises; a power-of-two
    ``step`` divides by multiplying with its inverse (the same float64, exactly)."""
    H, W = depth.shape
    draws = np.zeros(W, np.float64)
    out = np.empty((H, W), np.float32)
    inv = 0.0
    if step > 0:
        m, _ = math.frexp(step)
        if m == 0.5:
            inv = 1.0 / step
    lost = 0
    changed = 0
    for v in range(H):
        _normals_in_row(depth, v, rng, draws)
        for u in range(W):
            z = np.float64(depth[v, u])
            noisy = z + draws[u] * (z * z * sigma_d / fb)
            if step > 0:
                disp = fb / max(noisy, 1e-6)
                disp = np.round(disp * inv if inv > 0 else disp / step) * step
                noisy = fb / max(disp, 1e-12) if disp > 0 else 0.0
            o = np.float32(noisy) if noisy > 0 else np.float32(0.0)
            o = o if z > 0 else np.float32(0.0)
            out[v, u] = o
            lost += (z > 0) & (o == 0)
            changed += o != depth[v, u]
    return out, lost, changed


@njit(cache=True, nogil=True)
def linear_noise_rng(depth, rng, a, b, z0):  # pragma: no cover - compiled
    """:func:`linear_noise` drawing its normals from ``rng`` (the same values as
    ``linear_noise(depth, rng.standard_normal(n_valid), ...)``); (new depth, pixels lost,
    pixels whose depth changed). Each row's draws first, then the model over the row."""
    H, W = depth.shape
    draws = np.zeros(W, np.float64)
    out = np.empty((H, W), np.float32)
    lost = 0
    changed = 0
    for v in range(H):
        _normals_in_row(depth, v, rng, draws)
        for u in range(W):
            z = np.float64(depth[v, u])
            noisy = np.float32(z + draws[u] * (a + b * max(z - z0, 0.0)))
            o = noisy if noisy > 0 else np.float32(0.0)
            o = o if z > 0 else np.float32(0.0)
            out[v, u] = o
            lost += (z > 0) & (o == 0)
            changed += o != depth[v, u]
    return out, lost, changed


@njit(cache=True, nogil=True)
def linear_noise(depth, draws, a, b, z0):  # pragma: no cover - compiled
    """z + N·(a + b·max(z − z0, 0)) per valid pixel (``draws`` in row-major order of the valid
    pixels); (new depth float32, pixels lost: the noise pushed them to <= 0)."""
    H, W = depth.shape
    out = np.zeros((H, W), np.float32)
    k = 0
    lost = 0
    for v in range(H):
        for u in range(W):
            z = np.float64(depth[v, u])
            if z <= 0:
                continue
            noisy = np.float32(z + draws[k] * (a + b * max(z - z0, 0.0)))
            k += 1
            if noisy > 0:
                out[v, u] = noisy
            else:
                lost += 1
    return out, lost


@njit(cache=True, nogil=True)
def dim_returns(depth, xy, albedo, threshold):  # pragma: no cover - compiled
    """Pixels whose albedo / r² falls under ``threshold``: ((H, W) bool, count)."""
    H, W = depth.shape
    lost = np.zeros((H, W), np.bool_)
    n = 0
    for v in range(H):
        for u in range(W):
            z = np.float64(depth[v, u])
            if z <= 0:
                continue
            x, y = xy[v, u, 0], xy[v, u, 1]
            if albedo[v, u] < threshold * z * z * (1.0 + x * x + y * y):
                lost[v, u] = True
                n += 1
    return lost, n


def valid_span(depth: np.ndarray) -> tuple[float, float]:
    """(smallest, largest) valid depth of a float32 depth image; (0, 0) when there is none.

    Depths are >= 0, and non-negative float32s order like their bits as uint32: the smallest
    non-zero one is the minimum of bits − 1 (0 wraps to the top) plus one. Two vectorised
    reductions, twice as fast as a compiled loop with a branch per pixel."""
    hi = float(depth.max()) if depth.size else 0.0
    if hi <= 0:
        return 0.0, 0.0
    bits = depth.view(np.uint32)
    lo = (bits - np.uint32(1)).min() + np.uint32(1)
    return float(np.uint32(lo).view(np.float32)), hi


@njit(cache=True, nogil=True)
def changed(d1, d2, i1, i2):  # pragma: no cover - compiled
    """Pixels whose depth or instance id differ between two frames."""
    H, W = d1.shape
    n = 0
    for v in range(H):
        for u in range(W):
            if d1[v, u] != d2[v, u] or i1[v, u] != i2[v, u]:
                n += 1
    return n


@njit(cache=True, nogil=True)
def any_code(depth, ids, code_by_id):  # pragma: no cover - compiled
    """True when some returning pixel has a non-zero code (:func:`pixel_codes`); stops at
    the first."""
    H, W = depth.shape
    last = code_by_id.shape[0] - 1
    for v in range(H):
        for u in range(W):
            if depth[v, u] > 0 and code_by_id[min(ids[v, u], last)]:
                return True
    return False


@njit(cache=True, nogil=True)
def pixel_codes(depth, ids, code_by_id):  # pragma: no cover - compiled
    """Each returning pixel's material code (``code_by_id[id]``, ids beyond the table read its
    last entry; 0 where no return) and how many pixels have a non-zero code."""
    H, W = depth.shape
    out = np.zeros((H, W), np.uint8)
    last = code_by_id.shape[0] - 1
    n = 0
    for v in range(H):
        for u in range(W):
            if depth[v, u] > 0:
                c = code_by_id[min(ids[v, u], last)]
                out[v, u] = c
                if c:
                    n += 1
    return out, n


@njit(cache=True, nogil=True, inline="always")
def _xat(X, v, u):  # pragma: no cover - compiled
    return X[v if X.shape[0] > 1 else 0, u]


@njit(cache=True, nogil=True, inline="always")
def _yat(Y, v, u):  # pragma: no cover - compiled
    return Y[v, u if Y.shape[1] > 1 else 0]


@njit(cache=True, nogil=True)
def specular_lost(
    depth, ids, code_by_id, X, Y, normal, cos_glare, drop_clear=False
):  # pragma: no cover
    """Returns lost on shiny surfaces: bare metal (code bit 1) always, other shiny pixels (bit
    0) where cos θ > ``cos_glare``, θ from ``normal`` ((H, W, 3); an empty array: the depth
    image's central differences, none beside a hole or the border); with ``drop_clear``,
    clear ones (bit 2) too. A pixel's code is its instance's (``code_by_id[id]`` as
    :func:`pixel_codes` looks it up, in the same pass). (lost (H, W) bool, count, clear pixels).

    ``X``, ``Y``: the rays' x and y (:func:`~genie_gl.effects.geometry.pixel_rays_xy`), (H, W)
    each, or (1, W) and (H, 1) for a pinhole sensor, whose x depends on the column only and
    y on the row only (the same values, without streaming a full (H, W, 2) array)."""
    H, W = depth.shape
    lost = np.zeros((H, W), np.bool_)
    n = 0
    n_clear = 0
    have_normal = normal.shape[0] == H
    cos2 = cos_glare * cos_glare if cos_glare > 0 else 0.0
    last = code_by_id.shape[0] - 1
    for v in range(H):
        for u in range(W):
            if not depth[v, u] > 0:
                continue
            c = code_by_id[min(ids[v, u], last)]
            if c == 0:
                continue
            if c & 4:
                n_clear += 1
                if drop_clear:
                    lost[v, u] = True
                    n += 1
                    continue
            if c & 2:
                lost[v, u] = True
                n += 1
                continue
            if not c & 1:
                continue
            x, y = _xat(X, v, u), _yat(Y, v, u)
            if have_normal:
                nx, ny, nz = (
                    np.float64(normal[v, u, 0]),
                    np.float64(normal[v, u, 1]),
                    np.float64(normal[v, u, 2]),
                )
            else:
                if u == 0 or v == 0 or u == W - 1 or v == H - 1:
                    continue
                za, zb = np.float64(depth[v, u + 1]), np.float64(depth[v, u - 1])
                zc, ze = np.float64(depth[v + 1, u]), np.float64(depth[v - 1, u])
                if za <= 0 or zb <= 0 or zc <= 0 or ze <= 0:
                    continue
                ax = _xat(X, v, u + 1) * za - _xat(X, v, u - 1) * zb
                ay = _yat(Y, v, u + 1) * za - _yat(Y, v, u - 1) * zb
                az = za - zb
                bx = _xat(X, v + 1, u) * zc - _xat(X, v - 1, u) * ze
                by = _yat(Y, v + 1, u) * zc - _yat(Y, v - 1, u) * ze
                bz = zc - ze
                nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
            # cos θ = |n·r| / (|n|·|r|), r = (x, y, 1): first squared, without a root or a
            # division, with a margin far beyond its rounding; only near the threshold exactly
            nr = nx * x + ny * y + nz
            n2 = nx * nx + ny * ny + nz * nz
            if nr * nr < cos2 * n2 * (x * x + y * y + 1.0) * (1.0 - 1e-5):
                continue
            dl = np.sqrt(x * x + y * y + 1.0)
            dx, dy, dz = x / dl, y / dl, 1.0 / dl
            if not have_normal:
                ln = np.sqrt(n2)
                if ln == 0:
                    continue
                nx, ny, nz = nx / ln, ny / ln, nz / ln
            if abs(nx * dx + ny * dy + nz * dz) > cos_glare:
                lost[v, u] = True
                n += 1
    return lost, n, n_clear


@njit(cache=True, nogil=True)
def edge_pixels(depth, jump):  # pragma: no cover - compiled
    """Pixels on a depth edge, in row-major order: those with a valid 4-neighbour more than
    ``jump`` away in depth. Returns (flat indices (N,) int64, flat index of the neighbour with
    the largest |step| (N,) int64; ties: the first of up, down, left, right)."""
    H, W = depth.shape
    idx = np.empty(H * W, np.int64)
    nb = np.empty(H * W, np.int64)
    n = 0
    for v in range(H):
        for u in range(W):
            z = np.float64(depth[v, u])
            if z <= 0:
                continue
            best, other = 0.0, -1
            for dv, du in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                vv, uu = v + dv, u + du
                if vv < 0 or vv >= H or uu < 0 or uu >= W:
                    continue
                zn = np.float64(depth[vv, uu])
                if zn <= 0:
                    continue
                d = abs(zn - z)
                if d > best:
                    best, other = d, vv * W + uu
            if best > jump:
                idx[n] = v * W + u
                nb[n] = other
                n += 1
    return idx[:n].copy(), nb[:n].copy()


@njit(cache=True, nogil=True)
def drop_where(depth, instance, semantic, gone):  # pragma: no cover - compiled
    """Copies of ``depth`` (as float32), ``instance`` and ``semantic`` with 0 where ``gone``
    (the bytes of :func:`~genie_gl.effects.base.drop`), in one pass."""
    H, W = depth.shape
    d = np.empty((H, W), np.float32)
    i = np.empty_like(instance)
    s = np.empty_like(semantic)
    for v in range(H):
        for u in range(W):
            if gone[v, u]:
                d[v, u] = 0
                i[v, u] = 0
                s[v, u] = 0
            else:
                d[v, u] = depth[v, u]
                i[v, u] = instance[v, u]
                s[v, u] = semantic[v, u]
    return d, i, s
