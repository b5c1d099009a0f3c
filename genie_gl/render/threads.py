"""How many cores a process's rendering uses: llvmpipe's rasteriser threads and numba's."""
from __future__ import annotations

import os

import numba


def limit_threads(threads: int) -> None:
    """Let this process use ``threads`` cores: llvmpipe's rasteriser threads (read when the
    driver loads, so call this before the first GL context of the process; an
    ``LP_NUM_THREADS`` already set wins) and numba's (the culling kernels).

    One core: llvmpipe rasterises in the thread that draws (``LP_NUM_THREADS=0``), as each
    of two workers on two cores does: the other worker keeps the second core busy, and no
    hand-over between threads is paid (two workers, 12 dataset scenes each way, three runs
    taking turns: 1-5 % less CPU a scene than one rasteriser thread; docs/pipeline.md)."""
    threads = max(1, int(threads))
    os.environ.setdefault("LP_NUM_THREADS", str(threads) if threads > 1 else "0")
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
