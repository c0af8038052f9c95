"""Reference fixed-width temperature binner (twin of ``accelcore-core/src/binning.rs``)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from accelcore.reference._common import (
    FloatArray,
    IntArray,
    check_finite_positive,
    check_int,
    concat,
    matrix,
    safe_divide,
    vector,
)
from accelcore.reference.errors import IncompatibleError, InsufficientDataError, ParameterError

__all__ = ["N_BINS_SLACK", "BinnedStats", "TemperatureBinner"]

#: Slack subtracted before ``ceil`` when counting temperature bins, so that a
#: window that is a whole number of widths up to rounding gets no sliver bin.
N_BINS_SLACK = 1e-9


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
        check_finite_positive("width_c", width_c)
        check_int("n_channels", n_channels, 0)
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
        t = vector(time_s, "time_s")
        n = t.shape[0]
        temperature = vector(temperature_c, "temperature_c", n)
        ch = matrix(channels, "channels", n, self.n_channels)

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
        t = concat(self._time)
        temperature = concat(self._temperature)
        ch = concat(self._channels, self.n_channels)

        count = np.bincount(index, minlength=self.n_bins).astype(np.int64)
        n = count.astype(np.float64)

        def bin_sum(values: FloatArray) -> FloatArray:
            return np.bincount(index, weights=values, minlength=self.n_bins).astype(np.float64)

        mean = np.full((self.n_bins, self.n_channels), np.nan)
        variance = np.full((self.n_bins, self.n_channels), np.nan)
        for c in range(self.n_channels):
            mean[:, c] = safe_divide(bin_sum(ch[:, c]), n)
            deviation = ch[:, c] - mean[index, c]
            variance[:, c] = safe_divide(bin_sum(deviation * deviation), np.maximum(n - 1, 0))

        return BinnedStats(
            edges_c=self.edges_c,
            count=count,
            temperature_c=safe_divide(bin_sum(temperature), n),
            time_s=safe_divide(bin_sum(t), n),
            mean=mean,
            variance=variance,
            n_below=self._n_below,
            n_above=self._n_above,
            n_nonfinite=self._n_nonfinite,
        )
