"""Reference incremental weighted least squares (twin of ``accelcore-core/src/regression.rs``)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from accelcore.reference._common import FloatArray, check_int, matrix, vector
from accelcore.reference.errors import (
    IncompatibleError,
    InsufficientDataError,
    NonFiniteError,
    ParameterError,
    SingularSystemError,
)

__all__ = ["RANK_RTOL", "LeastSquares", "LstsqSolution"]

#: Relative threshold of the rank test: column ``j`` of the weighted design is
#: numerically a combination of earlier columns when the norm of its component
#: orthogonal to them is at most ``RANK_RTOL`` times its own norm.
RANK_RTOL = 1e-10


@dataclass(frozen=True)
class LstsqSolution:
    """Output of :meth:`LeastSquares.finish`.

    Attributes
    ----------
    coefficients : ndarray of float64, shape (p,)
        Minimiser of ``sum(w * (y - X @ beta) ** 2)``.
    covariance : ndarray of float64, shape (p, p)
        ``sigma2 * inv(X' W X)`` with ``sigma2 = residual_sum_squares / dof``;
        all NaN when ``dof == 0``.
    residual_sum_squares : float
        Weighted residual sum of squares.
    dof : int
        ``n_rows - p``.
    n_rows : int
        Rows with non-zero weight.
    condition_number : float
        2-norm condition number of ``sqrt(W) X``.
    condition_number_scaled : float
        2-norm condition number of ``sqrt(W) X`` with each column scaled to
        unit norm.
    column_names : list of str
        Column names.
    """

    coefficients: FloatArray
    covariance: FloatArray
    residual_sum_squares: float
    dof: int
    n_rows: int
    condition_number: float
    condition_number_scaled: float
    column_names: list[str]


def _back_substitute(r: FloatArray, rhs: FloatArray) -> FloatArray:
    """Solve ``r @ x = rhs`` for upper-triangular, non-singular ``r``.

    ``rhs`` may be 1-D or 2-D (one system per column). The loop runs over the
    ``p`` unknowns, never over samples.
    """
    p = r.shape[0]
    x = np.zeros(rhs.shape, dtype=np.float64)
    for i in range(p - 1, -1, -1):
        x[i] = (rhs[i] - r[i, i + 1 :] @ x[i + 1 :]) / r[i, i]
    return x


def _triangular_factor(a: FloatArray) -> FloatArray:
    """Return ``R`` of the QR decomposition of ``a`` (Householder, LAPACK)."""
    # ``mode="r"`` returns the bare array at run time; ``asarray`` only restates its type.
    return np.asarray(np.linalg.qr(a, mode="r"), dtype=np.float64)


def _condition_number(a: FloatArray) -> float:
    """Return the 2-norm condition number of ``a``."""
    singular_values = np.linalg.svd(a, compute_uv=False)
    return float(singular_values[0] / singular_values[-1])


class LeastSquares:
    """Incremental weighted linear least squares.

    Solves ``min_beta sum_i w_i * (y_i - x_i @ beta) ** 2`` over all rows
    pushed (and merged). Each chunk is reduced on arrival to the triangular
    factor of the QR decomposition of ``[sqrt(w) X | sqrt(w) y]`` (Householder,
    via :func:`numpy.linalg.qr`); :meth:`finish` stacks the factors, reduces
    them once more and solves by back substitution.

    Parameters
    ----------
    n_columns : int
        Number of unknowns ``p`` (1 to 64).
    column_names : sequence of str or None, default None
        One name per column; default ``"x0"``, ``"x1"``, ...

    Raises
    ------
    ParameterError
        If ``n_columns`` is out of range, or the names do not match it or repeat.

    Notes
    -----
    Rank test: after the QR decomposition of the weighted design, column
    ``j`` is declared unidentifiable when the norm of its component orthogonal
    to the earlier *identifiable* columns is at most ``1e-10`` times its own
    norm (this includes all-zero columns). The test runs on the ``p x p``
    triangular factor, where both norms are preserved.
    """

    def __init__(self, n_columns: int, *, column_names: Sequence[str] | None = None) -> None:
        check_int("n_columns", n_columns, 1)
        if n_columns > 64:
            raise ParameterError(f"n_columns must be <= 64, got {n_columns}")
        names = [f"x{j}" for j in range(n_columns)] if column_names is None else list(column_names)
        if len(names) != n_columns:
            raise ParameterError(f"{len(names)} column names for {n_columns} columns")
        if len(set(names)) != len(names):
            raise ParameterError(f"column names must be unique, got {names}")
        self.n_columns = int(n_columns)
        self.column_names = names
        self._n_rows = 0
        self._factors: list[FloatArray] = []  # triangular factors of [sqrt(w) X | sqrt(w) y]

    @property
    def n_rows(self) -> int:
        """Rows with non-zero weight pushed so far."""
        return self._n_rows

    def push(
        self,
        design: ArrayLike,
        response: ArrayLike,
        weights: ArrayLike | None = None,
    ) -> None:
        """Add rows.

        Parameters
        ----------
        design : array_like of float64, shape (n, p)
            Design matrix rows.
        response : array_like of float64, shape (n,)
            Responses.
        weights : array_like of float64, shape (n,), optional
            Non-negative weights (default 1). Zero-weight rows are ignored and
            not counted.

        Raises
        ------
        ShapeError
            If the shapes do not match.
        NonFiniteError
            If any value is NaN or infinite (the chunk is rejected).
        ParameterError
            If a weight is negative (the chunk is rejected).
        """
        y = vector(response, "response")
        n = y.shape[0]
        x = matrix(design, "design", n, self.n_columns)
        w = np.ones(n) if weights is None else vector(weights, "weights", n)
        for what, values in (("design", x), ("response", y), ("weights", w)):
            if not np.isfinite(values).all():
                raise NonFiniteError(f"non-finite value in {what}")
        if (w < 0).any():
            raise ParameterError("weights must be >= 0")
        used = w > 0
        if not used.any():
            return
        root_w = np.sqrt(w[used])
        augmented = np.column_stack((x[used] * root_w[:, None], y[used] * root_w))
        self._factors.append(_triangular_factor(augmented))
        self._n_rows += int(np.count_nonzero(used))

    def merge(self, other: LeastSquares) -> None:
        """Absorb the rows of another problem with the same columns.

        Raises
        ------
        IncompatibleError
            If the number or names of the columns differ.
        """
        if (self.n_columns, self.column_names) != (other.n_columns, other.column_names):
            raise IncompatibleError(f"columns differ: {self.column_names} vs {other.column_names}")
        self._factors.extend(other._factors)
        self._n_rows += other._n_rows

    def finish(self) -> LstsqSolution:
        """Solve the problem.

        Returns
        -------
        LstsqSolution

        Raises
        ------
        InsufficientDataError
            If there are no rows or fewer rows than columns.
        SingularSystemError
            If some columns are numerically combinations of earlier ones.
        """
        p = self.n_columns
        if self._n_rows == 0:
            raise InsufficientDataError("no rows with non-zero weight")
        if self._n_rows < p:
            raise InsufficientDataError(f"need {p} rows, have {self._n_rows}")
        factor = _triangular_factor(np.concatenate(self._factors, axis=0))
        r = factor[:p, :p]
        z = factor[:p, p]
        rss = float(factor[p, p] ** 2) if factor.shape[0] > p else 0.0

        column_norm = np.linalg.norm(r, axis=0)
        identifiable: list[int] = []
        singular: list[str] = []
        for j in range(p):
            trial = _triangular_factor(r[:, [*identifiable, j]])
            orthogonal_part = abs(float(trial[len(identifiable), len(identifiable)]))
            if orthogonal_part <= RANK_RTOL * float(column_norm[j]):
                singular.append(self.column_names[j])
            else:
                identifiable.append(j)
        if singular:
            raise SingularSystemError(singular)

        coefficients = _back_substitute(r, z)
        dof = self._n_rows - p
        if dof > 0:
            r_inverse = _back_substitute(r, np.eye(p))
            covariance = (rss / dof) * (r_inverse @ r_inverse.T)
        else:
            covariance = np.full((p, p), np.nan)
        return LstsqSolution(
            coefficients=coefficients,
            covariance=covariance,
            residual_sum_squares=rss,
            dof=dof,
            n_rows=self._n_rows,
            condition_number=_condition_number(r),
            condition_number_scaled=_condition_number(r / column_norm),
            column_names=list(self.column_names),
        )
