"""BlockedLeastSquares (Rust) against the plain refit in accelcore.reference.heldout."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from accelcore.core import BlockedLeastSquares
from accelcore.errors import NonFiniteError, ParameterError, ShapeError
from accelcore.reference.heldout import cross_validate
from strategies import seeds


def _problem(seed: int, n_blocks: int, p: int, rows: int) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    n = n_blocks * rows
    t = rng.uniform(-1.0, 1.0, n)
    x = np.column_stack(
        [np.ones(n)] + [t**k if k % 2 else rng.uniform(-1, 1, n) for k in range(1, p)]
    )
    y = x @ np.arange(1.0, p + 1.0) + 0.05 * rng.standard_normal(n)
    w = rng.uniform(0.5, 2.0, n)
    block = rng.permutation(np.repeat(np.arange(n_blocks), rows))
    return x, y, w, block


@given(
    seed=seeds,
    n_blocks=st.integers(3, 10),
    n_folds=st.integers(2, 4),
    p=st.integers(1, 5),
    cut=st.floats(0.0, 1.0),
)
def test_heldout_errors_equal_refitting_the_rows(
    seed: int, n_blocks: int, n_folds: int, p: int, cut: float
) -> None:
    x, y, w, block = _problem(seed, n_blocks, p, 30)
    block_fold = np.arange(n_blocks) % n_folds
    cv = BlockedLeastSquares(p, n_blocks)
    k = int(cut * y.size)  # two chunks: the cut must not matter
    cv.push(x[:k], y[:k], block[:k], w[:k])
    cv.push(x[k:], y[k:], block[k:], w[k:])
    got = cv.cross_validate(block_fold)
    want = cross_validate(x, y, block, block_fold, w)
    # Designs here have scaled condition numbers below ~10 and <= 300 rows: QR (Rust)
    # and SVD-based lstsq (NumPy) agree to ~1e-12 relative; 1e-9 leaves room for
    # summation order in the per-block sums.
    np.testing.assert_allclose(
        got.heldout_rss_per_block, want.heldout_rss_per_block, rtol=1e-9, atol=1e-15
    )
    np.testing.assert_allclose(got.coefficients, want.coefficients, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(
        got.fold_coefficients, want.fold_coefficients, rtol=1e-10, atol=1e-12
    )
    assert got.in_sample_rss == pytest.approx(want.in_sample_rss, rel=1e-9)
    assert got.heldout_rss == pytest.approx(float(np.sum(want.heldout_rss_per_block)), rel=1e-9)
    assert got.not_identified == want.not_identified == []


@given(
    seed=seeds,
    n_blocks=st.integers(3, 8),
    n_folds=st.integers(2, 4),
    subset=st.lists(st.integers(0, 4), min_size=1, max_size=5, unique=True),
    response=st.integers(0, 2),
)
def test_a_subset_of_a_wide_design_equals_refitting_its_rows(
    seed: int, n_blocks: int, n_folds: int, subset: list[int], response: int
) -> None:
    x, y, w, block = _problem(seed, n_blocks, 5, 30)
    ys = np.column_stack([y, y + x[:, 1] ** 2, y - 3.0 * x[:, 2]])
    block_fold = np.arange(n_blocks) % n_folds
    cv = BlockedLeastSquares(5, n_blocks, n_responses=3)
    cv.push(x, ys, block, w)
    folds = cv.folds(block_fold)
    got = folds.cross_validate(subset, response=response)
    want = cross_validate(x[:, subset], ys[:, response], block, block_fold, w)
    np.testing.assert_allclose(
        got.heldout_rss_per_block, want.heldout_rss_per_block, rtol=1e-9, atol=1e-15
    )
    np.testing.assert_allclose(got.coefficients, want.coefficients, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(
        got.fold_coefficients, want.fold_coefficients, rtol=1e-10, atol=1e-12
    )
    assert got.in_sample_rss == pytest.approx(want.in_sample_rss, rel=1e-9)
    once = cv.cross_validate(block_fold, columns=subset, response=response)
    np.testing.assert_array_equal(once.heldout_rss_per_block, got.heldout_rss_per_block)


def test_subset_queries_refuse_bad_columns_and_responses() -> None:
    x, y, w, block = _problem(2, 3, 3, 20)
    cv = BlockedLeastSquares(3, 3, n_responses=2)
    with pytest.raises(ShapeError):
        cv.push(x, y, block, w)
    cv.push(x, np.column_stack([y, y]), block, w)
    folds = cv.folds([0, 1, 2])
    assert (folds.n_columns, folds.n_folds, cv.n_responses) == (3, 3, 2)
    for bad in ([], [1, 1], [3], [-1]):
        with pytest.raises(ParameterError, match="columns"):
            folds.cross_validate(bad)
    with pytest.raises(ParameterError, match="response"):
        folds.cross_validate([0], response=2)


def test_a_column_missing_from_a_training_fold_is_held_at_zero() -> None:
    # The step column is non-zero only in block 0: the fit without it cannot see it.
    n = 60
    block = np.repeat(np.arange(3), 20)
    x = np.column_stack([np.ones(n), (block == 0).astype(float)])
    y = 2.0 + 3.0 * x[:, 1]
    got = BlockedLeastSquares(2, 3)
    got.push(x, y, block)
    fit = got.cross_validate([0, 1, 2])
    want = cross_validate(x, y, block, [0, 1, 2])
    assert fit.fold_coefficients[0, 1] == want.fold_coefficients[0, 1] == 0.0
    # Block 0 predicted without its step: 20 rows off by exactly 3.
    assert fit.heldout_rss_per_block[0] == pytest.approx(180.0, rel=1e-12)
    np.testing.assert_allclose(fit.heldout_rss_per_block, want.heldout_rss_per_block, atol=1e-12)


def test_duplicate_column_is_reported_not_identified() -> None:
    x, y, w, block = _problem(5, 4, 2, 25)
    xd = np.column_stack([x, x[:, 1]])
    cv = BlockedLeastSquares(3, 4)
    cv.push(xd, y, block, w)
    fit = cv.cross_validate([0, 1, 0, 1])
    assert fit.not_identified == cross_validate(xd, y, block, [0, 1, 0, 1], w).not_identified == [2]
    assert fit.coefficients[2] == 0.0


def test_bad_input_names_what_is_wrong() -> None:
    cv = BlockedLeastSquares(2, 2)
    x = np.ones((4, 2))
    with pytest.raises(ParameterError, match="block"):
        cv.push(x, np.ones(4), [0, 0, 1, 2])
    with pytest.raises(ParameterError, match="block"):
        cv.push(x, np.ones(4), [0, 0, -1, 1])
    with pytest.raises(NonFiniteError, match="response"):
        cv.push(x, np.array([1.0, np.nan, 1.0, 1.0]), [0, 0, 1, 1])
    with pytest.raises(ParameterError, match="weights"):
        cv.push(x, np.ones(4), [0, 0, 1, 1], [1.0, -1.0, 1.0, 1.0])
