"""FusedPipeline: Rust fused pass vs the reference kernels composed, plus invariances.

Tolerances
----------
The fused pass and the composition sum and update the same numbers in a
different order (the first block of a stream is held back for merging and
binned last; the reference bins with two-pass sums, Rust with Welford), so
they agree up to rounding, never bit for bit:

* block and bin means: sums of ``n`` values of magnitude ``scale`` differ by
  at most ``n * eps * scale``; bins here hold at most a few thousand blocks,
  so ``RTOL = 1e-10`` relative to the column's scale has a margin of >10;
* bin variances: an absolute error of ``eps * scale**2`` per term, relative
  to the variance itself, hence ``VAR_RTOL * (variance + scale**2 * 1e-6)``;
* fits: a Givens QR and NumPy's lstsq are both backward stable: the
  coefficients differ by about ``kappa_scaled * eps`` relative to their
  column-scaled magnitude; with ``T - t_ref`` centred, ``kappa_scaled < 10``,
  so ``1e-9`` (relative to the response scale) leaves a margin of >1e5.
"""

from __future__ import annotations

import itertools
import threading
import time
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.typing import NDArray

import accelcore
from accelcore import reference
from accelcore.core import FusedPipeline

FloatArray = NDArray[np.float64]
RTOL = 1e-10
VAR_RTOL = 1e-7
FIT_RTOL = 1e-9
CONFIG: dict[str, Any] = {"lo_c": 0.0, "hi_c": 40.0, "width_c": 2.5}


def make_log(
    n: int, seed: int, nan_fraction: float = 0.0, gaps: int = 0
) -> tuple[FloatArray, FloatArray, FloatArray]:
    rng = np.random.default_rng(seed)
    dt = 0.05 + rng.uniform(-0.002, 0.002, n)
    if gaps:
        dt[rng.integers(0, n, gaps)] += rng.uniform(0.5, 3.0, gaps)
    t = 1000.0 + np.cumsum(dt)
    temp = -10.0 + 60.0 * np.arange(n) / max(n, 1) + rng.normal(0, 0.1, n)
    slope = np.array([0.01, -0.02, 0.003])
    ch = 0.3 * np.arange(3) + (temp[:, None] - 25.0) * slope + rng.normal(0, 0.01, (n, 3))
    if nan_fraction:
        ch[rng.random((n, 3)) < nan_fraction] = np.nan
    return t, temp, ch


def composed(
    t: FloatArray,
    temp: FloatArray,
    ch: FloatArray,
    *,
    min_count: int = 1,
    t_ref_c: float = 25.0,
) -> tuple[reference.BinnedStats, list[reference.LstsqSolution]]:
    """The reference kernels one after the other: what the fused pipeline computes."""
    d = reference.Decimator(min_count=min_count)
    d.push(t, temp, ch)
    blocks = d.finish()
    b = reference.TemperatureBinner(**CONFIG)
    b.push(blocks.time_s, blocks.temperature_c, blocks.channels)
    design = np.column_stack([np.ones(len(blocks.count)), blocks.temperature_c - t_ref_c])
    fits = []
    for j in range(3):
        ls = reference.LeastSquares(2)
        ls.push(design, blocks.channels[:, j], blocks.count.astype(np.float64))
        fits.append(ls.finish())
    return b.finish(), fits


def assert_matches(result: Any, binned: Any, fits: list[Any], scale: float) -> None:
    got = result.binned
    np.testing.assert_array_equal(got.count, binned.count)
    assert (got.n_below, got.n_above, got.n_nonfinite) == (
        binned.n_below,
        binned.n_above,
        binned.n_nonfinite,
    )
    np.testing.assert_allclose(got.time_s, binned.time_s, rtol=RTOL)
    np.testing.assert_allclose(got.temperature_c, binned.temperature_c, rtol=0, atol=RTOL * 60)
    np.testing.assert_allclose(got.mean, binned.mean, rtol=0, atol=RTOL * scale)
    var_tol = VAR_RTOL * (np.nan_to_num(binned.variance) + 1e-6 * scale**2)
    ok = np.isnan(got.variance) == np.isnan(binned.variance)
    assert ok.all()
    diff = np.abs(np.nan_to_num(got.variance) - np.nan_to_num(binned.variance))
    assert (diff <= var_tol).all()
    for f, g in zip(result.fits, fits, strict=True):
        assert f.n_rows == g.n_rows
        np.testing.assert_allclose(
            f.coefficients, g.coefficients, rtol=0, atol=FIT_RTOL * max(scale, 1.0)
        )


