"""TemperatureBinner: Rust kernel vs the NumPy reference, invariances, and named cases."""

from __future__ import annotations

import itertools
from fractions import Fraction
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import accelcore
from accelcore import reference
from accelcore.core import TemperatureBinner
from helpers import assert_bins_match, same_outcome
from strategies import BinnerCase, FloatArray, Stream, binner_cases, chunks, pieces

Kernel = Any  # accelcore.core.TemperatureBinner or reference.TemperatureBinner


def push_chunks(kernel: Kernel, stream: Stream, bounds: list[int]) -> Kernel:
    """Push ``stream`` cut at ``bounds``; return the kernel."""
    for time_s, temperature_c, channels in chunks(bounds, *stream.arrays()):
        kernel.push(time_s, temperature_c, channels)
    return kernel


def assert_match(rust: Any, expected: Any, stream: Stream) -> None:
    assert_bins_match(rust, expected, stream.channels, stream.time_s, stream.temperature_c)


def one_channel(temperature_c: list[float], values: list[float] | None = None) -> Stream:
    t = np.array(temperature_c, dtype=np.float64)
    v = np.zeros(t.size) if values is None else np.array(values, dtype=np.float64)
    return Stream(np.arange(t.size, dtype=np.float64), t, v[:, None])


# --------------------------------------------------------------------------- properties


@given(binner_cases())
def test_matches_reference(case: BinnerCase) -> None:
    rust = push_chunks(TemperatureBinner(**case.config), case.stream, case.bounds)
    expected = push_chunks(reference.TemperatureBinner(**case.config), case.stream, case.bounds)
    outcome = same_outcome(rust.finish, expected.finish)
    if outcome is not None:
        assert_match(*outcome, case.stream)


@given(binner_cases())
def test_chunking_invariance(case: BinnerCase) -> None:
    chunked = push_chunks(TemperatureBinner(**case.config), case.stream, case.bounds)
    whole = push_chunks(TemperatureBinner(**case.config), case.stream, [0, case.stream.n])
    outcome = same_outcome(chunked.finish, whole.finish)  # the same error, if any
    if outcome is not None:
        assert_match(*outcome, case.stream)


@given(binner_cases(), st.data())
def test_merge_equals_one_pass(case: BinnerCase, data: st.DataObject) -> None:
    cuts = data.draw(pieces(case.stream.n))
    parts = []
    for start, stop in itertools.pairwise(cuts):
        piece = Stream(*(a[start:stop] for a in case.stream.arrays()))
        parts.append(push_chunks(TemperatureBinner(**case.config), piece, [0, piece.n]))
    # Bins do not care about time order: merge in a random order.
    order = data.draw(st.permutations(range(len(parts))))
    merged = parts[order[0]]
    for i in order[1:]:
        merged.merge(parts[i])
    one_pass = push_chunks(reference.TemperatureBinner(**case.config), case.stream, case.bounds)
    outcome = same_outcome(merged.finish, one_pass.finish)
    if outcome is not None:
        assert_match(*outcome, case.stream)


@given(binner_cases(), st.data())
def test_merge_associative(case: BinnerCase, data: st.DataObject) -> None:
    n = case.stream.n
    i, j = sorted(data.draw(st.lists(st.integers(0, n), min_size=2, max_size=2)))

    def three() -> list[Kernel]:
        out = []
        for start, stop in ((0, i), (i, j), (j, n)):
            piece = Stream(*(a[start:stop] for a in case.stream.arrays()))
            out.append(push_chunks(TemperatureBinner(**case.config), piece, [0, piece.n]))
        return out

    a, b, c = three()
    a.merge(b)
    a.merge(c)
    a2, b2, c2 = three()
    b2.merge(c2)
    a2.merge(b2)
    outcome = same_outcome(a.finish, a2.finish)
    if outcome is not None:
        assert_match(*outcome, case.stream)


# --------------------------------------------------------------------------- named cases


def test_bin_closure_is_lo_inclusive_hi_exclusive() -> None:
    # Window [0, 2) in 0.5 °C bins; 0.5 and 1.0 are exact binary fractions,
    # so a temperature equal to an inner edge belongs to the bin above it.
    lo, hi = 0.0, 2.0
    temperatures = [
        lo,  # bin 0
        np.nextafter(lo, -np.inf),  # below
        0.5,  # bin 1 (inner edge -> upper bin)
        np.nextafter(0.5, -np.inf),  # bin 0
        1.0,  # bin 2
        np.nextafter(hi, -np.inf),  # bin 3 (last)
        hi,  # above (hi is excluded)
        np.nextafter(hi, np.inf),  # above
        -5.0,  # below
    ]
    stream = one_channel(temperatures)
    binner = push_chunks(
        TemperatureBinner(lo_c=lo, hi_c=hi, width_c=0.5, n_channels=1), stream, [0, stream.n]
    )
    out = binner.finish()
    np.testing.assert_array_equal(out.count, [2, 1, 1, 1])
    assert (out.n_below, out.n_above, out.n_nonfinite) == (2, 2, 0)
    expected = push_chunks(
        reference.TemperatureBinner(lo_c=lo, hi_c=hi, width_c=0.5, n_channels=1),
        stream,
        [0, stream.n],
    ).finish()
    assert_match(out, expected, stream)


