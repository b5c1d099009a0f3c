"""How many cores a process's rendering uses: llvmpipe's rasteriser threads and numba's."""

from __future__ import annotations

import os

import numba


def limit_threads(threads: int) -> None:
    """Let this process use ``threads`` cores: llvmpipe's rasteriser threads (read when the
    driver loads, so call this before the first GL context of the process; an
    ``LP_NUM_THREADS`` already set wins) and numba's (the culling kernels)."""
    threads = max(1, int(threads))
    os.environ.setdefault("LP_NUM_THREADS", str(threads))
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
