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

import contextlib
import ctypes
import multiprocessing as mp
import os
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import resource_tracker
from typing import Any

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
    if os.getppid() == 1 or (
        parent is not None and os.getppid() != parent
    ):  # it died before the request
        os._exit(1)
    return True


def forked_pool(
    workers: int, initializer: Callable[..., None] | None = None, initargs: tuple = ()
) -> ProcessPoolExecutor:
    """A pool of ``workers`` processes forked from this one: each starts with this process's
    memory (its scene, its compiled kernels) without a copy or a second import. Python >= 3.12
    warns of any fork in a process with threads; the callers' workers run only numpy and
    numba kernels, touching no lock another thread (a GL driver's, numba's work queue's) may
    hold, so the warning is silenced here. ``initializer`` should call
    :func:`die_with_parent` first."""
    with warnings.catch_warnings():
        warnings.filterwarnings(
            "ignore", r".*use of fork\(\) may lead to deadlocks", DeprecationWarning
        )
        return ProcessPoolExecutor(
            workers,
            mp_context=mp.get_context("fork"),
            initializer=initializer,
            initargs=initargs,
        )


@contextlib.contextmanager
def pool_started(make: Callable[[], Any]) -> Iterator[Any]:
    """The pool ``make()`` makes, made where no Ctrl-C reaches it; terminated when the block
    ends (as ``with pool:`` would).

    A Ctrl-C reaches the whole process group: a worker still unpickling its start-up data
    would print a ``KeyboardInterrupt`` traceback, and a leader interrupted half-way through
    making its pool would leave the workers it had started to fail on its vanished pipes
    (``EOFError``, ``UnpicklingError``, ``FileNotFoundError`` in ``spawn_main``). So the pool is
    made in a thread of its own with SIGINT blocked: no ``KeyboardInterrupt`` can land in the
    middle of it, and its workers inherit the blocked signal and never see one (their leader
    ends them: the pool's ``terminate``, or the kernel when it dies). The leader's interrupt
    lands in its main thread, which waits for the pool to be whole, terminates it and goes on
    unwinding (an interrupt that comes while the maker thread starts is held and raised once
    it has: one raised inside ``Thread.start`` would leave it making a pool no one ends)."""
    if (
        not hasattr(signal, "pthread_sigmask")
        or threading.current_thread() is not threading.main_thread()
    ):
        with make() as pool:
            yield pool
        return
    # it unblocks SIGINT once it has started its own process: start it first
    resource_tracker.ensure_running()
    box: dict[str, Any] = {}
    done = (
        threading.Event()
    )  # waited on, not join(): a join interrupted by Ctrl-C can mark a live thread stopped

    def run() -> None:
        try:
            box["pool"] = make()
        except BaseException as exc:  # noqa: BLE001  (handed to the main thread as it is)
            box["error"] = exc
        finally:
            done.set()

    maker = threading.Thread(target=run, name="genie-gl pool maker", daemon=True)
    held: list[int] = []

    def hold(signum: int, frame: object) -> None:
        held.append(signum)

    # While the maker starts, an interrupt is recorded, not raised: one raised inside start()
    # would leave a thread making a pool that no one ends. (One raised before this line finds
    # nothing started.)
    previous = {sig: signal.signal(sig, hold) for sig in (signal.SIGINT, signal.SIGTERM)}
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:  # the thread inherits the blocked SIGINT; the main thread gets it back at once
        maker.start()
    except BaseException:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        raise
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
    try:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        for sig in held[:1]:  # the interrupt that came meanwhile, through the caller's handler
            signal.raise_signal(sig)
        while not done.wait(0.05):
            pass
        if "error" in box:
            raise box["error"]
        yield box["pool"]
    finally:  # an interrupt anywhere above: the pool is made whole, then ended
        done.wait()
        if "pool" in box:
            box["pool"].terminate()


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
                print(
                    f"{who}: compiling genie-gl's kernels (numba), a one-time cost of a minute or "
                    "two on the first "
                    "run; later runs load them from the cache",
                    file=sys.stderr,
                    flush=True,
                )

        def on_end(self, ev: object) -> None:
            pass

    event.register("numba:compile", Note())
