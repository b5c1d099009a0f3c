"""What a genie-gl process does once: a worker dies with its parent; any process says when it
compiles its kernels (the first run's one-time cost).

Workers never outlive the run that started them. A run's leader holds the output folder's
lock; its workers write into that folder. When the leader is stopped (SIGTERM, SIGINT: the CLI
turns both into ``KeyboardInterrupt``, so the pools' ``with`` blocks terminate and join their
workers before the lock is released) or killed outright (SIGKILL: nothing of the leader runs),
the workers must stop too: :func:`die_with_parent`, called first in every worker, asks the
kernel to send the worker SIGKILL the moment its parent dies (Linux ``PR_SET_PDEATHSIG``;
elsewhere nothing).
"""
from __future__ import annotations

import ctypes
import os
import signal
import sys

from numba.core import event

PR_SET_PDEATHSIG = 1


def die_with_parent(parent: int | None = None) -> bool:
    """Have the kernel kill this process when its parent dies; True when it could. ``parent``:
    the pid that started this worker; when it is already gone, the worker exits now."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) != 0:
            return False
    except (OSError, AttributeError):
        return False
    if os.getppid() == 1 or (parent is not None and os.getppid() != parent):   # it died before the request
        os._exit(1)
    return True


_SAID: list[str] = []


def say_when_compiling(who: str) -> None:
    """Print one line to stderr, the first time this process compiles a numba kernel (a cache
    miss: kernels are compiled once, on the first run, and loaded from the cache after)."""
    if _SAID:
        return
    _SAID.append(who)

    class Note(event.Listener):
        said = False

        def on_start(self, ev: object) -> None:
            if not self.said:
                self.said = True
                print(f"{who}: compiling genie-gl's kernels (numba), a one-time cost of a minute or two on the first "
                      "run; later runs load them from the cache", file=sys.stderr, flush=True)

        def on_end(self, ev: object) -> None:
            pass

    event.register("numba:compile", Note())
