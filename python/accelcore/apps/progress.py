"""Progress of a long command on stderr: the one progress bar of the applications (tqdm).

A :class:`Progress` draws a tqdm bar on a terminal and erases it when the work
ends, so the command's results (on stdout, or its JSON) never hold a trace of it.
It draws nothing at all when the stream is not a terminal, when disabled
(``--quiet``), or when the work ends within :data:`DELAY_S` (a small input is
never cluttered: tqdm's own ``delay``). A background thread refreshes the bar
while one long step runs, so its elapsed time moves. ``bulk`` also asks for plain
log lines, one per session, when the stream is not a terminal (a log file of the
archive's run).

Part of the applications room: imports nothing of accelcore.
"""

from __future__ import annotations

import math
import sys
import threading
import time
from types import TracebackType
from typing import Never, Self, TextIO

from tqdm import tqdm

__all__ = ["DELAY_S", "Progress"]

#: Seconds of work before a bar first shows (a small input never shows one).
DELAY_S = 1.0

#: Seconds between two refreshes of the bar while one step runs.
TICK_S = 0.25


class Progress:
    """Progress of ``total`` steps (or of a count, when ``total`` is None) on a stream.

    Parameters
    ----------
    total : int or None
        Steps to do; None counts items (rows, say) without a bar.
    what : str, optional
        What is counted when ``total`` is None (``"rows"``), or a prefix of the bar.
    stream : text stream, optional
        Where progress goes; default ``sys.stderr`` (looked up when made).
    enabled : bool, default True
        False draws nothing (``--quiet``).
    log_lines : bool, default False
        When the stream is not a terminal, write one line per :meth:`advance`
        instead of nothing.
    rate : bool, default False
        Show the rate per minute and the time left (sessions of ``bulk``).
    delay_s : float, optional
        Seconds of work before the bar first shows; default :data:`DELAY_S`.
    """

    def __init__(
        self,
        total: int | None,
        *,
        what: str = "",
        stream: TextIO | None = None,
        enabled: bool = True,
        log_lines: bool = False,
        rate: bool = False,
        delay_s: float | None = None,
    ) -> None:
        self.total, self.what, self.done, self.step_name = total, what, 0, ""
        self.stream = stream or sys.stderr
        self.start = time.monotonic()
        self.rate = rate
        self.delay_s = DELAY_S if delay_s is None else delay_s
        self.tty = enabled and _isatty(self.stream)
        self.log_lines = enabled and log_lines and not self.tty
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._bar: tqdm[Never] | None = None
        self._ticker: threading.Thread | None = None
        if self.tty:
            bar: tqdm[Never] = tqdm(
                total=total,
                desc=what or None,
                unit=" " + what if total is None and what else "",
                file=self.stream,
                position=0,
                delay=self.delay_s,
                leave=False,
                ncols=79,
                mininterval=0.0,
                unit_scale=total is None,
                ascii=".#",
                bar_format=None if rate or total is None else "{desc}[{bar}] {n}/{total}{postfix}",
            )
            if total is None:
                bar.desc = ""
            self._bar = bar
            self._ticker = threading.Thread(target=self._tick, name="progress", daemon=True)
            self._ticker.start()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def step(self, name: str) -> None:
        """Start the next step, named beside the bar; the step before it counts as done."""
        with self._lock:
            if self.step_name:
                self.done += 1
                if self._bar is not None:
                    self._bar.update(1)
            self.step_name = name
            if self._bar is not None:
                self._bar.set_postfix_str(name, refresh=False)
                self._refresh()

    def advance(self, n: int = 1, *, item: str = "", status: str = "") -> None:
        """Count ``n`` more steps (or items) done; ``item`` and ``status`` go to log lines."""
        with self._lock:
            self.done += n
            if self.log_lines:
                self._line(item, status)
            if self._bar is not None:
                self._bar.update(n)
                self._refresh()

    def close(self) -> None:
        """Stop the refresher and erase the bar (tqdm clears its line: ``leave=False``)."""
        self._stop.set()
        if self._ticker is not None:
            self._ticker.join()
            self._ticker = None
        with self._lock:
            if self._bar is not None:
                self._bar.close()
                self._bar = None

    # ------------------------------------------------------------------ drawing
    def _tick(self) -> None:
        while not self._stop.wait(TICK_S):
            with self._lock:
                self._refresh()

    def _refresh(self) -> None:
        """Redraw the bar once the delay has passed (before it, draw nothing at all)."""
        if self._bar is not None and time.monotonic() - self.start >= self.delay_s:
            self._bar.refresh()

    def _speed(self) -> tuple[float, float]:
        elapsed = time.monotonic() - self.start
        per_s = self.done / elapsed if elapsed > 0 else 0.0
        left = ((self.total or 0) - self.done) / per_s if per_s > 0 else math.nan
        return per_s, left

    def _line(self, item: str, status: str) -> None:
        per_s, left = self._speed()
        self.stream.write(
            f"{self.done}/{self.total} {item}: {status} ({per_s * 60:.1f}/min, {left:.0f} s left)\n"
        )
        self.stream.flush()


def _isatty(stream: TextIO) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False
