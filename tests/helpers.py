"""Helpers shared by the tests: comparisons for the kernel tests, simulated sessions.

Every tolerance used to compare the Rust kernels with the reference lives
here, next to the reasoning that sets it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

import accelcore
from accelcore import reference, simulate
from accelcore.input.session import Session

FloatArray = NDArray[np.float64]
T = TypeVar("T")
U = TypeVar("U")

EPS = float(np.finfo(np.float64).eps)

#: Relative tolerance for block and bin means, applied to the magnitude of the
#: input column (an absolute tolerance of ``MEAN_RTOL * max|x|``). Both sides
#: sum the same values, possibly in a different association order (per-chunk
#: partial sums, merges, Welford updates); each sum of ``n`` terms is then off
#: by at most ``n * eps * max|x|``. Blocks and bins in the property tests hold
#: a few hundred rows at most, so ``2 * n * eps <= 1e-13``: 1e-12 leaves a
#: margin of ten and still catches any wrong row, divisor or grouping.
MEAN_RTOL = 1e-12

#: Safety factor on the backward error of a Householder or Givens QR
#: least-squares solve. The textbook bound is ``c(n, p) * eps`` with
#: ``c(n, p) = O(n p)`` in the worst case and ~``sqrt(n p)`` in practice; the
#: property tests have ``n <= 60``, ``p <= 6`` (``sqrt(n p) < 20``), and the
#: difference of two solvers is up to twice the error of one: 100 covers both.
LSTSQ_SAFETY = 100.0


def column_scale(values: FloatArray) -> float:
    """Largest finite magnitude in ``values`` (1 if there is none)."""
    finite = np.abs(values[np.isfinite(values)])
    return float(finite.max()) if finite.size else 1.0


KernelError = (accelcore.AccelcoreError, reference.ReferenceKernelError)


def same_outcome(first: Callable[[], T], second: Callable[[], U]) -> tuple[T, U] | None:
    """Run both calls; they must both succeed or raise the same kind of error.

    Typically ``first`` is the Rust kernel and ``second`` the reference (or
    another Rust run). Returns both results, or ``None`` when both raised an
    error of the same class name (Rust and reference errors share names).
    Anything else raised (a panic, a ``TypeError``) propagates and fails the
    test, so "never a crash" is checked on every input.
    """
    errors: list[BaseException | None] = []
    results: list[Any] = []
    for call in (first, second):
        try:
            results.append(call())
            errors.append(None)
        except KernelError as error:
            assert isinstance(error, ValueError)
            results.append(None)
            errors.append(error)
    first_error, second_error = errors
    if first_error is not None or second_error is not None:
        assert first_error is not None and second_error is not None, (
            f"only one side raised: {first_error!r} vs {second_error!r}"
        )
        assert type(first_error).__name__ == type(second_error).__name__, (
            f"different errors: {first_error!r} vs {second_error!r}"
        )
        return None
    return results[0], results[1]


def assert_close_scaled(actual: Any, expected: Any, scale: float, what: str) -> None:
    """``|actual - expected| <= MEAN_RTOL * scale`` elementwise, NaNs in the same places."""
    np.testing.assert_allclose(
        np.asarray(actual, dtype=np.float64),
        np.asarray(expected, dtype=np.float64),
        rtol=MEAN_RTOL,
        atol=MEAN_RTOL * scale,
        equal_nan=True,
        err_msg=what,
    )


# --------------------------------------------------------------------------- decimator


def assert_blocks_match(
    rust: Any,
    expected: reference.DecimatedBlocks,
    channels: FloatArray,
    time_s: FloatArray,
    temperature_c: FloatArray,
) -> None:
    """Compare a Rust ``finish()`` result with the reference (see :data:`MEAN_RTOL`)."""
    assert np.asarray(rust.block_index).dtype == np.int64
    assert np.asarray(rust.count).dtype == np.int64
    np.testing.assert_array_equal(rust.block_index, expected.block_index, err_msg="block_index")
    np.testing.assert_array_equal(rust.count, expected.count, err_msg="count")
    assert np.shape(rust.channels) == expected.channels.shape
    assert_close_scaled(rust.time_s, expected.time_s, column_scale(time_s), "time_s")
    assert_close_scaled(
        rust.temperature_c, expected.temperature_c, column_scale(temperature_c), "temperature_c"
    )
    for c in range(channels.shape[1]):
        assert_close_scaled(
            np.asarray(rust.channels)[:, c],
            expected.channels[:, c],
            column_scale(channels[:, c]),
            f"channel {c}",
        )


def assert_blocks_identical(a: Any, b: Any) -> None:
    """Two Rust results are bit-for-bit equal (sums run in row order in both)."""
    for name in ("block_index", "count", "time_s", "temperature_c", "channels"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


# --------------------------------------------------------------------------- binner


def variance_atol(count: Any, scale: float, variance: FloatArray) -> FloatArray:
    """Absolute tolerance for per-bin variances.

    A streaming (Welford / Chan) update computes each deviation ``x - mean``
    against a running mean that is off by up to ``k * eps * scale`` after
    ``k`` updates, so each squared-deviation term is off by about
    ``k * eps * scale * std`` and the variance by ``~ n * eps * scale * std``
    (the two-pass reference is accurate to ``eps * variance``). With ``n`` up
    to a few hundred per bin, ``1e-12 * scale * std`` is a margin of >= 10;
    the ``MEAN_RTOL * variance`` term covers ordinary rounding.
    """
    std = np.sqrt(np.where(np.isfinite(variance), variance, 0.0))
    n = np.maximum(np.asarray(count, dtype=np.float64), 1.0)[:, None]
    return np.maximum(1e-12, 4.0 * n * EPS) * scale * std + MEAN_RTOL * np.nan_to_num(variance)


def assert_bins_match(
    rust: Any,
    expected: reference.BinnedStats,
    channels: FloatArray,
    time_s: FloatArray,
    temperature_c: FloatArray,
) -> None:
    """Compare a Rust binner result with the reference."""
    np.testing.assert_array_equal(rust.edges_c, expected.edges_c, err_msg="edges_c")
    assert np.asarray(rust.count).dtype == np.int64
    np.testing.assert_array_equal(rust.count, expected.count, err_msg="count")
    assert (rust.n_below, rust.n_above, rust.n_nonfinite) == (
        expected.n_below,
        expected.n_above,
        expected.n_nonfinite,
    )
    assert_close_scaled(rust.time_s, expected.time_s, column_scale(time_s), "time_s")
    assert_close_scaled(
        rust.temperature_c, expected.temperature_c, column_scale(temperature_c), "temperature_c"
    )
    assert np.shape(rust.mean) == expected.mean.shape
    assert np.shape(rust.variance) == expected.variance.shape
    for c in range(channels.shape[1]):
        scale = column_scale(channels[:, c])
        assert_close_scaled(np.asarray(rust.mean)[:, c], expected.mean[:, c], scale, f"mean {c}")
        atol = variance_atol(expected.count, scale, expected.variance[:, [c]])[:, 0]
        rust_variance = np.asarray(rust.variance, dtype=np.float64)[:, c]
        np.testing.assert_array_equal(
            np.isnan(rust_variance), np.isnan(expected.variance[:, c]), err_msg="variance NaNs"
        )
        finite = ~np.isnan(rust_variance)
        assert np.all(
            np.abs(rust_variance[finite] - expected.variance[finite, c]) <= atol[finite]
        ), f"variance {c}: {rust_variance[finite]} vs {expected.variance[finite, c]}"


# --------------------------------------------------------------------------- least squares


def weighted_system(
    design: FloatArray, response: FloatArray, weights: FloatArray | None
) -> tuple[FloatArray, FloatArray]:
    """``(sqrt(W) X, sqrt(W) y)`` over the rows with non-zero weight."""
    w = np.ones(response.shape[0]) if weights is None else weights
    used = w > 0
    root = np.sqrt(w[used])
    return design[used] * root[:, None], response[used] * root


def assert_lstsq_close(
    coefficients: Any,
    expected: Any,
    design: FloatArray,
    response: FloatArray,
    weights: FloatArray | None,
    what: str = "coefficients",
) -> None:
    """Coefficients agree within the perturbation bound of the least-squares problem.

    Work in the column-scaled problem ``A_s d = b`` with ``A_s = sqrt(W) X D^-1``
    (unit columns, ``||A_s|| <= sqrt(p)``) and ``d = D beta``, whose condition
    number is ``kappa = condition_number_scaled``. A backward-stable solver
    (Householder or Givens QR) returns the exact solution of a problem
    perturbed by a relative ``delta = c * eps`` (Golub & Van Loan, Thm 5.3.1;
    Higham, Thm 20.1), hence

        ||d_computed - d|| <= delta * kappa * (2 ||d|| + (kappa + 1) ||r||),

    the ``kappa**2 * ||r||`` term being the sensitivity of least squares with
    a non-zero residual. Column scaling is free for QR (it is column-wise
    invariant), so the scaled ``kappa``, not the raw one, governs ``d``.
    ``delta = LSTSQ_SAFETY * eps`` (see there). Comparing ``d`` rather than
    ``beta`` means a coefficient of a tiny column is allowed a large absolute
    error, exactly as much as the data determine it.
    """
    a, _b = weighted_system(design, response, weights)
    column_norm = np.linalg.norm(a, axis=0)
    d_expected = column_norm * expected.coefficients
    d_actual = column_norm * np.asarray(coefficients, dtype=np.float64)
    kappa = expected.condition_number_scaled
    r = float(np.sqrt(expected.residual_sum_squares))
    tolerance = LSTSQ_SAFETY * EPS * kappa * (2 * np.linalg.norm(d_expected) + (kappa + 1) * r)
    error = np.abs(d_actual - d_expected)
    assert np.all(error <= tolerance), (
        f"{what}: scaled error {error.max():.3e} > {tolerance:.3e} (kappa_scaled={kappa:.3e})"
    )


def assert_solution_matches(
    rust: Any,
    expected: reference.LstsqSolution,
    design: FloatArray,
    response: FloatArray,
    weights: FloatArray | None,
) -> None:
    """Compare every field of a Rust least-squares solution with the reference."""
    p = expected.coefficients.shape[0]
    assert list(rust.column_names) == expected.column_names
    assert (rust.n_rows, rust.dof) == (expected.n_rows, expected.dof)
    assert_lstsq_close(rust.coefficients, expected, design, response, weights)

    a, b = weighted_system(design, response, weights)
    kappa = expected.condition_number_scaled
    # Residual: ||delta r|| <= delta * (1 + 2 kappa) ||b|| for a backward-stable
    # solver (Higham, Thm 20.1 with m > n), and rss = ||r||^2, so
    # |delta rss| <= 2 ||r|| ||delta r|| + ||delta r||^2.
    r = float(np.sqrt(expected.residual_sum_squares))
    delta_r = LSTSQ_SAFETY * EPS * (1 + 2 * kappa) * float(np.linalg.norm(b))
    rss_tolerance = 2 * r * delta_r + delta_r**2
    assert abs(rust.residual_sum_squares - expected.residual_sum_squares) <= rss_tolerance, (
        f"rss {rust.residual_sum_squares} vs {expected.residual_sum_squares}"
    )

    covariance = np.asarray(rust.covariance, dtype=np.float64)
    assert covariance.shape == (p, p)
    if expected.dof == 0:
        assert np.all(np.isnan(covariance)), "covariance must be all NaN when dof == 0"
    else:
        # Scaled covariance D C D = sigma^2 (A_s' A_s)^-1: the inverse of the
        # normal matrix has relative sensitivity ~ kappa^2 * delta, and
        # sigma^2 = rss / dof carries the relative rss error.
        column_norm = np.linalg.norm(a, axis=0)
        scaled = covariance * np.outer(column_norm, column_norm)
        scaled_expected = expected.covariance * np.outer(column_norm, column_norm)
        relative = LSTSQ_SAFETY * EPS * kappa**2 + rss_tolerance / max(
            expected.residual_sum_squares, np.finfo(np.float64).tiny
        )
        atol = relative * float(np.abs(scaled_expected).max())
        np.testing.assert_allclose(scaled, scaled_expected, rtol=0, atol=atol, err_msg="cov")

    # Condition numbers are diagnostics. The smallest singular value computed
    # by any backward-stable method is off by ~eps * sigma_max, i.e. kappa is
    # off by a relative ~eps * kappa; the 1e-8 floor leaves room for an
    # iterative SVD's stopping rule while still telling apart scaled from
    # unscaled numbers and kappa from kappa**2.
    for name in ("condition_number", "condition_number_scaled"):
        value = float(getattr(expected, name))
        rtol = 1e-8 + LSTSQ_SAFETY * EPS * value
        np.testing.assert_allclose(getattr(rust, name), value, rtol=rtol, err_msg=name)


def simulated_session(sim: simulate.SimulatedArrays, decimation_factor: int = 10) -> Session:
    """The session of simulated runs (20 Hz averaged to 2 Hz by default), in memory."""
    return Session.from_arrays(
        [(r.orientation, r.columns) for r in sim.runs],
        units=sim.units,
        rate_hz=sim.rate_hz,
        sensor=sim.sensor,
        decimation_factor=decimation_factor,
    )


def chamber_rate_c_per_min(state: Any) -> FloatArray:
    """The chamber's rate of change in a simulated run, °C/min, averaged over 60 s (centred).

    For effects defined in the tests (not the library's): the simulator's own
    ``RunState`` (``time_s``, ``chamber_temp_c``, ``rate_hz``).
    """
    rate = np.gradient(state.chamber_temp_c, state.time_s) * 60.0
    k = max(1, int(60 * state.rate_hz))
    return np.asarray(np.convolve(rate, np.ones(k) / k, mode="same"), dtype=np.float64)


def validation_case(bench: Any, name: str, hours: float) -> Any:
    """The case of that name of ``benches/validation.py`` (``bench``), for runs of ``hours``."""
    found = [c for c in bench._cases(hours * 3600.0) if c.name == name]
    assert len(found) == 1, name
    return found[0]