@pytest.mark.parametrize(
    ("lo", "hi", "width", "n_bins"),
    [
        (0.0, 60.0, 0.5, 120),
        (0.0, 1.0, 0.3, 4),  # last bin [0.9, 1.0) is narrower
        (0.0, 0.3, 0.1, 3),  # 0.3 / 0.1 = 2.9999999999999996 -> 3
        (0.0, 2.1, 0.7, 3),  # 2.1 / 0.7 = 3.0000000000000004 -> 3, thanks to the 1e-9 slack
        (-40.0, 125.0, 5.0, 33),
    ],
)
def test_bin_count_and_edges(lo: float, hi: float, width: float, n_bins: int) -> None:
    stream = one_channel([lo])
    out = push_chunks(
        TemperatureBinner(lo_c=lo, hi_c=hi, width_c=width, n_channels=1), stream, [0, 1]
    ).finish()
    edges = lo + np.arange(n_bins + 1) * width
    edges[-1] = hi
    # The edges are defined by this formula, so they must match bit for bit.
    np.testing.assert_array_equal(out.edges_c, edges)
    assert np.shape(out.count) == (n_bins,)
    assert np.shape(out.mean) == (n_bins, 1)


def test_temperature_in_last_sliver_clamps_to_last_bin() -> None:
    # 3 bins of 0.3 in [0, 0.9); the float just below 0.9 is 0.8999999999999999,
    # and 0.8999999999999999 / 0.3 rounds to 3.0: bin 3 is clamped to bin 2.
    t = np.nextafter(0.9, -np.inf)
    assert np.floor(t / 0.3) == 3
    stream = one_channel([t])
    out = push_chunks(
        TemperatureBinner(lo_c=0.0, hi_c=0.9, width_c=0.3, n_channels=1), stream, [0, 1]
    ).finish()
    np.testing.assert_array_equal(out.count, [0, 0, 1])


def test_nan_policy() -> None:
    # Any non-finite value skips the row and counts it in n_nonfinite only
    # (an infinite temperature is not "above").
    time_s = np.array([0.0, 1.0, np.nan, 3.0, 4.0, 5.0, 6.0])
    temperature_c = np.array([1.0, np.inf, 1.0, -np.inf, np.nan, 1.2, 1.4])
    channels = np.array([[1.0], [1.0], [1.0], [1.0], [1.0], [np.nan], [3.0]])
    binner = TemperatureBinner(lo_c=0.0, hi_c=2.0, width_c=1.0, n_channels=1)
    binner.push(time_s, temperature_c, channels)
    out = binner.finish()
    assert (out.n_nonfinite, out.n_below, out.n_above) == (5, 0, 0)
    np.testing.assert_array_equal(out.count, [0, 2])
    # Means of two finite values: exact up to one rounding.
    np.testing.assert_allclose(out.mean[1], [2.0], rtol=2e-16)
    np.testing.assert_allclose(out.time_s[1], 3.0, rtol=2e-16)
    np.testing.assert_allclose(out.temperature_c[1], 1.2, rtol=2e-16)


def test_empty_and_sparse_bins_are_nan() -> None:
    stream = one_channel([0.2, 1.2, 1.7], [5.0, 1.0, 3.0])
    out = push_chunks(
        TemperatureBinner(lo_c=0.0, hi_c=3.0, width_c=1.0, n_channels=1), stream, [0, 3]
    ).finish()
    np.testing.assert_array_equal(out.count, [1, 2, 0])
    # Mean NaN only where the bin is empty; variance NaN where count < 2.
    np.testing.assert_array_equal(np.isnan(out.mean[:, 0]), [False, False, True])
    np.testing.assert_array_equal(np.isnan(out.variance[:, 0]), [True, False, True])
    np.testing.assert_array_equal(np.isnan(out.time_s), [False, False, True])
    np.testing.assert_array_equal(np.isnan(out.temperature_c), [False, False, True])
    # ddof = 1: values 1 and 3 have sample variance 2 (exact in binary).
    assert out.variance[1, 0] == 2.0
    assert out.mean[0, 0] == 5.0


@pytest.mark.parametrize("kernel", [TemperatureBinner, reference.TemperatureBinner])
def test_empty_input(kernel: type[Kernel]) -> None:
    binner = kernel(n_channels=2)
    with pytest.raises((accelcore.InsufficientDataError, reference.InsufficientDataError)):
        binner.finish()
    binner.push(np.empty(0), np.empty(0), np.empty((0, 2)))  # an empty chunk is fine
    with pytest.raises((accelcore.InsufficientDataError, reference.InsufficientDataError)):
        binner.finish()


