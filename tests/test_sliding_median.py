"""The Rust sliding median against ``sliding_window_view`` + ``np.median``, bit for bit.

``accelcore.core.sliding_median`` replaced the NumPy window medians of the step
check, so it must give the same numbers exactly: the middle value of an odd
window, and for an even one the mean of the two middle values as ``np.median``
computes it, ``(0.0 + a + b) / 2`` (overflowing where ``a + b`` does, ``+0.0`` for a
zero median).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

import accelcore
from accelcore import reference, simulate
from accelcore.core import sliding_median
from accelcore.input import quality
from strategies import seeds

FloatArray = NDArray[np.float64]

#: Values that collide in windows: repeats, signed zeros, infinities, huge and tiny.
_POOL = np.array([0.0, -0.0, 1.0, -1.0, 2.5, np.inf, -np.inf, 1.5e308, 1e308, 5e-324])


def _series(
    n: int, seed: int, *, nan_fraction: float, pool_fraction: float, quantum: float
) -> FloatArray:
    """Normal values (rounded to multiples of ``quantum`` when it is > 0), some from the pool."""
    rng = np.random.default_rng(seed)
    y = rng.normal(size=n) * 10.0 ** rng.integers(-3, 4)
    if quantum > 0:
        y = np.round(y / quantum) * quantum
    from_pool = rng.random(n) < pool_fraction
    y[from_pool] = rng.choice(_POOL, size=int(from_pool.sum()))
    y[rng.random(n) < nan_fraction] = np.nan
    return y


def assert_bitwise_equal(got: FloatArray, want: FloatArray) -> None:
    """Equal shapes, NaN in the same places, and identical bits elsewhere (0.0 is not -0.0)."""
    np.testing.assert_array_equal(got, want)
    finite = ~np.isnan(want)
    np.testing.assert_array_equal(got[finite].view(np.uint64), want[finite].view(np.uint64))


@given(
    n=st.integers(1, 300),
    window_fraction=st.floats(0.0, 1.0),
    seed=seeds,
    nan_fraction=st.sampled_from([0.0, 0.0, 0.01, 0.1]),
    pool_fraction=st.sampled_from([0.0, 0.3, 1.0]),
    quantum=st.sampled_from([0.0, 0.1, 1.0 / 256]),
)
def test_matches_reference_bitwise(
    n: int,
    window_fraction: float,
    seed: int,
    nan_fraction: float,
    pool_fraction: float,
    quantum: float,
) -> None:
    window = 1 + round(window_fraction * (min(n, 60) - 1))
    y = _series(n, seed, nan_fraction=nan_fraction, pool_fraction=pool_fraction, quantum=quantum)
    with np.errstate(over="ignore", invalid="ignore"):
        want = reference.sliding_median(y, window)
    assert_bitwise_equal(sliding_median(y, window=window), want)


@pytest.mark.parametrize("window", [1, 2, 3, 19, 20, 21, 64, 255, 256])
def test_long_quantised_series_across_the_reference_chunks(window: int) -> None:
    # Decimated output of a quantised sensor: many ties; longer than one chunk of
    # the reference, so its chunk seams are covered too.
    y = _series((1 << 16) + 37, window, nan_fraction=0.0, pool_fraction=0.0, quantum=0.01)
    got = sliding_median(y, window=window)
    assert_bitwise_equal(got, reference.sliding_median(y, window))
    assert got.shape == (y.shape[0] - window + 1,)


def test_reference_is_np_median_of_each_window() -> None:
    y = _series(50, 4, nan_fraction=0.05, pool_fraction=0.3, quantum=0.5)
    for window in (1, 2, 7, 8, 50):
        with np.errstate(over="ignore", invalid="ignore"):
            want = np.array([np.median(y[j : j + window]) for j in range(50 - window + 1)])
            assert_bitwise_equal(reference.sliding_median(y, window), want)
        assert_bitwise_equal(sliding_median(y, window=window), want)


@pytest.mark.parametrize(
    ("y", "window", "want"),
    [
        ([1.0, 9.0, 2.0, 3.0, 8.0], 3, [2.0, 3.0, 3.0]),
        # an even window: the mean of the two middle values
        ([1.0, 9.0, 2.0, 3.0, 8.0], 2, [5.0, 5.5, 2.5, 5.5]),
        ([4.0, -1.0, 7.0, 2.0], 4, [3.0]),
        # (a + b) / 2, as np.mean: overflows where a + (b - a) / 2 would not
        ([1e308, 1.5e308], 2, [np.inf]),
        ([5e-324, 5e-324], 2, [5e-324]),
        ([-np.inf, np.inf], 2, [np.nan]),
        ([-np.inf, 3.0, np.inf, np.inf], 2, [-np.inf, np.inf, np.inf]),
    ],
)
def test_explicit_cases(y: list[float], window: int, want: list[float]) -> None:
    assert_bitwise_equal(sliding_median(np.array(y), window=window), np.array(want))
    with np.errstate(over="ignore", invalid="ignore"):
        want_numpy = np.median(sliding_window_view(np.array(y), window), axis=1)
    assert_bitwise_equal(np.array(want), want_numpy)


def test_zero_median_is_positive_zero() -> None:
    for window in (1, 2, 3):
        got = sliding_median(np.array([-0.0, -0.0, -0.0, 0.0]), window=window)
        assert not np.signbit(got).any()


def test_nan_in_a_window_propagates() -> None:
    y = np.array([1.0, 2.0, np.nan, 4.0, 5.0, 6.0])
    np.testing.assert_array_equal(
        np.isnan(sliding_median(y, window=2)), [False, True, True, False, False]
    )


def test_strided_and_integer_input() -> None:
    y = _series(200, 3, nan_fraction=0.0, pool_fraction=0.3, quantum=0.0)
    columns = np.column_stack([y, -y, y])
    assert_bitwise_equal(sliding_median(columns[:, 0], window=10), sliding_median(y, window=10))
    ints = np.arange(20) % 7
    assert_bitwise_equal(
        sliding_median(ints, window=6), reference.sliding_median(ints.astype(float), 6)
    )


@pytest.mark.parametrize(("n", "window"), [(5, 0), (5, -1), (5, 6), (0, 1)])
def test_bad_window_is_a_parameter_error(n: int, window: int) -> None:
    with pytest.raises(accelcore.ParameterError) as info:
        sliding_median(np.ones(n), window=window)
    assert info.value.parameter == "window"
    with pytest.raises(reference.ParameterError):
        reference.sliding_median(np.ones(n), window)


def test_two_dimensional_input_is_a_shape_error() -> None:
    with pytest.raises(accelcore.ShapeError):
        sliding_median(np.ones((4, 2)), window=3)
    with pytest.raises(reference.ShapeError):
        reference.sliding_median(np.ones((4, 2)), 3)


def test_step_check_is_unchanged_with_numpy_window_medians(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A low threshold turns noise into many step findings: each of them, its time,
    # size and z-score, as when the window medians came from np.median.
    simulate.session(tmp_path / "s", "ADXL335", seed=3, duration_h=0.2)
    session = accelcore.load_session(tmp_path / "s")
    got = quality.check_session(session, warn=False, step_z=1.5, step_window=6)
    monkeypatch.setattr(
        quality, "sliding_median", lambda y, *, window: reference.sliding_median(y, window)
    )
    want = quality.check_session(session, warn=False, step_z=1.5, step_window=6)
    assert len([i for i in want if i.kind == "step"]) > 10
    assert got == want
