"""Worker processes that never outlive the run that started them.

A run's leader holds the output folder's lock; its workers write into that folder. When the
leader is stopped (SIGTERM, SIGINT: the CLI turns both into ``KeyboardInterrupt``, so the
pools' ``with`` blocks terminate and join their workers before the lock is released) or
killed outright (SIGKILL: nothing of the leader runs), the workers must stop too:
:func:`die_with_parent`, called first in every worker, asks the kernel to send the worker
SIGKILL the moment its parent dies (Linux ``PR_SET_PDEATHSIG``; elsewhere nothing).
"""
from __future__ import annotations

import ctypes
import os
import signal
import sys

PR_SET_PDEATHSIG = 1


def die_with_parent() -> bool:
    """Have the kernel kill this process when its parent dies; True when it could."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) != 0:
            return False
    except (OSError, AttributeError):
        return False
    if os.getppid() == 1:   # the parent died before the request: go now
        os._exit(1)
    return True
