"""Pure-NumPy reference implementation of the accelcore streaming kernels.

This module is the executable specification of :mod:`accelcore.core`, the test
oracle of the property tests and the baseline of the benchmarks. It is written
in the plainest vectorised NumPy and never imports the compiled extension, so
it can be read, run and trusted on its own.

Every kernel has the same API as its Rust twin: a keyword-configured class with
``push`` (a chunk of samples), ``merge`` (another accumulator of the same
configuration) and ``finish`` (the result; it does not alter the state).
Chunks are validated in ``push``. :class:`TemperatureBinner` keeps the rows and
does all its arithmetic in ``finish`` (a two-pass variance); :class:`Decimator`
reduces each chunk to per-block sums and :class:`LeastSquares` each chunk to a
small triangular factor as they arrive, so that their memory does not grow
with the number of rows.

The reference raises its own exception classes, which carry the same names as
the ones in :mod:`accelcore` (``ParameterError``, ``ShapeError``, ...) and
likewise subclass :class:`ValueError`, so that tests can compare errors by
class name without this module depending on the extension.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "BinnedStats",
    "DecimatedBlocks",
    "Decimator",
    "IncompatibleError",
    "InsufficientDataError",
    "LeastSquares",
    "LstsqSolution",
    "NonFiniteError",
    "ParameterError",
    "ReferenceKernelError",
    "ShapeError",
    "SingularSystemError",
    "TemperatureBinner",
    "TimeOrderError",
    "running_median",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Relative threshold of the rank test: column ``j`` of the weighted design is
#: numerically a combination of earlier columns when the norm of its component
#: orthogonal to them is at most ``RANK_RTOL`` times its own norm.
RANK_RTOL = 1e-10

#: Slack subtracted before ``ceil`` when counting temperature bins, so that a
#: window that is a whole number of widths up to rounding gets no sliver bin.
N_BINS_SLACK = 1e-9


# --------------------------------------------------------------------------- errors


class ReferenceKernelError(ValueError):
    """Base class of the errors raised by the reference kernels."""


class ParameterError(ReferenceKernelError):
    """A configuration value or a weight is out of its valid range."""


class ShapeError(ReferenceKernelError):
    """Input arrays do not have the shape the kernel was configured for."""


class TimeOrderError(ReferenceKernelError):
    """Finite time stamps are not strictly increasing.

    Parameters
    ----------
    index : int
        Zero-based index of the offending row in the whole stream.
    previous_s : float
        Previous finite time stamp, s.
    time_s : float
        Offending time stamp, s.
    """

    def __init__(self, index: int, previous_s: float, time_s: float) -> None:
        super().__init__(
            f"time is not strictly increasing at sample {index}: {previous_s} s then {time_s} s"
        )
        self.index = index
        self.previous_s = previous_s
        self.time_s = time_s


class NonFiniteError(ReferenceKernelError):
    """A value that must be finite is NaN or infinite."""


class InsufficientDataError(ReferenceKernelError):
    """There is not enough usable data for the requested result."""


class IncompatibleError(ReferenceKernelError):
    """Two accumulators cannot be merged."""


class SingularSystemError(ReferenceKernelError):
    """The weighted design cannot identify some columns.

    Parameters
    ----------
    columns : list of str
        Names of the columns that are numerically linear combinations of
        earlier columns (or all zero).
    """

    def __init__(self, columns: list[str]) -> None:
        super().__init__(f"rank-deficient design: cannot identify {', '.join(columns)}")
        self.columns = columns


# --------------------------------------------------------------------------- helpers


def _vector(values: ArrayLike, what: str, n: int | None = None) -> FloatArray:
    """Return ``values`` as a 1-D float64 array, checking its length."""
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 1:
        raise ShapeError(f"{what} must be 1-D, got {array.ndim} dimensions")
    if n is not None and array.shape[0] != n:
        raise ShapeError(f"{what} has {array.shape[0]} rows, expected {n}")
    return array


def _matrix(values: ArrayLike, what: str, n: int, n_columns: int) -> FloatArray:
    """Return ``values`` as an ``(n, n_columns)`` float64 array, checking its shape."""
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 2:
        raise ShapeError(f"{what} must be 2-D, got {array.ndim} dimensions")
    if array.shape != (n, n_columns):
        raise ShapeError(f"{what} has shape {array.shape}, expected {(n, n_columns)}")
    return array


def _concat(chunks: Sequence[FloatArray], width: int | None = None) -> FloatArray:
    """Concatenate chunks along axis 0; an empty list gives an empty array."""
    if chunks:
        return np.concatenate(chunks, axis=0)
    shape = (0,) if width is None else (0, width)
    return np.empty(shape, dtype=np.float64)


def _safe_divide(numerator: FloatArray, denominator: FloatArray) -> FloatArray:
    """Divide elementwise, giving NaN where ``denominator`` is zero (no warning)."""
    out = np.full(np.broadcast_shapes(numerator.shape, denominator.shape), np.nan)
    np.divide(numerator, denominator, out=out, where=denominator != 0)
    return out


def _check_finite_positive(name: str, value: float) -> None:
    if not (math.isfinite(value) and value > 0):
        raise ParameterError(f"{name} must be finite and > 0, got {value}")


def _check_int(name: str, value: int, minimum: int) -> None:
    if int(value) != value or value < minimum:
        raise ParameterError(f"{name} must be an integer >= {minimum}, got {value}")


# --------------------------------------------------------------------------- Decimator


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
        _check_int("factor", factor, 1)
        _check_finite_positive("rate_hz", rate_hz)
        _check_int("n_channels", n_channels, 0)
        _check_int("min_count", min_count, 1)
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
        t = _vector(time_s, "time_s")
        n = t.shape[0]
        temperature = _vector(temperature_c, "temperature_c", n)
        ch = _matrix(channels, "channels", n, self.n_channels)

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


# --------------------------------------------------------------------------- TemperatureBinner


@dataclass(frozen=True)
class BinnedStats:
    """Output of :meth:`TemperatureBinner.finish`.

    Attributes
    ----------
    edges_c : ndarray of float64, shape (n_bins + 1,)
        ``lo_c + i * width_c`` for ``i < n_bins``, then ``hi_c``.
    count : ndarray of int64, shape (n_bins,)
        Rows per bin.
    temperature_c, time_s : ndarray of float64, shape (n_bins,)
        Mean temperature and time per bin (NaN when the bin is empty).
    mean : ndarray of float64, shape (n_bins, n_channels)
        Mean per bin and channel (NaN when the bin is empty).
    variance : ndarray of float64, shape (n_bins, n_channels)
        Sample variance (ddof = 1) per bin and channel (NaN when count < 2).
    n_below, n_above, n_nonfinite : int
        Finite rows with ``T < lo_c``, finite rows with ``T >= hi_c``, and rows
        skipped because a value was NaN or infinite.
    """

    edges_c: FloatArray
    count: IntArray
    temperature_c: FloatArray
    time_s: FloatArray
    mean: FloatArray
    variance: FloatArray
    n_below: int
    n_above: int
    n_nonfinite: int


class TemperatureBinner:
    """Fixed-width temperature bins with per-bin count, mean and variance.

    Bins are closed on the left and open on the right, ``[lo_c, hi_c)``
    overall: row with temperature ``T`` goes to bin
    ``floor((T - lo_c) / width_c)``, clamped to the last bin; ``T < lo_c`` and
    ``T >= hi_c`` are only counted. The last bin is narrower when the window
    is not a whole number of widths.

    Parameters
    ----------
    lo_c : float, default 0.0
        Lower edge of the window, °C (inclusive).
    hi_c : float, default 60.0
        Upper edge of the window, °C (exclusive), ``> lo_c``.
    width_c : float, default 0.5
        Bin width, °C (finite, > 0).
    n_channels : int, default 3
        Number of data channels.

    Raises
    ------
    ParameterError
        If the window or width is invalid.
    """

    def __init__(
        self,
        *,
        lo_c: float = 0.0,
        hi_c: float = 60.0,
        width_c: float = 0.5,
        n_channels: int = 3,
    ) -> None:
        if not (math.isfinite(lo_c) and math.isfinite(hi_c) and hi_c > lo_c):
            raise ParameterError(f"need finite lo_c < hi_c, got {lo_c}, {hi_c}")
        _check_finite_positive("width_c", width_c)
        _check_int("n_channels", n_channels, 0)
        n_bins = math.ceil((hi_c - lo_c) / width_c - N_BINS_SLACK)
        if n_bins < 1:
            raise ParameterError("the window holds no bin")
        self.lo_c = float(lo_c)
        self.hi_c = float(hi_c)
        self.width_c = float(width_c)
        self.n_channels = int(n_channels)
        self.n_bins = int(n_bins)
        self._n_nonfinite = 0
        self._n_below = 0
        self._n_above = 0
        self._bin: list[NDArray[np.intp]] = []  # in-window rows only
        self._time: list[FloatArray] = []
        self._temperature: list[FloatArray] = []
        self._channels: list[FloatArray] = []

    @property
    def edges_c(self) -> FloatArray:
        """Bin edges, °C, shape (n_bins + 1,)."""
        edges = self.lo_c + np.arange(self.n_bins + 1, dtype=np.float64) * self.width_c
        edges[-1] = self.hi_c
        return edges

    def push(
        self,
        time_s: ArrayLike,
        temperature_c: ArrayLike,
        channels: ArrayLike,
    ) -> None:
        """Add a chunk of rows.

        Parameters
        ----------
        time_s : array_like of float64, shape (n,)
            Time stamps, s (any order).
        temperature_c : array_like of float64, shape (n,)
            Temperatures, °C; selects the bin.
        channels : array_like of float64, shape (n, n_channels)
            Channel values.

        Raises
        ------
        ShapeError
            If the lengths differ or ``channels`` has the wrong shape.
        """
        t = _vector(time_s, "time_s")
        n = t.shape[0]
        temperature = _vector(temperature_c, "temperature_c", n)
        ch = _matrix(channels, "channels", n, self.n_channels)

        finite = np.isfinite(t) & np.isfinite(temperature) & np.isfinite(ch).all(axis=1)
        below = finite & (temperature < self.lo_c)
        above = finite & (temperature >= self.hi_c)
        inside = finite & ~below & ~above
        bin_index = np.floor((temperature[inside] - self.lo_c) / self.width_c).astype(np.intp)
        self._bin.append(np.minimum(bin_index, self.n_bins - 1))
        self._time.append(t[inside])
        self._temperature.append(temperature[inside])
        self._channels.append(ch[inside])
        self._n_nonfinite += int(n - np.count_nonzero(finite))
        self._n_below += int(np.count_nonzero(below))
        self._n_above += int(np.count_nonzero(above))

    def merge(self, other: TemperatureBinner) -> None:
        """Absorb another binner of identical configuration.

        Raises
        ------
        IncompatibleError
            If ``lo_c``, ``hi_c``, ``width_c`` or ``n_channels`` differ.
        """
        mine = (self.lo_c, self.hi_c, self.width_c, self.n_channels)
        theirs = (other.lo_c, other.hi_c, other.width_c, other.n_channels)
        if mine != theirs:
            raise IncompatibleError(f"configurations differ: {mine} vs {theirs}")
        self._bin.extend(other._bin)
        self._time.extend(other._time)
        self._temperature.extend(other._temperature)
        self._channels.extend(other._channels)
        self._n_nonfinite += other._n_nonfinite
        self._n_below += other._n_below
        self._n_above += other._n_above

    def finish(self) -> BinnedStats:
        """Return the per-bin statistics.

        Means are sums over count; variances are computed in two passes
        (sum of squared deviations from the bin mean, over ``count - 1``).

        Raises
        ------
        InsufficientDataError
            If no row fell inside the window.
        """
        index = np.concatenate(self._bin) if self._bin else np.empty(0, dtype=np.intp)
        if index.size == 0:
            raise InsufficientDataError("no sample inside the temperature window")
        t = _concat(self._time)
        temperature = _concat(self._temperature)
        ch = _concat(self._channels, self.n_channels)

        count = np.bincount(index, minlength=self.n_bins).astype(np.int64)
        n = count.astype(np.float64)

        def bin_sum(values: FloatArray) -> FloatArray:
            return np.bincount(index, weights=values, minlength=self.n_bins).astype(np.float64)

        mean = np.full((self.n_bins, self.n_channels), np.nan)
        variance = np.full((self.n_bins, self.n_channels), np.nan)
        for c in range(self.n_channels):
            mean[:, c] = _safe_divide(bin_sum(ch[:, c]), n)
            deviation = ch[:, c] - mean[index, c]
            variance[:, c] = _safe_divide(bin_sum(deviation * deviation), np.maximum(n - 1, 0))

        return BinnedStats(
            edges_c=self.edges_c,
            count=count,
            temperature_c=_safe_divide(bin_sum(temperature), n),
            time_s=_safe_divide(bin_sum(t), n),
            mean=mean,
            variance=variance,
            n_below=self._n_below,
            n_above=self._n_above,
            n_nonfinite=self._n_nonfinite,
        )


# --------------------------------------------------------------------------- LeastSquares


@dataclass(frozen=True)
class LstsqSolution:
    """Output of :meth:`LeastSquares.finish`.

    Attributes
    ----------
    coefficients : ndarray of float64, shape (p,)
        Minimiser of ``sum(w * (y - X @ beta) ** 2)``.
    covariance : ndarray of float64, shape (p, p)
        ``sigma2 * inv(X' W X)`` with ``sigma2 = residual_sum_squares / dof``;
        all NaN when ``dof == 0``.
    residual_sum_squares : float
        Weighted residual sum of squares.
    dof : int
        ``n_rows - p``.
    n_rows : int
        Rows with non-zero weight.
    condition_number : float
        2-norm condition number of ``sqrt(W) X``.
    condition_number_scaled : float
        2-norm condition number of ``sqrt(W) X`` with each column scaled to
        unit norm.
    column_names : list of str
        Column names.
    """

    coefficients: FloatArray
    covariance: FloatArray
    residual_sum_squares: float
    dof: int
    n_rows: int
    condition_number: float
    condition_number_scaled: float
    column_names: list[str]


def _back_substitute(r: FloatArray, rhs: FloatArray) -> FloatArray:
    """Solve ``r @ x = rhs`` for upper-triangular, non-singular ``r``.

    ``rhs`` may be 1-D or 2-D (one system per column). The loop runs over the
    ``p`` unknowns, never over samples.
    """
    p = r.shape[0]
    x = np.zeros(rhs.shape, dtype=np.float64)
    for i in range(p - 1, -1, -1):
        x[i] = (rhs[i] - r[i, i + 1 :] @ x[i + 1 :]) / r[i, i]
    return x


def _triangular_factor(matrix: FloatArray) -> FloatArray:
    """Return ``R`` of the QR decomposition of ``matrix`` (Householder, LAPACK)."""
    # ``mode="r"`` returns the bare array at run time; ``asarray`` only restates its type.
    return np.asarray(np.linalg.qr(matrix, mode="r"), dtype=np.float64)


def _condition_number(matrix: FloatArray) -> float:
    singular_values = np.linalg.svd(matrix, compute_uv=False)
    return float(singular_values[0] / singular_values[-1])


class LeastSquares:
    """Incremental weighted linear least squares.

    Solves ``min_beta sum_i w_i * (y_i - x_i @ beta) ** 2`` over all rows
    pushed (and merged). Each chunk is reduced on arrival to the triangular
    factor of the QR decomposition of ``[sqrt(w) X | sqrt(w) y]`` (Householder,
    via :func:`numpy.linalg.qr`); :meth:`finish` stacks the factors, reduces
    them once more and solves by back substitution.

    Parameters
    ----------
    n_columns : int
        Number of unknowns ``p`` (1 to 64).
    column_names : sequence of str or None, default None
        One name per column; default ``"x0"``, ``"x1"``, ...

    Raises
    ------
    ParameterError
        If ``n_columns`` is out of range, or the names do not match it or repeat.

    Notes
    -----
    Rank test: after the QR decomposition of the weighted design, column
    ``j`` is declared unidentifiable when the norm of its component orthogonal
    to the earlier *identifiable* columns is at most ``1e-10`` times its own
    norm (this includes all-zero columns). The test runs on the ``p x p``
    triangular factor, where both norms are preserved.
    """

    def __init__(self, n_columns: int, *, column_names: Sequence[str] | None = None) -> None:
        _check_int("n_columns", n_columns, 1)
        if n_columns > 64:
            raise ParameterError(f"n_columns must be <= 64, got {n_columns}")
        names = [f"x{j}" for j in range(n_columns)] if column_names is None else list(column_names)
        if len(names) != n_columns:
            raise ParameterError(f"{len(names)} column names for {n_columns} columns")
        if len(set(names)) != len(names):
            raise ParameterError(f"column names must be unique, got {names}")
        self.n_columns = int(n_columns)
        self.column_names = names
        self._n_rows = 0
        self._factors: list[FloatArray] = []  # triangular factors of [sqrt(w) X | sqrt(w) y]

    @property
    def n_rows(self) -> int:
        """Rows with non-zero weight pushed so far."""
        return self._n_rows

    def push(
        self,
        design: ArrayLike,
        response: ArrayLike,
        weights: ArrayLike | None = None,
    ) -> None:
        """Add rows.

        Parameters
        ----------
        design : array_like of float64, shape (n, p)
            Design matrix rows.
        response : array_like of float64, shape (n,)
            Responses.
        weights : array_like of float64, shape (n,), optional
            Non-negative weights (default 1). Zero-weight rows are ignored and
            not counted.

        Raises
        ------
        ShapeError
            If the shapes do not match.
        NonFiniteError
            If any value is NaN or infinite (the chunk is rejected).
        ParameterError
            If a weight is negative (the chunk is rejected).
        """
        y = _vector(response, "response")
        n = y.shape[0]
        x = _matrix(design, "design", n, self.n_columns)
        w = np.ones(n) if weights is None else _vector(weights, "weights", n)
        for what, values in (("design", x), ("response", y), ("weights", w)):
            if not np.isfinite(values).all():
                raise NonFiniteError(f"non-finite value in {what}")
        if (w < 0).any():
            raise ParameterError("weights must be >= 0")
        used = w > 0
        if not used.any():
            return
        root_w = np.sqrt(w[used])
        augmented = np.column_stack((x[used] * root_w[:, None], y[used] * root_w))
        self._factors.append(_triangular_factor(augmented))
        self._n_rows += int(np.count_nonzero(used))

    def merge(self, other: LeastSquares) -> None:
        """Absorb the rows of another problem with the same columns.

        Raises
        ------
        IncompatibleError
            If the number or names of the columns differ.
        """
        if (self.n_columns, self.column_names) != (other.n_columns, other.column_names):
            raise IncompatibleError(f"columns differ: {self.column_names} vs {other.column_names}")
        self._factors.extend(other._factors)
        self._n_rows += other._n_rows

    def finish(self) -> LstsqSolution:
        """Solve the problem.

        Returns
        -------
        LstsqSolution

        Raises
        ------
        InsufficientDataError
            If there are no rows or fewer rows than columns.
        SingularSystemError
            If some columns are numerically combinations of earlier ones.
        """
        p = self.n_columns
        if self._n_rows == 0:
            raise InsufficientDataError("no rows with non-zero weight")
        if self._n_rows < p:
            raise InsufficientDataError(f"need {p} rows, have {self._n_rows}")
        factor = _triangular_factor(np.concatenate(self._factors, axis=0))
        r = factor[:p, :p]
        z = factor[:p, p]
        rss = float(factor[p, p] ** 2) if factor.shape[0] > p else 0.0

        column_norm = np.linalg.norm(r, axis=0)
        identifiable: list[int] = []
        singular: list[str] = []
        for j in range(p):
            trial = _triangular_factor(r[:, [*identifiable, j]])
            orthogonal_part = abs(float(trial[len(identifiable), len(identifiable)]))
            if orthogonal_part <= RANK_RTOL * float(column_norm[j]):
                singular.append(self.column_names[j])
            else:
                identifiable.append(j)
        if singular:
            raise SingularSystemError(singular)

        coefficients = _back_substitute(r, z)
        dof = self._n_rows - p
        if dof > 0:
            r_inverse = _back_substitute(r, np.eye(p))
            covariance = (rss / dof) * (r_inverse @ r_inverse.T)
        else:
            covariance = np.full((p, p), np.nan)
        return LstsqSolution(
            coefficients=coefficients,
            covariance=covariance,
            residual_sum_squares=rss,
            dof=dof,
            n_rows=self._n_rows,
            condition_number=_condition_number(r),
            condition_number_scaled=_condition_number(r / column_norm),
            column_names=list(self.column_names),
        )


# --------------------------------------------------------------------------- running_median

#: Rows of the sliding-window view :func:`running_median` sorts at a time (bounds memory).
_MEDIAN_CHUNK = 1 << 16


def running_median(y: ArrayLike, window: int) -> FloatArray:
    """Centred running median of ``y`` over ``2 * (window // 2) + 1`` values.

    ``y`` is padded by ``half = window // 2`` values at each end with
    ``np.pad(mode="reflect")`` (the end values are not repeated), or
    ``mode="edge"`` when ``len(y) <= half``; output ``i`` is ``np.median`` of
    padded values ``i`` to ``i + 2 * half``, so NaN where that window holds a
    NaN. Empty ``y`` gives an empty array.

    Parameters
    ----------
    y : array_like, shape (n,)
        The series.
    window : int
        Window length, >= 1 (an even length is rounded up to the next odd one).

    Returns
    -------
    ndarray of float64, shape (n,)
        The running median.

    Raises
    ------
    ParameterError
        ``window`` is not an integer >= 1.
    ShapeError
        ``y`` is not 1-D.
    """
    _check_int("window", window, 1)
    y = _vector(y, "y")
    n = y.shape[0]
    half = int(window) // 2
    out = np.empty(n)
    if n == 0:
        return out
    padded = np.pad(y, half, mode="reflect") if n > half else np.pad(y, half, mode="edge")
    for start in range(0, n, _MEDIAN_CHUNK):
        stop = min(start + _MEDIAN_CHUNK, n)
        view = sliding_window_view(padded[start : stop + 2 * half], 2 * half + 1)
        out[start:stop] = np.median(view, axis=1)
    return out
