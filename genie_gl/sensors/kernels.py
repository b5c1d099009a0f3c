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
from numba import njit


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
def casts_shadow(depth, fb, tol_m, tol_rel):  # pragma: no cover - compiled
    """True when two valid 4-neighbours differ by more than half the shadow tolerance and the
    shadow of the nearer on the farther, fb·(1/z_near − 1/z_far) pixels, reaches half a pixel."""
    H, W = depth.shape
    for v in range(H):
        for u in range(W):
            z = np.float64(depth[v, u])
            if z <= 0:
                continue
            for dv, du in ((0, 1), (1, 0)):
                if v + dv >= H or u + du >= W:
                    continue
                n = np.float64(depth[v + dv, u + du])
                if n <= 0:
                    continue
                near, far = min(z, n), max(z, n)
                if far - near > 0.5 * (tol_m + tol_rel * near) and fb * (1.0 / near - 1.0 / far) >= 0.5:
                    return True
    return False


@njit(cache=True, nogil=True)
def shadow_mask(depth, xy, R, t, K, w2, h2, near2, depth2, rendered, tol_m, tol_rel):  # pragma: no cover
    """Which returns the second view cannot see: (gone (H, W) bool, occluded, outside).

    Every valid pixel's point (depth · (x, y, 1)) goes to the second view (X2 = R·X + t), is
    projected with K (rounded half to even, as ``np.rint``) and, when ``rendered``, compared
    with ``depth2`` there: hidden when it lies behind by more than tol_m + tol_rel·seen."""
    H, W = depth.shape
    gone = np.zeros((H, W), np.bool_)
    occluded = 0
    outside = 0
    for v in range(H):
        for u in range(W):
            z = np.float64(depth[v, u])
            if z <= 0:
                continue
            X, Y = xy[v, u, 0] * z, xy[v, u, 1] * z
            x2 = R[0, 0] * X + R[0, 1] * Y + R[0, 2] * z + t[0]
            y2 = R[1, 0] * X + R[1, 1] * Y + R[1, 2] * z + t[1]
            z2 = R[2, 0] * X + R[2, 1] * Y + R[2, 2] * z + t[2]
            if not z2 > near2:
                gone[v, u] = True
                outside += 1
                continue
            pu = np.rint((K[0, 0] * x2 + K[0, 1] * y2) / z2 + K[0, 2])
            pv = np.rint(K[1, 1] * y2 / z2 + K[1, 2])
            if not (pu >= 0 and pu < w2 and pv >= 0 and pv < h2):
                gone[v, u] = True
                outside += 1
                continue
            if rendered:
                seen = np.float64(depth2[int(pv), int(pu)])
                if seen > 0 and z2 > seen + (tol_m + tol_rel * seen):
                    gone[v, u] = True
                    occluded += 1
    return gone, occluded, outside


