"""Reference running and sliding medians (twins of ``accelcore-core/src/robust.rs``)."""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import ArrayLike

from accelcore.reference._common import FloatArray, check_int, vector
from accelcore.reference.errors import ParameterError

__all__ = ["running_median", "sliding_median"]

#: Rows of the sliding-window view the medians sort at a time (bounds memory).
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
    check_int("window", window, 1)
    y = vector(y, "y")
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


def sliding_median(y: ArrayLike, window: int) -> FloatArray:
    """Median of every window ``y[j : j + window]``, ``j = 0, ..., len(y) - window``.

    Output ``j`` is ``np.median(y[j : j + window])``: the middle value of an odd
    window, the mean of the two middle values of an even one, NaN where the window
    holds a NaN.

    Parameters
    ----------
    y : array_like, shape (n,)
        The series.
    window : int
        Window length, ``1 <= window <= n``.

    Returns
    -------
    ndarray of float64, shape (n - window + 1,)
        The window medians.

    Raises
    ------
    ParameterError
        ``window`` is not an integer >= 1, or exceeds ``len(y)``.
    ShapeError
        ``y`` is not 1-D.
    """
    check_int("window", window, 1)
    y = vector(y, "y")
    w = int(window)
    if w > y.shape[0]:
        raise ParameterError(f"window must be <= the series length {y.shape[0]}, got {w}")
    out = np.empty(y.shape[0] - w + 1)
    for start in range(0, out.shape[0], _MEDIAN_CHUNK):
        stop = min(start + _MEDIAN_CHUNK, out.shape[0])
        out[start:stop] = np.median(sliding_window_view(y[start : stop + w - 1], w), axis=1)
    return out
