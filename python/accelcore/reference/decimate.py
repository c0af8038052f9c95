"""Reference time-aligned block-mean decimator (twin of ``accelcore-core/src/decimate.rs``)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from accelcore.reference._common import (
    FloatArray,
    IntArray,
    check_finite_positive,
    check_int,
    matrix,
    vector,
)
from accelcore.reference.errors import (
    IncompatibleError,
    InsufficientDataError,
    ParameterError,
    TimeOrderError,
)

__all__ = ["DecimatedBlocks", "Decimator"]


@dataclass(frozen=True)
class DecimatedBlocks:
    """Output of :meth:`Decimator.finish`: one row per kept block.

    Attributes
    ----------
    block_index : ndarray of int64, shape (n_blocks,)
        Block index ``k``, increasing; block ``k`` covers
        ``[t0 + k * factor / rate_hz, t0 + (k + 1) * factor / rate_hz)``.
    count : ndarray of int64, shape (n_blocks,)
        Number of valid rows averaged in each block.
    time_s : ndarray of float64, shape (n_blocks,)
        Mean time of the block's valid rows, s.
    temperature_c : ndarray of float64, shape (n_blocks,)
        Mean temperature of the block's valid rows, °C.
    channels : ndarray of float64, shape (n_blocks, n_channels)
        Mean of each channel.
    """

    block_index: IntArray
    count: IntArray
    time_s: FloatArray
    temperature_c: FloatArray
    channels: FloatArray


class Decimator:
    """Time-aligned block-mean decimator.

    Rows are grouped into blocks of nominal length ``factor / rate_hz`` seconds
    on a grid anchored at ``t0``; each block is reduced to the mean of its
    valid rows. Gaps in time leave block indices unused; jitter only moves
    rows within the grid.

    Parameters
    ----------
    factor : int, default 10
        Samples per block at the nominal rate (>= 1).
    rate_hz : float, default 20.0
        Nominal input sample rate, Hz (finite, > 0).
    n_channels : int, default 3
        Number of data channels besides time and temperature.
    min_count : int, default 1
        Blocks with fewer valid rows are dropped by :meth:`finish` (>= 1).
    t0_s : float or None, default None
        Origin of the block grid, s. ``None`` takes the time of the first row
        whose time is finite. Pass the same value to every piece of a log that
        is decimated in pieces and merged.

    Raises
    ------
    ParameterError
        If a configuration value is out of range.

    Notes
    -----
    A row is *valid* when its time, temperature and every channel value are
    finite. Invalid rows are skipped and counted in :attr:`n_skipped_nonfinite`;
    :attr:`n_samples` counts all rows pushed. Finite times must strictly
    increase over the whole stream, whether or not the row is valid.

    The block of a valid row at time ``t`` is
    ``k = floor((t - t0) * rate_hz / factor)``, evaluated in exactly that
    order in float64.
    """

    def __init__(
        self,
        *,
        factor: int = 10,
        rate_hz: float = 20.0,
        n_channels: int = 3,
        min_count: int = 1,
        t0_s: float | None = None,
    ) -> None:
        check_int("factor", factor, 1)
        check_finite_positive("rate_hz", rate_hz)
        check_int("n_channels", n_channels, 0)
        check_int("min_count", min_count, 1)
        if t0_s is not None and not math.isfinite(t0_s):
            raise ParameterError(f"t0_s must be finite, got {t0_s}")
        self.factor = int(factor)
        self.rate_hz = float(rate_hz)
        self.n_channels = int(n_channels)
        self.min_count = int(min_count)
        self._t0: float | None = None if t0_s is None else float(t0_s)
        self._first_time: float | None = None  # first finite time pushed
        self._last_time: float | None = None  # last finite time pushed
        self._n_samples = 0
        self._n_skipped = 0
        # Per pushed chunk, its blocks: index, count, and sums of time,
        # temperature and channels (columns of one array, in that order).
        self._block_index: list[IntArray] = []
        self._count: list[IntArray] = []
        self._sums: list[FloatArray] = []

    @property
    def t0_s(self) -> float | None:
        """Origin of the block grid, s (``None`` until known)."""
        return self._t0

    @property
    def n_samples(self) -> int:
        """Rows pushed so far, valid or not."""
        return self._n_samples

    @property
    def n_skipped_nonfinite(self) -> int:
        """Rows skipped because a value was NaN or infinite."""
        return self._n_skipped

    def push(
        self,
        time_s: ArrayLike,
        temperature_c: ArrayLike,
        channels: ArrayLike,
    ) -> None:
        """Append a chunk of rows (reduced at once to per-block sums).

        Parameters
        ----------
        time_s : array_like of float64, shape (n,)
            Time stamps, s.
        temperature_c : array_like of float64, shape (n,)
            Temperatures, °C.
        channels : array_like of float64, shape (n, n_channels)
            Channel values.

        Raises
        ------
        ShapeError
            If the lengths differ or ``channels`` has the wrong shape.
        TimeOrderError
            If a finite time is not greater than the previous finite time.
            The chunk is then rejected as a whole.
        """
        t = vector(time_s, "time_s")
        n = t.shape[0]
        temperature = vector(temperature_c, "temperature_c", n)
        ch = matrix(channels, "channels", n, self.n_channels)

        has_time = np.isfinite(t)
        finite_rows = np.flatnonzero(has_time)
        finite_t = t[has_time]
        if finite_t.size:
            previous = finite_t[:-1]
            if self._last_time is not None:
                previous = np.concatenate(([self._last_time], previous))
                current = finite_t
                rows = finite_rows
            else:
                current = finite_t[1:]
                rows = finite_rows[1:]
            bad = np.flatnonzero(current <= previous)
            if bad.size:
                i = int(bad[0])
                raise TimeOrderError(
                    self._n_samples + int(rows[i]), float(previous[i]), float(current[i])
                )

        valid = has_time & np.isfinite(temperature) & np.isfinite(ch).all(axis=1)
        if finite_t.size:
            if self._first_time is None:
                self._first_time = float(finite_t[0])
            self._last_time = float(finite_t[-1])
            if self._t0 is None:
                self._t0 = float(finite_t[0])
        self._n_samples += n
        self._n_skipped += int(n - np.count_nonzero(valid))
        if self._t0 is None or not valid.any():
            return
        if not valid.all():
            t, temperature, ch = t[valid], temperature[valid], ch[valid]
        # Time increases, so block indices are sorted and each block is one run.
        k = np.floor((t - self._t0) * self.rate_hz / self.factor).astype(np.int64)
        starts = np.flatnonzero(np.concatenate(([True], k[1:] != k[:-1])))
        self._block_index.append(k[starts])
        self._count.append(np.diff(np.append(starts, k.size)).astype(np.int64))
        self._sums.append(
            np.column_stack(
                (
                    np.add.reduceat(t, starts),
                    np.add.reduceat(temperature, starts),
                    np.add.reduceat(ch, starts, axis=0) if self.n_channels else ch[starts],
                )
            )
        )

    def merge(self, other: Decimator) -> None:
        """Absorb another decimator that holds a different piece of the same stream.

        Parameters
        ----------
        other : Decimator
            Same ``factor``, ``rate_hz``, ``n_channels`` and ``min_count``; if both
            know ``t0`` it must be equal, and the ranges of finite times of the
            two must not overlap. Blocks of equal index are combined.

        Raises
        ------
        IncompatibleError
            If any of these conditions fails.
        """
        mine = (self.factor, self.rate_hz, self.n_channels, self.min_count)
        theirs = (other.factor, other.rate_hz, other.n_channels, other.min_count)
        if mine != theirs:
            raise IncompatibleError(f"configurations differ: {mine} vs {theirs}")
        if self._t0 is not None and other._t0 is not None and self._t0 != other._t0:
            raise IncompatibleError(
                f"grid origins differ ({self._t0} vs {other._t0}); "
                "pass t0_s explicitly when splitting a log"
            )
        if (
            self._first_time is not None
            and self._last_time is not None
            and other._first_time is not None
            and other._last_time is not None
            and not (self._last_time < other._first_time or other._last_time < self._first_time)
        ):
            raise IncompatibleError("time ranges overlap")
        if self._t0 is None:
            self._t0 = other._t0
        if other._first_time is not None and other._last_time is not None:
            if self._first_time is None or other._first_time < self._first_time:
                self._first_time = other._first_time
            if self._last_time is None or other._last_time > self._last_time:
                self._last_time = other._last_time
        self._n_samples += other._n_samples
        self._n_skipped += other._n_skipped
        self._block_index.extend(other._block_index)
        self._count.extend(other._count)
        self._sums.extend(other._sums)

    def finish(self) -> DecimatedBlocks:
        """Return the means of all blocks with at least ``min_count`` valid rows.

        Returns
        -------
        DecimatedBlocks
            Blocks in increasing index order.

        Raises
        ------
        InsufficientDataError
            If no block has ``min_count`` valid rows (including no data at all).
        """
        if not self._block_index:
            raise InsufficientDataError("no valid sample pushed")
        k = np.concatenate(self._block_index)
        count = np.concatenate(self._count)
        sums = np.concatenate(self._sums, axis=0)
        # A block cut by a chunk boundary (or split between merged pieces)
        # appears once per chunk: bring its parts together and add them up.
        order = np.argsort(k, kind="stable")
        k, count, sums = k[order], count[order], sums[order]
        starts = np.flatnonzero(np.concatenate(([True], k[1:] != k[:-1])))
        k = k[starts]
        count = np.add.reduceat(count, starts)
        sums = np.add.reduceat(sums, starts, axis=0)

        keep = count >= self.min_count
        if not keep.any():
            raise InsufficientDataError(f"no block has min_count={self.min_count} valid samples")
        means = sums[keep] / count[keep, None].astype(np.float64)
        return DecimatedBlocks(
            block_index=k[keep],
            count=count[keep],
            time_s=means[:, 0],
            temperature_c=means[:, 1],
            channels=means[:, 2:],
        )
