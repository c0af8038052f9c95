"""Decimator: Rust kernel vs the NumPy reference, invariances, and named cases."""

from __future__ import annotations

import itertools
import re
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import accelcore
from accelcore import reference
from accelcore.core import Decimator
from helpers import assert_blocks_identical, assert_blocks_match, same_outcome
from strategies import DecimatorCase, FloatArray, Stream, chunks, decimator_cases, pieces

Kernel = Any  # accelcore.core.Decimator or reference.Decimator


def push_chunks(kernel: Kernel, stream: Stream, bounds: list[int]) -> Kernel:
    """Push ``stream`` cut at ``bounds``; return the kernel."""
    for time_s, temperature_c, channels in chunks(bounds, *stream.arrays()):
        kernel.push(time_s, temperature_c, channels)
    return kernel


def first_finite_time(stream: Stream) -> float:
    """The grid origin a one-pass decimator with ``t0_s=None`` would take."""
    finite = stream.time_s[np.isfinite(stream.time_s)]
    return float(finite[0]) if finite.size else 0.0


def make_pieces(case: DecimatorCase, cuts: list[int], t0_s: float) -> list[Kernel]:
    """One Rust decimator per contiguous piece, all on the same grid."""
    config = {**case.config, "t0_s": t0_s}
    out = []
    for start, stop in itertools.pairwise(cuts):
        piece = Stream(*(a[start:stop] for a in case.stream.arrays()))
        out.append(push_chunks(Decimator(**config), piece, [0, piece.n]))
    return out


def finish_or_none(kernel: Kernel) -> Any:
    try:
        return kernel.finish()
    except accelcore.InsufficientDataError:
        return None


def assert_match(rust: Any, expected: Any, stream: Stream) -> None:
    assert_blocks_match(rust, expected, stream.channels, stream.time_s, stream.temperature_c)


