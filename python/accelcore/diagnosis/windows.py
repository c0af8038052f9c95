"""Windows of the engine's fits: consecutive samples of one block, fitted as their means.

A linear model holds for window means exactly: the weighted mean of ``X b + e`` over
a window is ``mean(X) b + mean(e)``. So every held-out fit of the diagnosis runs on
the weighted means of each window's columns and response, each window weighing the
sum of its samples' weights, and the rows a fit visits are 1/k of the samples. What
that leaves out is the variation of the columns *inside* a window, which is why the
windows are chosen from the data (:func:`choose_windows`): as long as the
observables' variation inside them explains nothing of the response, otherwise
shorter, down to one sample.

The response's own variation inside the windows (noise, mostly) is the same for
every model; the engine adds it back to each block's error, so held-out errors keep
their per-sample scale and the paired test its meaning.

Imports: NumPy and the core's least squares only.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from accelcore.core import BlockedLeastSquares

__all__ = [
    "MAX_WINDOW",
    "MIN_WINDOWS_PER_BLOCK",
    "WINDOW_LOSS",
    "Windows",
    "choose_windows",
    "difference_noise",
    "noise_floor",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Most samples averaged into one window.
MAX_WINDOW = 32

#: Largest share of a response's weighted square sum that the observables' variation
#: inside the windows may explain (beyond chance) for the windows to be kept.
WINDOW_LOSS = 1e-3

#: Fewest windows a block is cut into (a block shorter than this many samples is not
#: averaged at all: a static hold of a few seconds keeps every sample).
MIN_WINDOWS_PER_BLOCK = 8


@dataclass(frozen=True)
class Windows:
    """Windows of consecutive samples, never across a block.

    Attributes
    ----------
    sample_window : ndarray of int64, shape (n_samples,)
        Window of each sample (non-decreasing).
    start : ndarray of int64, shape (n,)
        First sample of each window (windows are contiguous and never empty).
    weight : ndarray of float64, shape (n,)
        Sum of the sample weights of each window.
    block : ndarray of int64, shape (n,)
        Block of each window.
    length : int
        Most samples in one window (1: no averaging).
    """

    sample_window: IntArray
    start: IntArray
    weight: FloatArray
    block: IntArray
    w: FloatArray
    length: int

    @property
    def n(self) -> int:
        """Number of windows."""
        return int(self.start.size)

    def compress(self, values: FloatArray) -> FloatArray:
        """Return the weighted mean of ``values`` (one per sample) in every window.

        A window whose weights sum to 0 gets the weighted sum, 0 (it weighs nothing).
        """
        sums = np.add.reduceat(self.w * values, self.start)
        return np.asarray(sums / np.where(self.weight > 0, self.weight, 1.0), dtype=np.float64)


def choose_windows(
    w: FloatArray,
    block_start: IntArray,
    block_stop: IntArray,
    observables: Sequence[FloatArray],
    responses: Sequence[FloatArray],
) -> Windows:
    """Return the longest windows that leave out nothing the observables explain.

    Starting at :data:`MAX_WINDOW` samples (and at most a block's samples over
    :data:`MIN_WINDOWS_PER_BLOCK`), each response's deviations from its window means
    are regressed on the deviations of every finite observable and its square; when
    what they explain, less what ``q`` random columns explain by chance
    (``q * rss / dof``), exceeds :data:`WINDOW_LOSS` of the response's weighted
    square sum, the windows are halved.

    Parameters
    ----------
    w : ndarray, shape (n_samples,)
        Sample weights.
    block_start, block_stop : ndarray of int64
        The blocks (contiguous, covering every sample).
    observables : sequence of ndarray
        What the model's columns are functions of (non-finite ones are skipped).
    responses : sequence of ndarray
        The responses the fits will see.
    """
    n = int(w.size)
    sizes = block_stop - block_start
    sample_block = np.repeat(np.arange(sizes.size), sizes)
    local = np.arange(n) - block_start[sample_block]
    root_w = np.sqrt(w)
    columns = []
    for o in observables:
        if not np.all(np.isfinite(o)):
            continue
        c = o - (np.average(o, weights=w) if w.sum() > 0 else o.mean())
        columns += [c, c * c]
    k = MAX_WINDOW
    while True:
        per_block = np.clip(sizes // MIN_WINDOWS_PER_BLOCK, 1, k)
        counts = -(-sizes // per_block)
        first = np.concatenate([[0], np.cumsum(counts)[:-1]])
        window = (first[sample_block] + local // per_block[sample_block]).astype(np.int64)
        n_win = int(counts.sum())
        weight = np.bincount(window, weights=w, minlength=n_win).astype(np.float64)
        if k == 1 or n_win == n or _explains_nothing(window, weight, w, root_w, columns, responses):
            break
        k //= 2
    return Windows(
        window,
        np.flatnonzero(np.diff(window, prepend=-1)).astype(np.int64),
        weight,
        np.repeat(np.arange(sizes.size), counts).astype(np.int64),
        w,
        k,
    )


def _explains_nothing(
    window: IntArray,
    weight: FloatArray,
    w: FloatArray,
    root_w: FloatArray,
    columns: Sequence[FloatArray],
    responses: Sequence[FloatArray],
) -> bool:
    """Return whether the columns' variation inside the windows explains no response's."""
    if not columns:
        return True
    safe = np.where(weight > 0, weight, 1.0)
    # Windows are contiguous runs of samples: their sums by reduceat, spread back by repeat.
    start = np.flatnonzero(np.diff(window, prepend=-1))
    counts = np.diff(np.append(start, window.size))
    q, r = len(columns), len(responses)
    # Each column's and response's weighted deviation from its window mean, written into
    # one array (columns first), in the column order the core takes.
    dev = np.empty((window.size, q + r), order="F")
    for j, values in enumerate([*columns, *responses]):
        mean = np.add.reduceat(w * values, start) / safe
        np.subtract(values, np.repeat(mean, counts), out=dev[:, j])
        dev[:, j] *= root_w
    live = np.abs(dev[:, :q]).sum(axis=0) > 0
    d = dev[:, :q][:, live]
    if d.shape[1] == 0:
        return True
    dys = dev[:, q:]
    # One factorisation for every response; columns the data cannot tell apart (time
    # inside windows that are themselves linear in time) are held at 0.
    lsq = BlockedLeastSquares(d.shape[1], 1, n_responses=len(responses))
    lsq.push(d, dys, np.zeros(w.size, dtype=np.int64), np.ones(w.size))
    folded = lsq.folds(np.zeros(1, dtype=np.int64))
    for i, y in enumerate(responses):
        total = float((w * y * y).sum())
        if total <= 0:
            continue
        fit = folded.cross_validate(response=i)
        dy = dys[:, i]
        rss = float(fit.in_sample_rss)
        q_used = d.shape[1] - len(fit.not_identified)
        explained = max(float(dy @ dy) - rss, 0.0)
        chance = q_used * rss / max(w.size - weight.size - q_used, 1)
        if explained - chance > WINDOW_LOSS * total:
            return False
    return True


def difference_noise(y: FloatArray, w: FloatArray, block: IntArray) -> float:
    """Return the white noise a weighted sum of squares of ``y`` holds: raw variance x samples.

    A sample of weight ``w`` (a mean of ``w`` raw samples) adds ``w`` times its squared
    error, so white noise adds its raw variance per sample; the difference of two
    neighbouring samples of one block has variance ``raw (1 / w_i + 1 / w_(i-1))``, and
    a smooth signal adds next to nothing to it. Infinity when no two samples of weight
    share a block.
    """
    pair = (block[1:] == block[:-1]) & (w[1:] > 0) & (w[:-1] > 0)
    if not pair.any():
        return math.inf
    d = (y[1:] - y[:-1])[pair]
    inv = 1.0 / w[1:][pair] + 1.0 / w[:-1][pair]
    return float(np.mean(d * d / inv)) * float(np.count_nonzero(w > 0))


def noise_floor(y: FloatArray, w: FloatArray, block: IntArray, within: float) -> float:
    """Return the least weighted squared error any model of ``y`` leaves: its noise.

    ``within`` (the samples' scatter about their window means, in every model's
    held-out error as it is), unless :func:`difference_noise` says the noise is less (a
    model that moves inside windows can explain part of that scatter).
    """
    return min(within, difference_noise(y, w, block))