def test_nothing_in_window_is_insufficient() -> None:
    binner = TemperatureBinner(lo_c=0.0, hi_c=1.0, width_c=0.5, n_channels=1)
    binner.push(np.arange(3.0), np.array([-1.0, 1.0, np.nan]), np.zeros((3, 1)))
    with pytest.raises(accelcore.InsufficientDataError):
        binner.finish()


@pytest.mark.parametrize(
    ("n", "spread", "how"),
    [
        # ~16000 LSB with variation at the 1e-6 relative scale (std 0.016 LSB),
        # so mean/std ~ 1e6: the naive sum-of-squares formula loses ~12 digits
        # and misses the variance by ~1e-4 relative here; Welford, a shifted
        # or a two-pass computation keeps it to ~1e-11.
        (5000, 16000 * 1e-6, "one push"),
        (5000, 16000 * 1e-6, "chunks"),
        (5000, 16000 * 1e-6, "merged pieces"),
    ],
)
def test_welford_stability(n: int, spread: float, how: str) -> None:
    rng = np.random.default_rng(20240611)
    values = 16000.0 + spread * rng.standard_normal(n)
    time_s = np.arange(n, dtype=np.float64)
    temperature_c = np.full(n, 25.0)  # all in one bin
    stream = Stream(time_s, temperature_c, values[:, None])
    config: dict[str, Any] = {"lo_c": 20.0, "hi_c": 30.0, "width_c": 10.0, "n_channels": 1}
    if how == "one push":
        binner = push_chunks(TemperatureBinner(**config), stream, [0, n])
    elif how == "chunks":
        binner = push_chunks(TemperatureBinner(**config), stream, [*list(range(0, n, 7)), n])
    else:
        cuts = [0, 1, 1000, 1001, 3333, n]
        binner = TemperatureBinner(**config)
        for start, stop in itertools.pairwise(cuts):
            part = Stream(*(a[start:stop] for a in stream.arrays()))
            binner.merge(push_chunks(TemperatureBinner(**config), part, [0, part.n]))

    # Exact sample variance of the float64 inputs, in rational arithmetic.
    exact = [Fraction(float(v)) for v in values]
    mean = sum(exact, Fraction(0)) / n
    variance = sum(((v - mean) ** 2 for v in exact), Fraction(0)) / (n - 1)

    out = binner.finish()
    assert out.count[0] == n
    relative_error = abs(Fraction(float(out.variance[0, 0])) - variance) / variance
    # The spec's bound: 1e-6 relative. A stable algorithm achieves ~1e-11
    # (eps * mean/std * a small factor), the naive formula ~1e-4.
    assert relative_error < Fraction(1, 10**6), float(relative_error)
    assert abs(Fraction(float(out.mean[0, 0])) - mean) / mean < Fraction(1, 10**12)


def test_merge_rejects_other_config() -> None:
    base: dict[str, Any] = {"lo_c": 0.0, "hi_c": 60.0, "width_c": 0.5, "n_channels": 3}
    changes: list[dict[str, Any]] = [
        {"lo_c": 1.0},
        {"hi_c": 59.0},
        {"width_c": 1.0},
        {"n_channels": 2},
    ]
    for change in changes:
        with pytest.raises(accelcore.IncompatibleError):
            TemperatureBinner(**base).merge(TemperatureBinner(**{**base, **change}))


@pytest.mark.parametrize(
    ("time_s", "temperature_c", "channels"),
    [
        (np.zeros(3), np.zeros(2), np.zeros((3, 2))),
        (np.zeros(2), np.zeros(3), np.zeros((3, 2))),
        (np.zeros(3), np.zeros(3), np.zeros((3, 1))),
        pytest.param(np.zeros(3), np.zeros(3), np.zeros(3), id="channels-1d"),
    ],
)
def test_shape_errors(time_s: FloatArray, temperature_c: FloatArray, channels: FloatArray) -> None:
    with pytest.raises(accelcore.ShapeError):
        TemperatureBinner(n_channels=2).push(time_s, temperature_c, channels)
    with pytest.raises(reference.ShapeError):
        reference.TemperatureBinner(n_channels=2).push(time_s, temperature_c, channels)


@pytest.mark.parametrize(
    "config",
    [
        {"width_c": 0.0},
        {"width_c": -0.5},
        {"width_c": float("nan")},
        {"lo_c": 10.0, "hi_c": 10.0},
        {"lo_c": 10.0, "hi_c": 0.0},
        {"hi_c": float("inf")},
    ],
)
def test_invalid_config(config: dict[str, Any]) -> None:
    with pytest.raises(accelcore.ParameterError):
        TemperatureBinner(**config)
    with pytest.raises(reference.ParameterError):
        reference.TemperatureBinner(**config)
