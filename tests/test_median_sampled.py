"""The quality checks' median of many values, taken from a sorted sample, is ``np.median``.

From :data:`accelcore.input.medians._SAMPLED_FROM` values on, ``median_of_finite``
selects the middle among the values between two bounds read from a sample, and
falls back to a partition of everything when the sample misplaces the middle;
either way the result must be ``np.median``'s, bit for bit.
"""

from __future__ import annotations

import warnings

import numpy as np
from hypothesis import example, given
from hypothesis import strategies as st
from numpy.typing import NDArray

from accelcore.input.medians import (
    _SAMPLED_FROM,
    _middle_from_sample,
    median_of_finite,
    nanmedian_columns,
)
from strategies import seeds

FloatArray = NDArray[np.float64]
_KINDS = ("normal", "quantised", "sorted", "reversed", "zeros", "infinite", "two_levels")


def _values(kind: str, n: int, seed: int) -> FloatArray:
    rng = np.random.default_rng(seed)
    y = rng.normal(size=n) * 10.0 ** rng.integers(-4, 4)
    if kind == "quantised":  # an ADC's steps with rounding noise: long runs of ties
        y = np.round(np.abs(y) * 3) / 3 + np.round(rng.normal(size=n), 1) * 1e-9
    elif kind == "sorted":
        y.sort()
    elif kind == "reversed":
        y = np.sort(y)[::-1].copy()
    elif kind == "zeros":
        y[rng.random(n) < 0.6] = 0.0
        y[rng.random(n) < 0.2] = -0.0
    elif kind == "infinite":
        y[rng.random(n) < 0.3] = np.inf
        y[rng.random(n) < 0.2] = -np.inf
    elif kind == "two_levels":
        y = np.where(rng.random(n) < 0.5, -1.0, 1.0)
    return y


def _bits(x: float) -> bytes:
    return np.float64(x).tobytes()


@given(
    n=st.integers(_SAMPLED_FROM, 5 * _SAMPLED_FROM),
    seed=seeds,
    kind=st.sampled_from(_KINDS),
)
def test_the_sampled_median_is_np_median(n: int, seed: int, kind: str) -> None:
    a = _values(kind, n, seed)
    want = _bits(float(np.median(a)))
    assert _bits(median_of_finite(a.copy())) == want
    assert _bits(median_of_finite(a.copy(), overwrite=True)) == want
    # The selection itself: the two middle order statistics, or None.
    k = n // 2
    middle = _middle_from_sample(a.copy(), k, n % 2 == 0)
    if middle is not None:
        ordered = np.sort(a)
        want_middle = (float(ordered[k - 1 if n % 2 == 0 else k]), float(ordered[k]))
        assert tuple(float(v) for v in middle) == want_middle


def test_most_data_takes_the_sample() -> None:
    for kind in _KINDS:
        a = _values(kind, 14_400, seed=3)
        assert _middle_from_sample(a, 7200, True) is not None, kind


def test_a_misleading_sample_falls_back_to_the_partition() -> None:
    # Every value the sample sees is large; most values are small.
    n = 20_000
    step = n // 512
    a = np.arange(n, dtype=np.float64) * 1e-6
    a[::step] = 1e3 + np.arange(a[::step].size)
    assert _middle_from_sample(a.copy(), n // 2, True) is None
    assert _bits(median_of_finite(a)) == _bits(float(np.median(a)))


@given(
    n=st.integers(1, 3 * _SAMPLED_FROM),
    seed=seeds,
    kind=st.sampled_from(_KINDS),
    nan_fraction=st.sampled_from([0.0, 0.1, 1.0]),
)
# Found by a draw: the middle of -inf and +inf (NaN) raised NumPy's "invalid" warning.
@example(n=2, seed=1, kind="infinite", nan_fraction=0.0)
def test_the_column_nanmedian_is_np_nanmedian(
    n: int, seed: int, kind: str, nan_fraction: float
) -> None:
    a = np.column_stack([_values(kind, n, seed), _values(kind, n, seed + 1)])
    a[np.random.default_rng(seed).random(n) < nan_fraction, 1] = np.nan
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # NumPy's all-NaN slice warning
        want = np.nanmedian(a, axis=0)
    assert nanmedian_columns(a).tobytes() == want.tobytes()
