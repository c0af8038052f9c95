"""The levels a run's block means sit on: the samples a block holds, and a quantiser's grid.

A quantiser puts the mean of ``k`` samples on a grid of its step / ``k``. Where that
grid is at least the blocks' noise (a 10- or 12-bit ADC on a quiet part, a digital
sensor at several mg per LSB), the output holds one code for whole blocks, at its
extremes as everywhere else: :mod:`accelcore.input.quality` tells such codes from a
rail and from spikes by these figures.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from accelcore._accelcore import typical_count as core_typical_count

__all__ = ["level_grid", "quantiser_sigma", "typical_count"]


def typical_count(count: NDArray[np.int64]) -> int:
    """Return the samples most blocks of a run hold (a full block; 1 for a log kept whole).

    The most common count, not the largest: a run's full blocks do not depend on where
    a file cut it, nor on a block that timing jitter gave one sample more. The core's
    rule, which the spike screen's block noise scales by (:func:`block_noise`).
    """
    return core_typical_count(count)


def level_grid(y: NDArray[np.float64], count: NDArray[np.int64]) -> float | None:
    """Return the least positive difference between the distinct means of the full blocks.

    On data that are not quantised the grid is as fine as float rounding (steps below
    1e-9 of the values' median size are rounding; a wild value does not set that
    size). ``None`` when the full blocks hold one value.
    """
    levels = np.unique(y[count == typical_count(count)])
    if levels.size < 2:
        return None
    steps = np.diff(levels)
    steps = steps[steps > 1e-9 * max(1.0, float(np.median(np.abs(levels))))]
    return float(steps.min()) if steps.size else 0.0


def quantiser_sigma(grid: float, count: NDArray[np.int64]) -> float:
    """Return a quantiser's own noise, step/sqrt(12) (step: the grid times a block's samples)."""
    return grid * typical_count(count) / math.sqrt(12.0)