@njit(cache=True, nogil=True)
def shadow_drop(depth, instance, semantic, xy, R, t, K, w2, h2, near2, depth2, rendered, tol_m,
                tol_rel):  # pragma: no cover - compiled
    """:func:`shadow_mask` and :func:`~genie_gl.sensors.effect.drop` in one pass: ``depth``,
    ``instance`` and ``semantic`` (copies the caller made) are zeroed in place where the
    second view cannot see; (gone, occluded, outside) as :func:`shadow_mask` returns them."""
    gone, occluded, outside = shadow_mask(depth, xy, R, t, K, w2, h2, near2, depth2, rendered, tol_m, tol_rel)
    if occluded + outside:
        H, W = depth.shape
        for v in range(H):
            for u in range(W):
                if gone[v, u]:
                    depth[v, u] = 0
                    instance[v, u] = 0
                    semantic[v, u] = 0
    return gone, occluded, outside


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
def specular_lost(depth, ids, code_by_id, X, Y, normal, cos_glare, drop_clear=False):  # pragma: no cover
    """Returns lost on shiny surfaces: bare metal (code bit 1) always, other shiny pixels (bit
    0) where cos θ > ``cos_glare``, θ from ``normal`` ((H, W, 3); an empty array: the depth
    image's central differences, none beside a hole or the border); with ``drop_clear``,
    clear ones (bit 2) too. A pixel's code is its instance's (``code_by_id[id]`` as
    :func:`pixel_codes` looks it up, in the same pass). (lost (H, W) bool, count, clear pixels).

    ``X``, ``Y``: the rays' x and y (:func:`~genie_gl.sensors.geometry.pixel_rays_xy`), (H, W)
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
            x, y, z = _xat(X, v, u), _yat(Y, v, u), np.float64(depth[v, u])
            if have_normal:
                nx, ny, nz = np.float64(normal[v, u, 0]), np.float64(normal[v, u, 1]), np.float64(normal[v, u, 2])
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


def scanline_shadow(depth: np.ndarray, shift: float, tol_m: float, tol_rel: float):
    """Which returns the second view of a rectified pair cannot see, from the depth image
    alone: (gone (H, W) bool, occluded, outside).

    The second view has the same pinhole K and sits at X2 = X1 + (tx, 0, 0): a return at
    column u and depth z appears in the same row at x2 = u + shift/z, shift = fx·tx. Each row
    is drawn into a one-dimensional depth buffer of the second view (W columns, centres at
    integers): two neighbours whose depths differ by at most the tolerance are one surface
    (the segment between them, 1/z linear in x2: exact for a plane); a return without such a
    neighbour on one side covers half a pixel on that side at its own depth.

    Only returns on the second view's side can hide a return (of two points whose order the
    views swap, the one on that side is the nearer), so the row is walked from that side: each
    return is looked up before it and the segment to its predecessor are drawn, which also
    keeps it from hiding behind its own surface. It is outside when rint(x2) leaves [0, W),
    hidden when the buffer there holds a surface nearer than z − (tol_m + tol_rel·seen).

    Computed for the second view on the +x side (shift < 0, :func:`_scanline_right`); one on
    the −x side is its mirror image (the image flipped left to right, the shift negated)."""
    depth = np.ascontiguousarray(depth, dtype=np.float32)
    if shift <= 0:
        return _scanline_right(depth, float(shift), float(tol_m), float(tol_rel))
    gone, occluded, outside = _scanline_right(np.ascontiguousarray(depth[:, ::-1]), -float(shift), float(tol_m),
                                              float(tol_rel))
    return np.ascontiguousarray(gone[:, ::-1]), occluded, outside


@njit(cache=True, nogil=True)
def _scanline_right(depth, shift, tol_m, tol_rel):  # pragma: no cover - compiled
    """:func:`scanline_shadow` for shift <= 0: rows walked right to left.

    A column is drawn when its centre lies in [lo, hi) (as a rasteriser fills). A draw that
    no later look-up can read is skipped, which changes nothing: ``fut[u]``, the rightmost
    column a return left of u looks up, lies left of it (the usual case: a surface both views
    see, walked right to left, maps to columns further and further left); and a look-up left
    of every column drawn so far finds nothing. Only near a fold of x2 (an edge whose shadow
    reaches a pixel) is anything drawn."""
    H, W = depth.shape
    gone = np.zeros((H, W), np.bool_)
    ib = np.empty(W, np.float64)
    izr = np.empty(W, np.float64)
    xr = np.empty(W, np.float64)
    col = np.empty(W, np.int64)
    fut = np.empty(W, np.int64)
    occluded = 0
    outside = 0
    for v in range(H):
        for u in range(W):                 # one vectorised pass: 1/z, x2, the column looked up
            z = np.float64(depth[v, u])
            i = 1.0 / z if z > 0 else 0.0
            x = u + shift * i
            izr[u] = i
            xr[u] = x
            c = np.rint(x)
            col[u] = int(c) if (z > 0 and c >= 0 and c < W) else -1
            ib[u] = 0.0
        last = -1                          # fut[u] = max(col[:u])
        for u in range(W):
            fut[u] = last
            last = max(last, col[u])
        drawn = W                          # the leftmost column drawn in this row
        has_prev = False
        prev_i = 0.0
        prev_x = 0.0
        prev_z = 0.0
        for u in range(W - 1, -1, -1):
            iz = izr[u]
            if iz == 0.0:
                if has_prev and fut[u] >= prev_x - 0.5:   # the predecessor's half pixel towards the hole
                    drawn = _draw(ib, prev_x - 0.5, prev_x, prev_x, prev_i, 0.0, drawn)
                has_prev = False
                continue
            x = xr[u]
            c = col[u]
            reach = max(fut[u], c)
            if c < 0:
                gone[v, u] = True
                outside += 1
            # the usual case needs nothing: its own draws (from min(x, prev_x) on) lie right of
            # every later look-up, the predecessor's half pixel right of this one's too, and
            # its look-up left of every column drawn
            if not has_prev or fut[u] >= min(x, prev_x) or reach >= prev_x - 0.5 or c >= drawn:
                z = np.float64(depth[v, u])
                linked = has_prev and abs(prev_z - z) <= tol_m + tol_rel * min(prev_z, z)
                if has_prev and not linked and reach >= prev_x - 0.5:   # the predecessor's half pixel
                    drawn = _draw(ib, prev_x - 0.5, prev_x, prev_x, prev_i, 0.0, drawn)
                if c >= drawn and ib[c] > iz:
                    seen = 1.0 / ib[c]
                    if z > seen + (tol_m + tol_rel * seen):
                        gone[v, u] = True
                        occluded += 1
                if linked:                 # the surface between the two, after the look-up
                    if fut[u] >= min(x, prev_x):
                        drawn = _draw(ib, min(x, prev_x), max(x, prev_x), x, iz, (prev_i - iz) / (prev_x - x), drawn)
                elif fut[u] >= x:          # its own half pixel towards the predecessor
                    drawn = _draw(ib, x, x + 0.5, x, iz, 0.0, drawn)
                prev_z = z
            else:
                prev_z = np.float64(depth[v, u])
            has_prev = True
            prev_i, prev_x = iz, x
    return gone, occluded, outside


@njit(cache=True, nogil=True)
def _draw(ib, lo, hi, xa, ia, slope, drawn):  # pragma: no cover - compiled
    """Draw the columns whose centres lie in [lo, hi) of the line 1/z = ia + slope·(x − xa)
    into the row's inverse-depth buffer ``ib`` (the largest 1/z, the nearest, wins); the new
    leftmost drawn column."""
    W = ib.shape[0]
    c0, c1 = max(int(np.ceil(lo)), 0), min(int(np.ceil(hi)) - 1, W - 1)
    for c in range(c0, c1 + 1):
        i = ia + slope * (c - xa)
        if i > ib[c]:
            ib[c] = i
    return min(drawn, c0) if c0 <= c1 else drawn


@njit(cache=True, nogil=True)
def drop_where(depth, instance, semantic, gone):  # pragma: no cover - compiled
    """Copies of ``depth`` (as float32), ``instance`` and ``semantic`` with 0 where ``gone``
    (the bytes of :func:`~genie_gl.sensors.effect.drop`), in one pass."""
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