def rows(*rows_: tuple[float, ...]) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(time, temperature, channels) arrays from literal rows ``(t, T, c0, c1, ...)``."""
    table = np.array(rows_, dtype=np.float64).reshape(len(rows_), -1)
    return table[:, 0].copy(), table[:, 1].copy(), table[:, 2:].copy()


# --------------------------------------------------------------------------- properties


@given(decimator_cases())
def test_matches_reference(case: DecimatorCase) -> None:
    rust = push_chunks(Decimator(**case.config), case.stream, case.bounds)
    expected = push_chunks(reference.Decimator(**case.config), case.stream, case.bounds)
    assert rust.n_samples == expected.n_samples == case.stream.n
    assert rust.n_skipped_nonfinite == expected.n_skipped_nonfinite
    outcome = same_outcome(rust.finish, expected.finish)
    if outcome is not None:
        assert_match(*outcome, case.stream)
        # finish() leaves the state alone: a second call gives the same answer.
        assert_blocks_identical(rust.finish(), outcome[0])


@given(decimator_cases())
def test_chunking_invariance(case: DecimatorCase) -> None:
    # Sums run in row order whatever the chunking, so results are bit-identical.
    chunked = finish_or_none(push_chunks(Decimator(**case.config), case.stream, case.bounds))
    whole = finish_or_none(push_chunks(Decimator(**case.config), case.stream, [0, case.stream.n]))
    assert (chunked is None) == (whole is None)
    if chunked is not None:
        assert_blocks_identical(chunked, whole)


@given(decimator_cases(), st.data())
def test_merge_equals_one_pass(case: DecimatorCase, data: st.DataObject) -> None:
    # The pieces share the grid origin a one-pass run picks (t0_s=None takes
    # the first finite time), so merging them must reproduce the one pass.
    t0_s = case.config["t0_s"]
    if t0_s is None:
        t0_s = first_finite_time(case.stream)
    cuts = data.draw(pieces(case.stream.n))
    parts = make_pieces(case, cuts, t0_s)
    if data.draw(st.booleans(), label="merge later pieces first"):
        parts.reverse()
    merged = parts[0]
    for part in parts[1:]:
        merged.merge(part)
    one_pass = push_chunks(reference.Decimator(**case.config), case.stream, case.bounds)
    assert merged.n_samples == one_pass.n_samples
    assert merged.n_skipped_nonfinite == one_pass.n_skipped_nonfinite
    outcome = same_outcome(merged.finish, one_pass.finish)
    if outcome is not None:
        assert_match(*outcome, case.stream)


@given(decimator_cases(), st.data())
def test_merge_associative(case: DecimatorCase, data: st.DataObject) -> None:
    t0_s = case.config["t0_s"] if case.config["t0_s"] is not None else 0.0
    n = case.stream.n
    i, j = sorted(data.draw(st.lists(st.integers(0, n), min_size=2, max_size=2)))
    a, b, c = make_pieces(case, [0, i, j, n], t0_s)
    a.merge(b)
    a.merge(c)  # (a + b) + c
    a2, b2, c2 = make_pieces(case, [0, i, j, n], t0_s)
    b2.merge(c2)
    a2.merge(b2)  # a + (b + c)
    left, right = finish_or_none(a), finish_or_none(a2)
    assert (left is None) == (right is None)
    if left is not None:
        # Block sums split across pieces are added in a different order.
        assert_match(left, right, case.stream)


# --------------------------------------------------------------------------- named cases


@pytest.mark.parametrize("kernel", [Decimator, reference.Decimator])
def test_empty_input(kernel: type[Kernel]) -> None:
    decimator = kernel(n_channels=2)
    with pytest.raises((accelcore.InsufficientDataError, reference.InsufficientDataError)):
        decimator.finish()
    decimator.push(np.empty(0), np.empty(0), np.empty((0, 2)))  # an empty chunk is fine
    assert decimator.n_samples == 0
    with pytest.raises((accelcore.InsufficientDataError, reference.InsufficientDataError)):
        decimator.finish()


def test_only_invalid_rows_is_insufficient() -> None:
    decimator = Decimator(n_channels=1)
    decimator.push(*rows((0.0, np.nan, 1.0), (0.05, 20.0, np.inf), (np.nan, 20.0, 1.0)))
    assert decimator.n_samples == 3
    assert decimator.n_skipped_nonfinite == 3
    with pytest.raises(accelcore.InsufficientDataError):
        decimator.finish()


def test_min_count_drops_sparse_blocks_and_may_leave_none() -> None:
    # 20 Hz, factor 10: 0.5 s blocks. Block 0 gets 3 rows, block 1 gets 1.
    data = rows((0.0, 20.0, 1.0), (0.1, 20.0, 2.0), (0.2, 20.0, 3.0), (0.6, 21.0, 4.0))
    decimator = Decimator(n_channels=1, min_count=2)
    decimator.push(*data)
    out = decimator.finish()
    np.testing.assert_array_equal(out.block_index, [0])
    np.testing.assert_array_equal(out.count, [3])
    np.testing.assert_allclose(out.channels, [[2.0]], rtol=1e-15)  # (1 + 2 + 3) / 3, exact
    sparse = Decimator(n_channels=1, min_count=4)
    sparse.push(*data)
    with pytest.raises(accelcore.InsufficientDataError):
        sparse.finish()


def test_nan_policy() -> None:
    # A row is used only if time, temperature and every channel are finite;
    # the others are skipped and counted. A row with a finite time but a NaN
    # elsewhere still fixes t0 and still takes part in the time-order check.
    time_s, temperature_c, channels = rows(
        (10.0, np.nan, 1.0, 1.0),  # invalid, but its time sets t0 = 10
        (10.05, 20.0, 2.0, 4.0),
        (np.nan, 20.0, 99.0, 99.0),  # invalid, time unknown: no order check
        (10.10, 22.0, np.inf, 0.0),  # invalid
        (10.15, 24.0, 4.0, 8.0),
        (10.55, -np.inf, 0.0, 0.0),  # invalid
        (10.60, 30.0, 6.0, 6.0),
    )
    decimator = Decimator(n_channels=2)
    decimator.push(time_s, temperature_c, channels)
    assert decimator.n_samples == 7
    assert decimator.n_skipped_nonfinite == 4
    out = decimator.finish()
    np.testing.assert_array_equal(out.block_index, [0, 1])  # 0.5 s blocks from t0 = 10
    np.testing.assert_array_equal(out.count, [2, 1])
    # Means of two or one finite values: exact up to one rounding.
    np.testing.assert_allclose(out.time_s, [10.1, 10.6], rtol=2e-16)
    np.testing.assert_allclose(out.temperature_c, [22.0, 30.0], rtol=2e-16)
    np.testing.assert_allclose(out.channels, [[3.0, 6.0], [6.0, 6.0]], rtol=2e-16)
    expected = reference.Decimator(n_channels=2)
    expected.push(time_s, temperature_c, channels)
    assert_blocks_match(out, expected.finish(), channels, time_s, temperature_c)


def test_gap_alignment() -> None:
    # Blocks stay on the grid t0 + k * factor / rate across a gap: after 10 s
    # without data the next rows land in block 20, not in a new block 2.
    # Jitter moves a row across a boundary only if it crosses it.
    time_s = np.array([0.0, 0.05, 0.499, 0.501, 10.0, 10.05, 10.52])
    n = time_s.size
    decimator = Decimator(n_channels=1, t0_s=0.0)
    decimator.push(time_s, np.full(n, 25.0), np.arange(n, dtype=np.float64)[:, None])
    out = decimator.finish()
    np.testing.assert_array_equal(out.block_index, [0, 1, 20, 21])
    np.testing.assert_array_equal(out.count, [3, 1, 2, 1])
    np.testing.assert_allclose(out.channels[:, 0], [1.0, 3.0, 4.5, 6.0], rtol=2e-16)


def test_block_index_formula_order() -> None:
    # k = floor((t - t0) * rate_hz / factor), in that order. With rate 20 and
    # factor 3, t = 9 * (3 / 20) = 1.3499999999999999 gives 26.999...96 / 3
    # -> k = 8, while t / (factor / rate) would give exactly 9.
    t = 9 * (3 / 20)
    assert np.floor((t - 0.0) * 20.0 / 3) == 8 and np.floor(t / (3 / 20)) == 9
    decimator = Decimator(factor=3, rate_hz=20.0, n_channels=1, t0_s=0.0)
    decimator.push(np.array([0.0, t]), np.array([20.0, 20.0]), np.array([[0.0], [1.0]]))
    np.testing.assert_array_equal(decimator.finish().block_index, [0, 8])


def test_explicit_t0_allows_negative_blocks() -> None:
    decimator = Decimator(n_channels=1, t0_s=100.0)  # 0.5 s blocks
    decimator.push(np.array([99.2, 99.6, 100.0]), np.full(3, 20.0), np.ones((3, 1)))
    np.testing.assert_array_equal(decimator.finish().block_index, [-2, -1, 0])


@pytest.mark.parametrize(
    ("first", "second", "bad_row"),
    [
        ([0.0, 0.1, 0.05], None, 2),  # backwards inside a chunk
        ([0.0, 0.1, 0.1], None, 2),  # repeated time
        ([0.0, np.nan, 0.1, 0.1], None, 3),  # NaN rows are skipped by the check...
        ([0.0, 0.1], [0.2, 0.1], 3),  # ...and the index is global across pushes
        ([0.0, 0.1], [0.1], 2),
        ([0.0, 0.1], [np.nan, 0.05], 3),
    ],
)
def test_time_going_backwards(first: list[float], second: list[float] | None, bad_row: int) -> None:
    decimator = Decimator(n_channels=1)

    def push(times: list[float]) -> None:
        t = np.array(times)
        decimator.push(t, np.full(t.size, 20.0), np.zeros((t.size, 1)))

    if second is None:
        with pytest.raises(accelcore.TimeOrderError) as info:
            push(first)
    else:
        push(first)
        with pytest.raises(accelcore.TimeOrderError) as info:
            push(second)
    assert isinstance(info.value, accelcore.AccelcoreError)
    assert isinstance(info.value, ValueError)
    assert info.value.index == bad_row  # documented attribute (accelcore.errors)
    # The message names the global row index (as a number of its own, not a
    # digit of one of the times).
    assert re.search(rf"(?<![\d.]){bad_row}(?![\d.])", str(info.value)), str(info.value)


def test_time_order_error_reference_agrees() -> None:
    # The reference carries the index as data; same case as above.
    decimator = reference.Decimator(n_channels=1)
    decimator.push(np.array([0.0, 0.1]), np.full(2, 20.0), np.zeros((2, 1)))
    with pytest.raises(reference.TimeOrderError) as info:
        decimator.push(np.array([np.nan, 0.05]), np.full(2, 20.0), np.zeros((2, 1)))
    assert info.value.index == 3


@pytest.mark.parametrize(
    ("time_s", "temperature_c", "channels"),
    [
        (np.zeros(3), np.zeros(2), np.zeros((3, 2))),  # temperature too short
        (np.zeros(3), np.zeros(3), np.zeros((2, 2))),  # channels too short
        (np.zeros(3), np.zeros(3), np.zeros((3, 3))),  # wrong number of channels
        pytest.param(np.zeros(3), np.zeros(3), np.zeros(3), id="channels-1d"),
        pytest.param(np.zeros(3), np.zeros((3, 1)), np.zeros((3, 2)), id="temperature-2d"),
    ],
)
def test_shape_errors(time_s: FloatArray, temperature_c: FloatArray, channels: FloatArray) -> None:
    time_s = np.arange(time_s.size, dtype=np.float64)
    for kernel, error in (
        (Decimator, accelcore.ShapeError),
        (reference.Decimator, reference.ShapeError),
    ):
        with pytest.raises(error):
            kernel(n_channels=2).push(time_s, temperature_c, channels)


@pytest.mark.parametrize(
    "config",
    [
        {"factor": 0},
        {"rate_hz": 0.0},
        {"rate_hz": -20.0},
        {"rate_hz": float("nan")},
        {"rate_hz": float("inf")},
        {"min_count": 0},
        {"t0_s": float("nan")},
        pytest.param(
            {"factor": -1},
        ),
        pytest.param(
            {"min_count": -1},
        ),
    ],
)
def test_invalid_config(config: dict[str, Any]) -> None:
    with pytest.raises(accelcore.ParameterError):
        Decimator(**config)
    with pytest.raises(reference.ParameterError):
        reference.Decimator(**config)


@pytest.mark.parametrize(
    "other",
    [
        {"factor": 5},
        {"rate_hz": 10.0},
        {"n_channels": 2},
        {"min_count": 2},
    ],
)
def test_merge_rejects_other_config(other: dict[str, Any]) -> None:
    with pytest.raises(accelcore.IncompatibleError):
        Decimator(n_channels=1).merge(Decimator(**{"n_channels": 1, **other}))


def _with_rows(t0_s: float | None, times: list[float]) -> Kernel:
    decimator = Decimator(n_channels=1, t0_s=t0_s)
    t = np.array(times)
    decimator.push(t, np.full(t.size, 20.0), np.zeros((t.size, 1)))
    return decimator


def test_merge_rejects_different_t0() -> None:
    # Without an explicit t0_s each piece anchors its grid at its own first row.
    with pytest.raises(accelcore.IncompatibleError):
        _with_rows(None, [0.0, 0.1]).merge(_with_rows(None, [0.2, 0.3]))
    with pytest.raises(accelcore.IncompatibleError):
        _with_rows(0.0, [0.0]).merge(_with_rows(1.0, [2.0]))


def test_merge_rejects_overlapping_time_ranges() -> None:
    with pytest.raises(accelcore.IncompatibleError):
        _with_rows(0.0, [0.0, 0.2]).merge(_with_rows(0.0, [0.1, 0.3]))
    with pytest.raises(accelcore.IncompatibleError):
        _with_rows(0.0, [0.0, 0.2]).merge(_with_rows(0.0, [0.2, 0.3]))


def test_merge_combines_blocks_of_equal_index() -> None:
    a = _with_rows(0.0, [0.0, 0.1])
    b = _with_rows(0.0, [0.2, 0.7])
    a.merge(b)
    out = a.finish()
    np.testing.assert_array_equal(out.block_index, [0, 1])
    np.testing.assert_array_equal(out.count, [3, 1])
    assert a.n_samples == 4


def test_merge_into_empty_adopts_grid() -> None:
    empty = Decimator(n_channels=1)
    empty.merge(_with_rows(None, [5.0, 5.6]))
    np.testing.assert_array_equal(empty.finish().block_index, [0, 1])


def test_finish_does_not_alter_state() -> None:
    decimator = _with_rows(0.0, [0.0, 0.1])
    first = decimator.finish()
    again = decimator.finish()
    assert_blocks_identical(first, again)
    decimator.push(np.array([0.6]), np.array([20.0]), np.zeros((1, 1)))
    np.testing.assert_array_equal(decimator.finish().count, [2, 1])


def test_rejected_chunk_leaves_state_unchanged() -> None:
    decimator = _with_rows(0.0, [0.0, 0.1])
    with pytest.raises(accelcore.TimeOrderError):
        decimator.push(np.array([0.2, 0.15]), np.full(2, 20.0), np.zeros((2, 1)))
    assert decimator.n_samples == 2
    decimator.push(np.array([0.2, 0.6]), np.full(2, 20.0), np.ones((2, 1)))
    out = decimator.finish()
    np.testing.assert_array_equal(out.count, [3, 1])
    np.testing.assert_array_equal(out.channels[:, 0], [1.0 / 3.0, 1.0])
