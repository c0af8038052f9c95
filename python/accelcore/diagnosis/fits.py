"""Fits of the engine: the coefficients of one axis model, and the test oracle's solve.

:class:`CV` holds the held-out and in-sample error of one axis model;
:class:`Fit` holds the coefficients of the free terms of one axis model, in-sample
and per held-out fold (:meth:`accelcore.diagnosis.engine.Engine.fit`). :func:`_solve`
solves one accumulated problem, holding the columns the data cannot identify at
zero, by pushing the rows again without them (the tests' reference for the engine).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from accelcore.core import HeldOutFit, LeastSquares
from accelcore.errors import SingularSystemError
from accelcore.model import Term

__all__ = ["CV", "Fit", "fold_coefficients"]

FloatArray = NDArray[np.float64]


def fold_coefficients(held: HeldOutFit, n_folds: int) -> tuple[FloatArray, FloatArray]:
    """Return the coefficients of a held-out fit on all data and per fold (one row each).

    A fold without a weighted row leaves every row for training: its row is the fit on
    all data; a fold the core did not report (past its last) is zeros.
    """
    beta_in = np.asarray(held.coefficients, dtype=np.float64)
    beta_fold = np.zeros((n_folds, beta_in.size))
    beta_fold[: held.fold_coefficients.shape[0]] = held.fold_coefficients
    beta_fold[np.isnan(beta_fold).any(axis=1)] = beta_in
    return beta_in, beta_fold


#: Column names of the accumulators: the column's index, so that a rank error maps back.
_NAMES = [str(i) for i in range(64)]


@dataclass
class CV:
    """Cross-validated fit of one axis model."""

    terms: tuple[Term, ...]
    sse_blocks: FloatArray  # held-out weighted SSE per block, mg²
    sse_in: float  # in-sample weighted SSE, mg²
    rms_out: float
    rms_in: float
    #: The held-out error is per sample, the model's moves inside windows counted
    #: (:mod:`accelcore.diagnosis.inside`); else of window means.
    per_sample: bool = False


@dataclass(frozen=True)
class Fit:
    """Coefficients of the free terms of one axis model, in-sample and per held-out fold.

    Attributes
    ----------
    columns : tuple of ndarray, each shape (n,)
        Design column of each free term, one value per sample (not stacked: the
        fitted values are built column by column, see :meth:`fitted`).
    beta_in : ndarray, shape (p,)
        Fit on every sample.
    beta_fold : ndarray, shape (n_folds, p)
        Fit on every fold but the k-th (zeros for an empty fold).
    rss_in : float
        Weighted residual sum of squares of ``beta_in``, mg².
    """

    columns: tuple[FloatArray, ...]
    beta_in: FloatArray
    beta_fold: FloatArray
    rss_in: float

    def fitted(self, beta: FloatArray, start: int = 0, stop: int | None = None) -> FloatArray:
        """Return the design times ``beta`` on the samples ``start:stop``."""
        out: FloatArray | None = None
        for col, b in zip(self.columns, beta, strict=True):
            part = col[start:stop] * b
            if out is None:
                out = part
            else:
                out += part
        if out is None:
            return np.zeros(0)
        return out


def _solve(
    acc: LeastSquares,
    x: FloatArray,
    y: FloatArray,
    w: FloatArray,
    rows: NDArray[np.bool_] | None,
) -> tuple[FloatArray, float]:
    """Coefficients and weighted RSS of an accumulated problem; unidentified columns get zero.

    The core names the columns it cannot identify (``SingularSystemError.columns``);
    they are dropped and the problem's rows (``x[rows]``, every row when ``rows`` is
    None) pushed again over the remaining columns, until the design has full rank.
    On the rows fitted, the fitted values are those of the minimum-norm solution; the
    coefficients differ from it only in how they split among columns that those rows
    cannot tell apart. With no row, fewer rows than columns, or no identifiable
    column, every coefficient is zero.
    """
    p = x.shape[1]
    keep = np.arange(p)
    while acc.n_rows >= keep.size > 0:
        try:
            solution = acc.finish()
        except SingularSystemError as exc:
            drop = {int(c) for c in exc.columns}
            keep = keep[[i for i in range(keep.size) if i not in drop]]
            if keep.size:
                acc = LeastSquares(int(keep.size), column_names=_NAMES[: keep.size])
                if rows is None:
                    acc.push(x[:, keep], y, w)
                else:
                    acc.push(x[np.ix_(rows, keep)], y[rows], w[rows])
            continue
        beta = np.zeros(p)
        beta[keep] = solution.coefficients
        return beta, float(solution.residual_sum_squares)
    rw, ry = (w, y) if rows is None else (w[rows], y[rows])
    return np.zeros(p), float((rw * ry * ry).sum())
