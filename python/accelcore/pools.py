"""Thread pools kept for the life of the process: one per purpose and size.

Reading a session's logs, the diagnosis' quality check beside its engine, and the
engine's factor pushes each run a few tasks on threads (the core releases the
GIL). A pool made and shut down per call costs a thread start and join per
worker, each time (a few hundred microseconds on a virtual machine, more than
some of the tasks); these pools are made once and reused. Each purpose has its
own pools, so a task never waits on work queued behind itself. A child process
made by ``fork`` starts without them (their threads do not exist there) and makes
its own on first use.

Foundation: imports nothing from accelcore.
"""

from __future__ import annotations

import os
import sys
import threading
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager

__all__ = ["SIDE_TASK_SWITCH_S", "beside", "shared_pool"]

#: The interpreter's switch interval while Python work runs on a pool thread beside
#: the caller's (CPython's default is 5 ms).
SIDE_TASK_SWITCH_S = 0.0005

_POOLS: dict[tuple[str, int], ThreadPoolExecutor] = {}
_LOCK = threading.Lock()


def shared_pool(purpose: str, workers: int) -> ThreadPoolExecutor:
    """Return the process' pool of ``workers`` threads (at least 1) for ``purpose``.

    Never shut it down: other callers share it. Its threads are daemon-like (as every
    :class:`~concurrent.futures.ThreadPoolExecutor`'s): they end with the interpreter.
    """
    key = (purpose, max(1, int(workers)))
    pool = _POOLS.get(key)
    if pool is None:
        with _LOCK:
            pool = _POOLS.get(key)
            if pool is None:
                pool = ThreadPoolExecutor(max_workers=key[1], thread_name_prefix=purpose)
                _POOLS[key] = pool
    return pool


@contextmanager
def beside() -> Iterator[None]:
    """Run the ``with`` body while a task that runs Python code works on a pool thread.

    Two threads that both run Python code take turns on the GIL; one that asks for it
    waits until the other lets go or the switch interval (5 ms by default) ends. The
    caller's thread lets go at every core or NumPy call, and each time may wait that
    long to go on: the diagnosis' quality check on its thread beside the engine's
    set-up added 9.7 ms to a six-run 0.25 h session's diagnosis (5.3 ms to a 2 h one),
    more than the 3.5 ms the check takes alone. For the body the interval is
    :data:`SIDE_TASK_SWITCH_S` (5.0 and 3.9 ms added); the previous one comes back
    after it, unless someone else changed it meanwhile.
    """
    before = sys.getswitchinterval()
    sys.setswitchinterval(SIDE_TASK_SWITCH_S)
    ours = sys.getswitchinterval()  # as the interpreter rounded it
    try:
        yield
    finally:
        if sys.getswitchinterval() == ours:
            sys.setswitchinterval(before)


def _forget_after_fork() -> None:
    """In a forked child: the parent's pools have no threads here; start afresh."""
    global _LOCK
    _POOLS.clear()
    _LOCK = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_after_fork)
