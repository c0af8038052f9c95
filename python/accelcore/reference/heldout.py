"""Held-out least squares, written plainly: refit the rows of every other fold.

The specification of :class:`accelcore.core.BlockedLeastSquares`: samples belong to
blocks, blocks to folds; each fold is predicted by the weighted least-squares fit
on the rows of all other folds, and each block's held-out error is the weighted
sum of squares of its rows under that fit. Columns a training set cannot
identify are held at zero: a column is dropped when the part of it orthogonal to
the columns before it (that are kept) is at most ``1e-10`` of its norm, the rank
test of the core's QR. This module refits rows with NumPy; it never calls the core.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["HeldOut", "cross_validate"]

FloatArray = NDArray[np.float64]
RANK_TOLERANCE = 1e-10


@dataclass(frozen=True)
class HeldOut:
    """What :func:`cross_validate` returns (the fields of the core's ``HeldOutFit``)."""

    coefficients: FloatArray
    not_identified: list[int]
    in_sample_rss: float
    fold_coefficients: FloatArray
    heldout_rss_per_block: FloatArray


def _identifiable_fit(x: FloatArray, y: FloatArray) -> tuple[FloatArray, list[int]]:
    """Least squares of already-weighted rows, dependent columns held at zero."""
    p = x.shape[1]
    keep: list[int] = []
    for j in range(p):
        col = x[:, j]
        norm = float(np.linalg.norm(col))
        if norm == 0.0:
            continue
        if keep:
            basis = x[:, keep]
            coef, *_ = np.linalg.lstsq(basis, col, rcond=None)
            resid = float(np.linalg.norm(col - basis @ coef))
        else:
            resid = norm
        if resid > RANK_TOLERANCE * norm:
            keep.append(j)
    beta = np.zeros(p)
    if keep:
        sol, *_ = np.linalg.lstsq(x[:, keep], y, rcond=None)
        beta[keep] = sol
    return beta, [j for j in range(p) if j not in keep]


def cross_validate(
    design: ArrayLike,
    response: ArrayLike,
    block: ArrayLike,
    block_fold: ArrayLike,
    weights: ArrayLike | None = None,
) -> HeldOut:
    """Fit without each fold, score each block held out, by refitting rows.

    Parameters
    ----------
    design : array_like, shape (n, p)
    response : array_like, shape (n,)
    block : array_like of int, shape (n,)
        Block of each row.
    block_fold : array_like of int, shape (n_blocks,)
        Fold of each block.
    weights : array_like, shape (n,), optional
        Non-negative row weights (default 1).

    Returns
    -------
    HeldOut
    """
    x = np.asarray(design, dtype=np.float64)
    y = np.asarray(response, dtype=np.float64)
    blk = np.asarray(block, dtype=np.int64)
    fold_of_block = np.asarray(block_fold, dtype=np.int64)
    w = np.ones(y.size) if weights is None else np.asarray(weights, dtype=np.float64)
    sw = np.sqrt(w)
    xw, yw = x * sw[:, None], y * sw
    row_fold = fold_of_block[blk]
    n_folds = int(fold_of_block.max()) + 1 if fold_of_block.size else 0
    beta, dropped = _identifiable_fit(xw, yw)
    in_sample = float(np.sum((yw - xw @ beta) ** 2))
    folds = np.full((n_folds, x.shape[1]), np.nan)
    heldout = np.zeros(fold_of_block.size)
    for k in range(n_folds):
        test = row_fold == k
        if not np.any(test & (w > 0)):
            continue
        train = ~test
        folds[k] = _identifiable_fit(xw[train], yw[train])[0] if np.any(train) else 0.0
        err = (yw - xw @ folds[k]) ** 2
        np.add.at(heldout, blk[test], err[test])
    return HeldOut(beta, dropped, in_sample, folds, heldout)
