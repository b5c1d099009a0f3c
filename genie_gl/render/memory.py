"""Frame memory: a frame's output arrays as views into recycled blocks (see :class:`_Pool`)."""

from __future__ import annotations

import ctypes
import functools
import math
import threading

import numpy as np


class _Pool:
    """Recycled memory for frame buffers.

    A fresh array is page-faulted in on its first write, 4 KiB at a time: for a 640 x 480
    frame that costs several times the read-back itself. A frame's buffers are views into one
    block lent from this pool; when the last view dies (the frame is dropped), the block comes
    back and the next frame of that size writes into memory that is already mapped. Frames
    are made and dropped on any thread (a reentrant lock: a block may come back while the
    same thread is lending one).
    """

    def __init__(self, max_bytes: int = 512 << 20) -> None:
        self.free: dict[int, list[np.ndarray]] = {}
        self.max_bytes, self.bytes = max_bytes, 0
        self.types: dict[int, type] = {}
        self.lock = threading.RLock()

    def lend(self, size: int) -> np.ndarray:
        """A writable uint8 array of ``size`` bytes, returned to the pool when it dies."""
        with self.lock:
            blocks = self.free.get(size)
            raw = blocks.pop() if blocks else None
            if raw is not None:
                self.bytes -= size
        if raw is None:
            raw = np.empty(size, np.uint8)
        lease_type = self.types.get(size)
        if lease_type is None:
            pool = self

            class Lease(ctypes.c_ubyte * size):  # type: ignore[misc, valid-type]
                def __del__(self) -> None:  # the last view of the block is gone
                    pool.give_back(self._raw)

            lease_type = self.types[size] = Lease
        lease = lease_type.from_address(raw.ctypes.data)
        lease._raw = raw  # keeps the memory alive as long as any view of the lease
        return np.frombuffer(lease, np.uint8)

    def give_back(self, raw: np.ndarray) -> None:
        with self.lock:
            if self.bytes + raw.nbytes <= self.max_bytes:
                self.free.setdefault(raw.nbytes, []).append(raw)
                self.bytes += raw.nbytes


_POOL = _Pool()


@functools.lru_cache(maxsize=64)
def _parts(
    H: int, W: int, color: bool, normals: bool, triangles: bool = False
) -> tuple[tuple, tuple[int, ...]]:
    """A frame's arrays (name, dtype, shape, bytes) and their sizes in its block, 64-byte
    aligned."""
    parts = [("depth", np.float32, (H, W)), ("instance", np.uint32, (H, W))]
    if triangles:
        parts.append(("primitive", np.uint32, (H, W, 2)))
    if normals:
        parts.append(("normal", np.float32, (H, W, 3)))
    if color:
        parts.append(("rgba", np.uint8, (H, W, 4)))
    parts.append(("semantic", np.uint16, (H, W)))
    parts = [
        (name, dt, shape, math.prod(shape) * np.dtype(dt).itemsize) for name, dt, shape in parts
    ]
    return tuple(parts), tuple(-(-n // 64) * 64 for *_, n in parts)


def frame_buffers(
    H: int, W: int, color: bool, normals: bool, triangles: bool = False
) -> dict[str, np.ndarray]:
    """A frame's output arrays as views into one block of recycled memory (see :class:`_Pool`)."""
    parts, sizes = _parts(H, W, color, normals, triangles)
    block = _POOL.lend(sum(sizes))
    out, at = {}, 0
    for (name, dt, shape, n), b in zip(parts, sizes):
        out[name] = block[at : at + n].view(dt).reshape(shape)
        at += b
    return out


def prefault(H: int, W: int, color: bool, normals: bool, frames: int) -> int:
    """Put ``frames`` frames' blocks, written once (mapped), in the pool (never more than it
    keeps): a process's first scene then renders into mapped memory as every later one does
    (a worker's warm-up). Returns the number of blocks."""
    frames = min(frames, _POOL.max_bytes // max(1, sum(_parts(H, W, color, normals)[1])))
    held = [frame_buffers(H, W, color, normals) for _ in range(frames)]
    for bufs in held:
        for a in bufs.values():
            a.fill(0)
    del held  # the blocks go back to the pool
    return frames
