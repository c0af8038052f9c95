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
import threading
from concurrent.futures import ThreadPoolExecutor

__all__ = ["shared_pool"]

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


def _forget_after_fork() -> None:
    """In a forked child: the parent's pools have no threads here; start afresh."""
    global _LOCK
    _POOLS.clear()
    _LOCK = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_after_fork)
