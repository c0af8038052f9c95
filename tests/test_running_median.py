"""The Rust running median against its NumPy reference, bit for bit.

``accelcore.core.running_median`` replaced ``sliding_window_view`` + ``np.median``
in the data-quality checks, so it must give the same numbers exactly: the median
of an odd window is one of its values, and a zero median is ``+0.0`` as in
``np.median``. Padding follows ``np.pad``: ``"reflect"`` when ``n > window // 2``,
``"edge"`` otherwise.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.typing import NDArray

import accelcore
from accelcore import reference
from accelcore._accelcore import block_noise
from accelcore.core import running_median
from accelcore.input.medians import median_of_finite
from accelcore.input.quality import _robust_sigma, _running_median
from strategies import seeds

FloatArray = NDArray[np.float64]

#: Values that collide in windows: repeats, signed zeros and infinities.
_POOL = np.array([0.0, -0.0, 1.0, -1.0, 2.5, np.inf, -np.inf])


def _series(n: int, seed: int, nan_fraction: float, pool_fraction: float) -> FloatArray:
    rng = np.random.default_rng(seed)
    y = rng.normal(size=n) * 10.0 ** rng.integers(-3, 4)
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
    n=st.integers(0, 300),
    window=st.integers(1, 25),
    seed=seeds,
    nan_fraction=st.sampled_from([0.0, 0.0, 0.01, 0.1]),
    pool_fraction=st.sampled_from([0.0, 0.3, 1.0]),
)
def test_matches_reference_bitwise(
    n: int, window: int, seed: int, nan_fraction: float, pool_fraction: float
) -> None:
    y = _series(n, seed, nan_fraction, pool_fraction)
    assert_bitwise_equal(running_median(y, window=window), reference.running_median(y, window))


@pytest.mark.parametrize("n", [1000, 1001])
def test_every_network_window_on_a_long_series(n: int) -> None:
    # Windows up to 15 go through a selection network, 8 outputs at a time; wider
    # ones through a sorted window. Many blocks, odd and even lengths, NaN and ties.
    y = _series(n, n, 0.01, 0.3)
    for window in range(1, 19):
        assert_bitwise_equal(running_median(y, window=window), reference.running_median(y, window))


@given(
    n=st.integers(1, 12),
    extra=st.integers(0, 30),
    seed=seeds,
    pool_fraction=st.sampled_from([0.0, 0.5, 1.0]),
)
def test_window_wider_than_series_matches_edge_padding(
    n: int, extra: int, seed: int, pool_fraction: float
) -> None:
    # n <= window // 2: np.pad(mode="edge"), every window holds the whole series.
    window = 2 * n + extra
    y = _series(n, seed, 0.0, pool_fraction)
    assert_bitwise_equal(running_median(y, window=window), reference.running_median(y, window))


@pytest.mark.parametrize(
    ("y", "window", "want"),
    [
        # reflect: padded [2, 1, 2, 9, 0, 9], the end values are not repeated
        ([1.0, 2.0, 9.0, 0.0], 3, [2.0, 2.0, 2.0, 9.0]),
        # an even window is the next odd one
        ([1.0, 2.0, 9.0, 0.0], 2, [2.0, 2.0, 2.0, 9.0]),
        # edge (n = 3 <= half = 3): padded [1, 1, 1, 1, 7, 2, 2, 2, 2]
        ([1.0, 7.0, 2.0], 7, [1.0, 2.0, 2.0]),
        ([4.0], 9, [4.0]),
        # n = half + 1: the last n for which reflection applies
        ([3.0, 1.0, 2.0], 5, [2.0, 1.0, 2.0]),
        ([5.0, -1.0, 3.0], 1, [5.0, -1.0, 3.0]),
    ],
)
def test_explicit_cases(y: list[float], window: int, want: list[float]) -> None:
    assert_bitwise_equal(running_median(np.array(y), window=window), np.array(want))
    assert_bitwise_equal(reference.running_median(np.array(y), window), np.array(want))


def test_nan_in_a_window_propagates() -> None:
    y = np.array([1.0, 2.0, np.nan, 4.0, 5.0, 6.0, 7.0])
    got = running_median(y, window=3)
    np.testing.assert_array_equal(np.isnan(got), [False, True, True, True, False, False, False])
    assert np.isnan(running_median(np.array([1.0, np.nan]), window=9)).all()


def test_zero_median_is_positive_zero() -> None:
    got = running_median(np.array([-0.0, -0.0, -0.0]), window=3)
    assert not np.signbit(got).any()


def test_empty_input_gives_empty_output() -> None:
    for window in (1, 9, 1000):
        assert running_median(np.empty(0), window=window).shape == (0,)
        assert reference.running_median(np.empty(0), window).shape == (0,)


def test_strided_and_integer_input() -> None:
    y = _series(200, 3, 0.0, 0.3)
    columns = np.column_stack([y, -y, y])
    assert_bitwise_equal(running_median(columns[:, 0], window=9), running_median(y, window=9))
    ints = np.arange(20) % 7
    assert_bitwise_equal(
        running_median(ints, window=5), reference.running_median(ints.astype(float), 5)
    )


@pytest.mark.parametrize("window", [0, -1])
def test_bad_window_is_a_parameter_error(window: int) -> None:
    with pytest.raises(accelcore.ParameterError) as info:
        running_median(np.ones(5), window=window)
    assert info.value.parameter == "window"
    with pytest.raises(reference.ParameterError):
        reference.running_median(np.ones(5), window)


def test_two_dimensional_input_is_a_shape_error() -> None:
    with pytest.raises(accelcore.ShapeError):
        running_median(np.ones((4, 2)), window=3)


def test_quality_checks_use_the_kernel() -> None:
    y = _series(1000, 5, 0.0, 0.2)
    assert_bitwise_equal(_running_median(y, 9), reference.running_median(y, 9))


@given(n=st.integers(1, 200), seed=seeds, pool_fraction=st.sampled_from([0.0, 0.5, 1.0]))
def test_median_of_finite_is_np_median(n: int, seed: int, pool_fraction: float) -> None:
    a = _series(n, seed, 0.0, pool_fraction)
    a = a[np.isfinite(a)]
    for values in (a, np.abs(a)):
        if values.size:
            want = np.array([np.median(values)])
            assert_bitwise_equal(np.array([median_of_finite(values)]), want)


@given(
    n=st.integers(1, 200),
    seed=seeds,
    pool_fraction=st.sampled_from([0.0, 0.5, 0.9, 1.0]),
    guess_from=st.sampled_from(["zero", "value", "other"]),
)
def test_median_of_finite_with_a_guess_is_np_median(
    n: int, seed: int, pool_fraction: float, guess_from: str
) -> None:
    # A guess that is the median skips the partition; any other guess must not matter.
    a = _series(n, seed, 0.0, pool_fraction)
    a = a[np.isfinite(a)]
    if a.size == 0:
        return
    guess = {"zero": 0.0, "value": float(a[seed % a.size]), "other": 0.123456789}[guess_from]
    want = np.array([np.median(a)])
    assert_bitwise_equal(np.array([median_of_finite(a, guess=guess)]), want)
    assert_bitwise_equal(np.array([median_of_finite(a.copy(), overwrite=True)]), want)


def _former_robust_sigma(r: FloatArray) -> float:
    """The implementation before the fast paths, with np.median throughout."""
    r = r[np.isfinite(r)]
    if r.size == 0:
        return 0.0
    deviation = np.abs(r - np.median(r))
    sigma = 1.4826 * float(np.median(deviation))
    if sigma == 0.0:
        sigma = math.sqrt(math.pi / 2) * float(np.mean(deviation))
    return sigma


@given(
    n=st.integers(0, 300),
    seed=seeds,
    nan_fraction=st.sampled_from([0.0, 0.0, 0.1]),
    zero_fraction=st.sampled_from([0.0, 0.2, 0.6, 0.95]),
)
def test_robust_sigma_matches_the_former_implementation(
    n: int, seed: int, nan_fraction: float, zero_fraction: float
) -> None:
    # Exact zeros make 0 the median (the counting path) or the MAD 0 (the fallback).
    r = _series(n, seed, nan_fraction, 0.2)
    r[np.random.default_rng(seed + 1).random(n) < zero_fraction] = 0.0
    got, want = np.array([_robust_sigma(r)]), np.array([_former_robust_sigma(r)])
    assert_bitwise_equal(got, want)


def test_robust_sigma_is_unchanged() -> None:
    # The former implementation, with np.median throughout.
    rng = np.random.default_rng(7)
    for r in (rng.normal(size=1001), rng.normal(size=1000), np.round(rng.normal(size=50))):
        r[::97] = np.nan
        finite = r[np.isfinite(r)]
        want = 1.4826 * float(np.median(np.abs(finite - np.median(finite))))
        assert _robust_sigma(r) == want
    constant = np.array([1.0, 1.0, 1.0, 5.0])
    assert _robust_sigma(constant) == np.sqrt(np.pi / 2) * float(np.mean(np.abs(constant - 1.0)))


def _numpy_block_noise(y: FloatArray, count: np.ndarray, window: int) -> tuple[FloatArray, float]:
    """The spike screen's block noise in NumPy (the reference's running median)."""
    typical = int(np.bincount(count).argmax()) if count.size else 1
    with np.errstate(invalid="ignore"):  # inf - inf: NaN, as in the core
        resid = (y - reference.running_median(y, window)) * np.sqrt(count / typical)
    return resid, _former_robust_sigma(resid)


@given(
    n=st.integers(1, 3000),
    seed=seeds,
    window=st.sampled_from([1, 3, 9, 20]),
    short_fraction=st.sampled_from([0.0, 0.01, 0.3]),
    nan_fraction=st.sampled_from([0.0, 0.0, 0.05]),
)
def test_block_noise_is_the_numpy_twin(
    n: int, seed: int, window: int, short_fraction: float, nan_fraction: float
) -> None:
    # Partial blocks (gap edges) are scaled to a full block; NaN blocks stay NaN.
    rng = np.random.default_rng(seed)
    y = _series(n, seed, nan_fraction, 0.2)
    count = np.where(rng.random(n) < short_fraction, rng.integers(1, 10, n), 10).astype(np.int64)
    got_r, got_s = block_noise(y, count, window=window)
    want_r, want_s = _numpy_block_noise(y, count, window)
    assert_bitwise_equal(got_r, want_r)
    assert_bitwise_equal(np.array([got_s]), np.array([want_s]))
