"""A time-constant search, written plainly: build each trial's design, refit its rows.

The specification of :class:`accelcore.core.TimeConstantSearch`. A trial is a linear
model at one value of ``tau``: columns that do not depend on it (*fixed*, given as
window means) and columns built from it at full rate, then averaged over windows of
consecutive samples:

- ``("lag", k, m)``: ``(lag(T, tau) - t_ref_c)^k``, the temperature of each record
  through a first-order lag (:func:`first_order_lag`, one pass per record, gathered
  to the samples), the power as repeated products ``p_k = p_(k-1) * p_1``;
- ``("decay", 0, m)``: ``exp(-t / tau)``, ``t`` the time since the run's start;

each the weighted mean of its window's samples (a window of zero weight: the
weighted sum) times its multiplier ``m`` (one value per window, or 1). The trial's
score is the held-out weighted squared error of every block (:func:`cross_validate`,
rows refitted with NumPy) on every ``stride``-th window, summed. The search rounds
``tau`` to three significant digits (``float(f"{tau:.3g}")``), scores a log grid,
then takes parabolic steps in ``log tau`` (golden section where a parabola leaves the
bracket). Nothing is kept between trials; this module never calls the core.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from accelcore.reference.heldout import cross_validate

__all__ = ["TimeConstantSearch", "first_order_lag"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
Column = tuple[str, int, ArrayLike | None]


def first_order_lag(
    time_s: ArrayLike, temperature_c: ArrayLike, tau_s: float, tau_cool_s: float | None = None
) -> FloatArray:
    """Return the temperature through a first-order lag of ``tau_s`` seconds.

    ``y[i] = y[i-1] + a (x[i] - y[i-1])``, ``a = 1 - exp(-(t[i] - t[i-1]) / tau)``
    computed as ``-expm1(-dt / tau)`` (as the core does), ``y[0] = x[0]``. With
    ``tau_cool_s``: ``tau`` is ``tau_s`` where ``x[i] > y[i-1]`` (heating), else
    ``tau_cool_s``.
    """
    t = np.asarray(time_s, dtype=np.float64)
    x = np.asarray(temperature_c, dtype=np.float64)
    cool = tau_s if tau_cool_s is None else tau_cool_s
    y = np.empty_like(x)
    for i in range(x.size):
        if i == 0:
            y[i] = x[0]
        else:
            tau = tau_s if x[i] > y[i - 1] else cool
            alpha = -math.expm1(-(t[i] - t[i - 1]) / tau)
            y[i] = y[i - 1] + alpha * (x[i] - y[i - 1])
    return y


class TimeConstantSearch:
    """Time-constant searches over one data set (see the module docstring).

    Parameters
    ----------
    records : list of (array_like, array_like)
        Time (s) and temperature (°C) of every record, whole.
    gather : array_like of int, shape (n,)
        Each sample's index in the records laid end to end.
    elapsed_s, sample_weight : array_like, shape (n,)
        Each sample's time since its run's start (s) and weight.
    window_start : array_like of int, shape (n_windows,)
        First sample of each window (contiguous windows from sample 0).
    window_weight : array_like, shape (n_windows,)
        Each window's weight.
    window_block : array_like of int, shape (n_windows,)
        Each window's block.
    block_fold : array_like of int, shape (n_blocks,)
        Each block's fold.
    t_ref_c : float
        Reference temperature, °C.
    stride : int
        Trials fit windows ``0, stride, 2 stride, ...``.
    """

    def __init__(
        self,
        records: Sequence[tuple[ArrayLike, ArrayLike]],
        gather: ArrayLike,
        elapsed_s: ArrayLike,
        sample_weight: ArrayLike,
        window_start: ArrayLike,
        window_weight: ArrayLike,
        window_block: ArrayLike,
        block_fold: ArrayLike,
        /,
        *,
        t_ref_c: float,
        stride: int,
    ) -> None:
        self.records = [
            (np.asarray(t, dtype=np.float64), np.asarray(x, dtype=np.float64)) for t, x in records
        ]
        self.gather = np.asarray(gather, dtype=np.int64)
        self.elapsed_s = np.asarray(elapsed_s, dtype=np.float64)
        self.w = np.asarray(sample_weight, dtype=np.float64)
        self.start = np.asarray(window_start, dtype=np.int64)
        self.window_weight = np.asarray(window_weight, dtype=np.float64)
        self.window_block = np.asarray(window_block, dtype=np.int64)
        self.block_fold = np.asarray(block_fold, dtype=np.int64)
        self.t_ref_c = float(t_ref_c)
        self.rows = np.arange(0, self.start.size, stride)

    @property
    def n_rows(self) -> int:
        """Windows a trial fits."""
        return int(self.rows.size)

    def window_means(self, values: FloatArray) -> FloatArray:
        """Weighted mean of ``values`` (one per sample) over each window."""
        stops = np.append(self.start[1:], self.w.size)
        sums = np.array(
            [np.sum(self.w[a:b] * values[a:b]) for a, b in zip(self.start, stops, strict=True)]
        )
        return np.asarray(sums / np.where(self.window_weight > 0, self.window_weight, 1.0))

    def design(self, fixed: ArrayLike, columns: Sequence[Column], tau_s: float) -> FloatArray:
        """Return the design of one trial, one row per trial window."""
        f = np.asarray(fixed, dtype=np.float64)
        lagged = np.concatenate([first_order_lag(t, x, tau_s) for t, x in self.records])
        d = lagged[self.gather] - self.t_ref_c if self.records else np.zeros(0)
        out = []
        for kind, k, multiplier in columns:
            if kind == "fixed":
                out.append(f[:, k])
                continue
            if kind == "lag":
                values = d.copy()
                for _ in range(k - 1):
                    values = values * d
            else:
                values = np.exp(-self.elapsed_s / tau_s)
            col = self.window_means(values)
            if multiplier is not None:
                col = col * np.asarray(multiplier, dtype=np.float64)
            out.append(col)
        return np.column_stack(out)[self.rows]

    def score(
        self, fixed: ArrayLike, response: ArrayLike, columns: Sequence[Column], tau_s: float, /
    ) -> float:
        """Held-out weighted squared error of every block of one trial, summed."""
        x = self.design(fixed, columns, tau_s)
        y = np.asarray(response, dtype=np.float64)[self.rows]
        fit = cross_validate(
            x, y, self.window_block[self.rows], self.block_fold, self.window_weight[self.rows]
        )
        return float(np.sum(fit.heldout_rss_per_block))

    def search(
        self,
        fixed: ArrayLike,
        response: ArrayLike,
        columns: Sequence[Column],
        /,
        *,
        range_s: tuple[float, float],
        grid_points: int = 10,
        steps: int = 8,
        tol: float = 5e-3,
    ) -> tuple[float, FloatArray]:
        """Return the best ``tau`` and every trial ``(tau, score)`` in the order tried."""
        cache: dict[float, float] = {}

        def score(tau: float) -> float:
            tau = float(f"{tau:.3g}")
            if tau not in cache:
                cache[tau] = self.score(fixed, response, columns, tau)
            return cache[tau]

        grid = np.linspace(math.log(range_s[0]), math.log(range_s[1]), grid_points)
        vals = [score(math.exp(g)) for g in grid]
        i = int(np.argmin(vals))
        last = grid.size - 1
        a, fa = grid[max(i - 1, 0)], vals[max(i - 1, 0)]
        b, fb = grid[min(i + 1, last)], vals[min(i + 1, last)]
        x, fx = grid[i], vals[i]
        golden = (3 - math.sqrt(5)) / 2
        for _ in range(steps):
            num = (x - a) ** 2 * (fx - fb) - (x - b) ** 2 * (fx - fa)
            den = (x - a) * (fx - fb) - (x - b) * (fx - fa)
            u = x - 0.5 * num / den if den != 0 else math.nan
            if not (a < u < b) or abs(u - x) < 0.5 * tol:
                u = x + golden * (b - x) if (b - x) > (x - a) else x - golden * (x - a)
            fu = score(math.exp(u))
            moved = abs(u - x)
            if fu < fx:
                if u < x:
                    b, fb = x, fx
                else:
                    a, fa = x, fx
                x, fx = u, fu
            elif u < x:
                a, fa = u, fu
            else:
                b, fb = u, fu
            if moved < tol or b - a < 2 * tol:
                break
        best = min(cache, key=lambda t: cache[t])
        return best, np.array(list(cache.items()), dtype=np.float64).reshape(-1, 2)
