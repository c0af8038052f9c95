"""Exact medians of large arrays, faster than ``np.median`` and bitwise the same.

:func:`median_of_finite` is the median of a 1-D array without NaN: the quality
checks' robust scales, the consistency check's run levels and the diagnosis' run
events take many medians of thousands of values. Long arrays go to the core's
selection (:func:`accelcore._accelcore.median`, the same figures as ``np.median``
bit for bit); short ones stay in NumPy, where a call costs less.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from accelcore._accelcore import median, nanmedian_columns

__all__ = ["median_of_finite", "nanmedian_columns"]


def median_of_finite(
    a: NDArray[np.float64], *, overwrite: bool = False, guess: float | None = None
) -> float:
    """``float(np.median(a))`` of a non-empty 1-D array without NaN, several times faster.

    ``np.median`` partitions at two ranks (the middle and, for its NaN check, the
    last), which NumPy's vectorised selection does not handle; one rank it does. The
    result is bitwise the same: the middle value, or the mean of the two middle
    values, summed from +0.0 as ``np.mean`` does (so a zero median is +0.0). With
    ``overwrite`` the values of ``a`` are reordered in place instead of copied.

    A ``guess`` is tried first, by counting the values below and equal to it: when
    the middle rank(s) fall among the equal ones, the median is the guess and no
    partition is needed (values that compare equal are bitwise equal, or both zero).
    """
    n = a.shape[0]
    k = n // 2
    if guess is not None:
        below = int(np.count_nonzero(a < guess))
        if below <= k - 1 + n % 2 and below + int(np.count_nonzero(a == guess)) > k:
            if n % 2:
                return float(0.0 + guess)
            return float((0.0 + guess + guess) / 2)
    if n >= _CORE_FROM:
        return median(a)
    if overwrite:
        a.partition(k)
        part = a
    else:
        part = np.partition(a, k)
    if n % 2:
        return float(0.0 + part[k])
    # The middle of -inf and +inf is NaN, as NumPy's median says (without its warning).
    with np.errstate(invalid="ignore"):
        return float((0.0 + part[:k].max() + part[k]) / 2)


#: From this many values on, medians come from the core (a call there costs a few
#: microseconds more than NumPy's; its selection takes 2 ns a value against 10).
_CORE_FROM = 256
