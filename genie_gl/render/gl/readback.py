"""Read-back of a frame's ids and depth: one packed target, unpacked by one compiled kernel.

The geometry pass writes depth and instance id into one RG32UI target (the float32 view z as
its bits, the instance id beside it): a frame is one read of 8 bytes a pixel instead of three
reads (depth R32F, instance R32UI, semantic R16UI), and llvmpipe writes one target per
fragment instead of three (measured: ~15 % less rasteriser CPU a frame at 640 x 480). The
semantic id is not rendered: it is the instance's, looked up in a per-instance table once
the packed pixels are split into the frame's arrays and the sensor's range is applied
(nothing nearer than ``near_m``, nothing beyond ``far_m``).

The frames are the same bit for bit as the three-target layout (``Renderer(...,
targets="separate")``, kept for the comparison: tests/render/test_readback.py).
"""

from __future__ import annotations

import numpy as np

from ...jit import njit


@njit(cache=True, nogil=True, boundscheck=False)
def _unpack(
    bits, lut, depth, instance, semantic, with_depth, half, far
):  # pragma: no cover - compiled
    """Split packed (depth bits, instance) pixels into ``depth`` (when ``with_depth``),
    ``instance`` and ``semantic`` (``lut[instance]``). With ``with_depth``, a pixel with depth
    beyond ``far`` or within ``|z - half| < half`` (0 < z < near, in float32 as numpy computes
    it) gets no return (0, 0, 0). Returns how many pixels were emptied so.

    Two passes on one thread: depth and ids branch-free (a loop the compiler vectorises), then
    the semantic ids looked up from the ids just written, an emptied pixel's id 0 giving
    ``lut[0]``, 0 (no instance has id 0). Written as one pass, the table look-up kept the whole
    loop scalar: about twice the CPU, even spread over two threads."""
    z_of = bits.view(np.float32)
    n = instance.shape[0]
    emptied = 0
    if lut[0] != 0:  # a table with an id 0 (not a scene's): one pass, an emptied pixel's class 0
        for p in range(n):
            i = bits[2 * p + 1]
            bad = False
            if with_depth:
                z = z_of[2 * p]
                bad = (z > far) | (abs(z - half) < half)
                emptied += bad
                depth[p] = np.float32(0) if bad else z
            instance[p] = np.uint32(0) if bad else i
            semantic[p] = np.uint16(0) if bad else lut[i]
        return emptied
    if with_depth:
        for p in range(n):
            i = bits[2 * p + 1]
            z = z_of[2 * p]
            bad = (z > far) | (abs(z - half) < half)
            emptied += bad
            depth[p] = np.float32(0) if bad else z
            instance[p] = np.uint32(0) if bad else i
    else:
        for p in range(n):
            instance[p] = bits[2 * p + 1]
    for p in range(n):
        semantic[p] = lut[instance[p]]
    return emptied


@njit(cache=True, nogil=True, boundscheck=False)
def _unpack_sorted(
    bits, ids, sems, depth, instance, semantic, with_depth, half, far
):  # pragma: no cover
    """:func:`_unpack` for ids too large for a table: each new id looked up in sorted ``ids``."""
    z_of = bits.view(np.float32)
    last, last_sem = np.uint32(0), np.uint16(0)
    emptied = 0
    for p in range(instance.shape[0]):
        i = bits[2 * p + 1]
        if i != last:
            last = i
            k = np.searchsorted(ids, i)
            last_sem = sems[k] if k < ids.shape[0] and ids[k] == i else np.uint16(0)
        if with_depth:
            z = z_of[2 * p]
            if z > far or abs(z - half) < half:
                depth[p] = 0
                instance[p] = 0
                semantic[p] = 0
                emptied += 1
                continue
            depth[p] = z
        instance[p] = i
        semantic[p] = last_sem
    return emptied


LUT_MAX_ID = 1 << 20  # ids up to this: a direct table (2 MB at most); larger ones: a sorted search


def semantic_table(ids: np.ndarray, semantic: np.ndarray) -> tuple[np.ndarray, ...] | None:
    """The semantic id of each instance id for :func:`unpack`: (table,) indexed by id when the
    ids are small, else (sorted ids uint32, their semantic ids uint16); None when an id occurs
    twice (then ids alone cannot tell the class: the renderer keeps three targets)."""
    order = np.argsort(ids, kind="stable")
    ids_sorted = np.ascontiguousarray(ids[order], np.uint32)
    if len(ids_sorted) > 1 and (np.diff(ids_sorted.astype(np.int64)) == 0).any():
        return None
    sems = np.ascontiguousarray(np.asarray(semantic)[order], np.uint16)
    if len(ids_sorted) == 0 or int(ids_sorted[-1]) < LUT_MAX_ID:
        lut = np.zeros(int(ids_sorted[-1]) + 1 if len(ids_sorted) else 1, np.uint16)
        lut[ids_sorted] = sems
        return (lut,)
    return ids_sorted, sems


def unpack(
    packed: np.ndarray,
    table: tuple[np.ndarray, np.ndarray],
    depth: np.ndarray | None,
    instance: np.ndarray,
    semantic: np.ndarray,
    near_m: float = 0.0,
    far_m: float = np.inf,
) -> int:
    """Fill ``instance``, ``semantic`` and (unless None) ``depth`` from ``packed`` (H, W, 2)
    uint32 as read back; with ``depth``, pixels outside the range (near_m, far_m] are emptied.
    Returns the number of pixels emptied."""
    with_depth = depth is not None
    d = depth.reshape(-1) if with_depth else np.zeros(1, np.float32)
    args = (
        d,
        instance.reshape(-1),
        semantic.reshape(-1),
        with_depth,
        np.float32(0.5 * near_m),
        np.float32(far_m),
    )
    if len(table) == 1:
        return int(_unpack(packed.reshape(-1), table[0], *args))
    return int(_unpack_sorted(packed.reshape(-1), *table, *args))
