"""The core's median of many values is ``np.median``'s, bit for bit; its sort ``np.sort``'s.

From :data:`accelcore.input.medians._CORE_FROM` values on, ``median_of_finite`` takes
the core's selection (:func:`accelcore._accelcore.median`) over integer keys ordered
like ``f64::total_cmp``; ``nanmedian_columns`` is the core's too. Whatever the values
(ties, signed zeros, infinities, sorted input, NaN), the result must be NumPy's.
"""

from __future__ import annotations

import warnings

import numpy as np
from hypothesis import example, given
from hypothesis import strategies as st
from numpy.typing import NDArray

from accelcore._accelcore import median, sorted_values
from accelcore.input.medians import _CORE_FROM, median_of_finite, nanmedian_columns
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
    n=st.integers(_CORE_FROM, 20 * _CORE_FROM),
    seed=seeds,
    kind=st.sampled_from(_KINDS),
)
def test_the_core_median_is_np_median(n: int, seed: int, kind: str) -> None:
    a = _values(kind, n, seed)
    want = _bits(float(np.median(a)))
    assert _bits(median_of_finite(a.copy())) == want
    assert _bits(median_of_finite(a.copy(), overwrite=True)) == want
    assert _bits(median(a)) == want
    assert _bits(median(a[::-1])) == want  # a strided view: copied, same figure


@given(n=st.integers(0, 3 * _CORE_FROM), seed=seeds, kind=st.sampled_from(_KINDS))
def test_a_nan_or_nothing_gives_nan_without_a_warning(n: int, seed: int, kind: str) -> None:
    a = _values(kind, n, seed)
    if n:
        a[seed % n] = np.nan if seed % 2 else -np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.isnan(median(a))


@given(
    n=st.integers(1, 3 * _CORE_FROM),
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
    assert nanmedian_columns(np.asfortranarray(a)).tobytes() == want.tobytes()


@given(n=st.integers(0, 3 * _CORE_FROM), seed=seeds, kind=st.sampled_from(_KINDS))
def test_the_core_sort_is_np_sort(n: int, seed: int, kind: str) -> None:
    # The diagnosis' knots bisect it: equal to np.sort wherever values compare unequal
    # (the order of -0.0 and 0.0 is NumPy's algorithm's; the core puts -0.0 first).
    a = _values(kind, n, seed)
    if n and seed % 3 == 0:
        a[seed % n] = np.nan
    got = sorted_values(a)
    want = np.sort(a)
    assert np.array_equal(got, want, equal_nan=True)
    finite = got[~np.isnan(got)]
    assert not np.any(np.diff(np.signbit(finite[finite == 0]).astype(int)) > 0)  # -0.0 first