@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(200, 6000),
    nan_fraction=st.sampled_from([0.0, 0.01, 0.2]),
    gaps=st.integers(0, 5),
    min_count=st.sampled_from([1, 5]),
    cuts=st.lists(st.integers(0, 6000), max_size=5),
)
def test_matches_reference_composition(
    seed: int, n: int, nan_fraction: float, gaps: int, min_count: int, cuts: list[int]
) -> None:
    t, temp, ch = make_log(n, seed, nan_fraction, gaps)
    p = FusedPipeline(min_count=min_count, **CONFIG)
    bounds = [0, *sorted(min(c, n) for c in cuts), n]
    for lo, hi in itertools.pairwise(bounds):
        p.push(t[lo:hi], temp[lo:hi], ch[lo:hi])
    binned, fits = composed(t, temp, ch, min_count=min_count)
    result = p.finish()
    assert result.n_samples == n
    assert_matches(result, binned, fits, scale=1.0)


@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(400, 6000),
    cuts=st.lists(st.integers(1, 5999), min_size=1, max_size=4, unique=True),
    reverse=st.booleans(),
)
def test_merge_of_pieces_equals_one_pass(seed: int, n: int, cuts: list[int], reverse: bool) -> None:
    t, temp, ch = make_log(n, seed, 0.01)
    t0 = float(t[0])
    whole = FusedPipeline(t0_s=t0, **CONFIG)
    whole.push(t, temp, ch)
    bounds = [0, *sorted(min(c, n) for c in cuts), n]
    pieces = []
    for lo, hi in itertools.pairwise(bounds):
        piece = FusedPipeline(t0_s=t0, **CONFIG)
        piece.push(t[lo:hi], temp[lo:hi], ch[lo:hi])
        pieces.append(piece)
    if reverse:  # the later piece absorbs the earlier one
        merged = pieces[-1]
        for piece in reversed(pieces[:-1]):
            merged.merge(piece)
    else:
        merged = pieces[0]
        for piece in pieces[1:]:
            merged.merge(piece)
    expected = whole.finish()
    got = merged.finish()
    assert (got.n_samples, got.n_blocks, got.n_skipped_nonfinite) == (
        expected.n_samples,
        expected.n_blocks,
        expected.n_skipped_nonfinite,
    )
    assert_matches(got, expected.binned, expected.fits, scale=1.0)


def test_recovers_offset_and_slope() -> None:
    t, temp, ch = make_log(100_000, 1)
    p = FusedPipeline(**CONFIG)
    p.push(t, temp, ch)
    result = p.finish()
    offsets = [f.coefficients[0] for f in result.fits]
    slopes = [f.coefficients[1] for f in result.fits]
    np.testing.assert_allclose(offsets, [0.0, 0.3, 0.6], atol=1e-3)
    np.testing.assert_allclose(slopes, [0.01, -0.02, 0.003], atol=1e-4)
    assert result.fits[0].column_names == ["offset", "slope_per_c"]


def test_nan_rows_are_skipped_and_counted() -> None:
    t, temp, ch = make_log(2000, 2)
    ch[::7, 1] = np.nan
    p = FusedPipeline(**CONFIG)
    p.push(t, temp, ch)
    assert p.n_skipped_nonfinite == len(range(0, 2000, 7))
    assert p.finish().n_skipped_nonfinite == p.n_skipped_nonfinite


def test_empty_input_raises() -> None:
    p = FusedPipeline(**CONFIG)
    p.push(np.empty(0), np.empty(0), np.empty((0, 3)))
    with pytest.raises(accelcore.InsufficientDataError):
        p.finish()


def test_merge_without_shared_t0_is_rejected() -> None:
    t, temp, ch = make_log(3000, 3)
    a, b = FusedPipeline(**CONFIG), FusedPipeline(**CONFIG)
    a.push(t[:1505], temp[:1505], ch[:1505])
    b.push(t[1505:], temp[1505:], ch[1505:])
    with pytest.raises(accelcore.IncompatibleError):
        a.merge(b)


def test_time_order_error() -> None:
    p = FusedPipeline(**CONFIG)
    with pytest.raises(accelcore.TimeOrderError):
        p.push([0.0, 1.0, 0.5], [20.0] * 3, np.zeros((3, 3)))


def test_push_releases_the_gil() -> None:
    # While one thread pushes a large chunk, the main thread keeps running Python.
    t, temp, ch = make_log(2_000_000, 4)
    p = FusedPipeline(**CONFIG)
    ticks = 0
    worker = threading.Thread(target=p.push, args=(t, temp, ch))
    worker.start()
    deadline = time.monotonic() + 30
    while worker.is_alive() and time.monotonic() < deadline:
        ticks += 1
        time.sleep(0)
    worker.join()
    assert ticks > 1
