"""LeastSquares: Rust kernel vs the NumPy reference and numpy.linalg.lstsq."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import accelcore
from accelcore import reference
from accelcore.core import LeastSquares
from helpers import (
    EPS,
    assert_lstsq_close,
    assert_solution_matches,
    same_outcome,
    weighted_system,
)
from strategies import FloatArray, RegressionCase, chunks, collinear_cases, pieces, regression_cases

Kernel = Any  # accelcore.core.LeastSquares or reference.LeastSquares


def push_rows(kernel: Kernel, case: RegressionCase, bounds: list[int]) -> Kernel:
    """Push the rows of ``case`` cut at ``bounds``; return the kernel."""
    if case.weights is None:
        for design, response in chunks(bounds, case.design, case.response):
            kernel.push(design, response)
    else:
        for design, response, weights in chunks(bounds, case.design, case.response, case.weights):
            kernel.push(design, response, weights)
    return kernel


def new(kernel: type[Kernel], case: RegressionCase) -> Kernel:
    return kernel(case.n_columns, column_names=case.column_names)


def reference_solution(case: RegressionCase) -> reference.LstsqSolution | None:
    try:
        solution: reference.LstsqSolution = push_rows(
            new(reference.LeastSquares, case), case, [0, case.design.shape[0]]
        ).finish()
    except reference.ReferenceKernelError:
        return None
    return solution


def piece_kernels(case: RegressionCase, cuts: list[int]) -> list[Kernel]:
    out = []
    for start, stop in itertools.pairwise(cuts):
        kernel = new(LeastSquares, case)
        out.append(push_rows(kernel, case, [start, stop]))
    return out


# --------------------------------------------------------------------------- properties


@given(regression_cases())
def test_matches_reference(case: RegressionCase) -> None:
    rust = push_rows(new(LeastSquares, case), case, case.bounds)
    expected = push_rows(new(reference.LeastSquares, case), case, case.bounds)
    outcome = same_outcome(rust.finish, expected.finish)
    if outcome is None:
        return
    solution, expected_solution = outcome
    assert_solution_matches(solution, expected_solution, case.design, case.response, case.weights)
    # Also against numpy.linalg.lstsq, fed the column-equilibrated weighted
    # system: lstsq (SVD) is only normwise backward stable, so on the raw
    # design its error would follow the unscaled condition number instead.
    a, b = weighted_system(case.design, case.response, case.weights)
    norm = np.linalg.norm(a, axis=0)
    lstsq = np.linalg.lstsq(a / norm, b, rcond=None)[0] / norm
    assert_lstsq_close(lstsq, expected_solution, case.design, case.response, case.weights, "lstsq")


@given(regression_cases())
def test_chunking_invariance(case: RegressionCase) -> None:
    chunked = push_rows(new(LeastSquares, case), case, case.bounds)
    whole = push_rows(new(LeastSquares, case), case, [0, case.design.shape[0]])
    outcome = same_outcome(chunked.finish, whole.finish)
    if outcome is not None:
        # Same perturbation bound as against the reference (see helpers).
        assert_lstsq_close(
            outcome[0].coefficients, outcome[1], case.design, case.response, case.weights
        )
        assert outcome[0].n_rows == outcome[1].n_rows


@given(regression_cases(), st.data())
def test_merge_equals_one_pass(case: RegressionCase, data: st.DataObject) -> None:
    parts = piece_kernels(case, data.draw(pieces(case.design.shape[0])))
    order = data.draw(st.permutations(range(len(parts))))
    merged = parts[order[0]]
    for i in order[1:]:
        merged.merge(parts[i])
    one_pass = push_rows(new(reference.LeastSquares, case), case, case.bounds)
    outcome = same_outcome(merged.finish, one_pass.finish)
    if outcome is not None:
        assert_solution_matches(*outcome, case.design, case.response, case.weights)


@given(regression_cases(), st.data())
def test_merge_associative(case: RegressionCase, data: st.DataObject) -> None:
    n = case.design.shape[0]
    i, j = sorted(data.draw(st.lists(st.integers(0, n), min_size=2, max_size=2)))
    a, b, c = piece_kernels(case, [0, i, j, n])
    a.merge(b)
    a.merge(c)
    a2, b2, c2 = piece_kernels(case, [0, i, j, n])
    b2.merge(c2)
    a2.merge(b2)
    outcome = same_outcome(a.finish, a2.finish)
    if outcome is not None:
        assert_lstsq_close(
            outcome[0].coefficients, outcome[1], case.design, case.response, case.weights
        )


@given(collinear_cases())
def test_exactly_collinear_columns_are_named(case: RegressionCase) -> None:
    rust = push_rows(new(LeastSquares, case), case, case.bounds)
    expected = push_rows(new(reference.LeastSquares, case), case, case.bounds)
    with pytest.raises(accelcore.SingularSystemError) as rust_error:
        rust.finish()
    with pytest.raises(reference.SingularSystemError) as reference_error:
        expected.finish()
    assert list(rust_error.value.columns) == case.dependent
    assert reference_error.value.columns == case.dependent


@given(regression_cases(), st.sampled_from([1e-3, 7.0, 2.0**20]))
def test_weight_scale_invariance(case: RegressionCase, factor: float) -> None:
    # Multiplying every weight by c leaves the minimiser unchanged.
    scaled = RegressionCase(
        case.design,
        case.response,
        factor * (np.ones(case.design.shape[0]) if case.weights is None else case.weights),
        case.bounds,
        case.column_names,
    )
    original = push_rows(new(LeastSquares, case), case, case.bounds)
    rescaled = push_rows(new(LeastSquares, scaled), scaled, scaled.bounds)
    outcome = same_outcome(rescaled.finish, original.finish)
    if outcome is not None:
        expected = reference_solution(case)
        assert expected is not None
        assert_lstsq_close(
            outcome[0].coefficients, expected, case.design, case.response, case.weights
        )
        assert outcome[0].n_rows == outcome[1].n_rows


# --------------------------------------------------------------------------- named cases


@pytest.mark.parametrize("degree", range(6))
def test_polynomial_in_raw_celsius_matches_lstsq(degree: int) -> None:
    # A thermal-calibration fit as users write it: powers of the raw
    # temperature in °C over -40...125 °C, no centring or scaling. The raw
    # design is badly conditioned (cond ~1.6e10 at degree 5, because T^5
    # reaches 3e10 while T^0 is 1), but equilibrating the columns brings it to
    # ~3e2: the problem itself is benign, only its units are not.
    temperature_c = np.linspace(-40.0, 125.0, 331)
    design = np.vander(temperature_c, degree + 1, increasing=True)
    rng = np.random.default_rng(7)
    truth = np.array([16384.0, 2.5, -0.03, 4e-4, -2e-6, 5e-9])[: degree + 1]
    response = design @ truth + 0.5 * rng.standard_normal(temperature_c.size)  # 0.5 LSB noise

    rust = LeastSquares(degree + 1)
    rust.push(design, response)
    solution = rust.finish()
    expected = reference.LeastSquares(degree + 1)
    expected.push(design, response)
    assert_solution_matches(solution, expected.finish(), design, response, None)

    # numpy.linalg.lstsq on the equilibrated design D^-1 (lstsq is SVD-based
    # and only normwise stable: on the raw design its error would follow the
    # raw condition number, 1e10, and swamp the small-column coefficients).
    norm = np.linalg.norm(design, axis=0)
    d_lstsq = np.linalg.lstsq(design / norm, response, rcond=None)[0]
    d_rust = norm * np.asarray(solution.coefficients)
    residual = float(np.sqrt(solution.residual_sum_squares))
    kappa = solution.condition_number_scaled
    # Tolerance derived from the condition number, not tuned. Both solvers
    # are backward stable on the equilibrated problem: each solves exactly a
    # problem perturbed by a relative c * eps, with c an O(1)..O(sqrt(n p))
    # constant (below 0.1 for both when checked against an exact rational
    # solution). Least-squares perturbation theory (Golub & Van Loan,
    # Thm 5.3.1) then puts each within c * eps * kappa * (2 ||d|| +
    # (kappa + 1) ||r||) of the exact d, and their difference within twice
    # that; c = 25 per side gives the 50. At degree 5, 50 * eps * kappa is
    # ~3e-12 relative: a wrong column, scaling or weighting misses by orders.
    rtol = 50 * kappa * EPS
    tolerance = rtol * (2 * float(np.linalg.norm(d_lstsq)) + (kappa + 1) * residual)
    assert np.linalg.norm(d_rust - d_lstsq) <= tolerance, (np.abs(d_rust - d_lstsq), tolerance)
    # The scaled condition number is what makes this fit fine in float64.
    if degree == 5:
        assert solution.condition_number > 1e9
        assert solution.condition_number_scaled < 1e4


def test_rank_deficiency_names_the_right_columns() -> None:
    rng = np.random.default_rng(3)
    t = rng.uniform(-40.0, 125.0, 50)
    columns = {
        "offset": np.ones_like(t),
        "slope": t,
        "slope_x2": 2.0 * t,  # 2 * slope
        "quad": t**2,
        "offset_plus_slope": 1.0 + t,  # offset + slope
        "zero": np.zeros_like(t),  # all zero
        "cubic": t**3,
    }
    names = list(columns)
    design = np.column_stack(list(columns.values()))
    response = rng.normal(size=t.size)
    expected = ["slope_x2", "offset_plus_slope", "zero"]
    rust = LeastSquares(len(names), column_names=names)
    rust.push(design, response)
    with pytest.raises(accelcore.SingularSystemError) as rust_error:
        rust.finish()
    assert list(rust_error.value.columns) == expected
    oracle = reference.LeastSquares(len(names), column_names=names)
    oracle.push(design, response)
    with pytest.raises(reference.SingularSystemError) as reference_error:
        oracle.finish()
    assert reference_error.value.columns == expected
    assert issubclass(accelcore.SingularSystemError, accelcore.AccelcoreError)
    assert issubclass(accelcore.SingularSystemError, ValueError)


def test_default_names_in_singular_error() -> None:
    design = np.array([[1.0, 2.0], [2.0, 4.0], [3.0, 6.0]])
    solver = LeastSquares(2)
    solver.push(design, np.array([1.0, 2.0, 2.5]))
    with pytest.raises(accelcore.SingularSystemError) as info:
        solver.finish()
    assert list(info.value.columns) == ["x1"]


def test_zero_weight_rows_are_ignored() -> None:
    rng = np.random.default_rng(5)
    design = np.column_stack([np.ones(30), rng.normal(size=30)])
    response = design @ [1.0, -2.0] + 0.1 * rng.normal(size=30)
    weights = np.where(np.arange(30) % 3 == 0, 0.0, 1.0)
    with_zeros = LeastSquares(2)
    with_zeros.push(design, response, weights)
    kept = weights > 0
    without = LeastSquares(2)
    without.push(design[kept], response[kept])
    a, b = with_zeros.finish(), without.finish()
    assert a.n_rows == b.n_rows == 20
    assert a.dof == 18
    expected = reference.LeastSquares(2)
    expected.push(design[kept], response[kept])
    assert_solution_matches(a, expected.finish(), design[kept], response[kept], None)


def test_zero_weights_can_make_a_column_singular() -> None:
    # Column "b" is non-zero only on rows that carry no weight.
    design = np.array([[1.0, 0.0], [1.0, 0.0], [1.0, 5.0], [1.0, 0.0]])
    weights = np.array([1.0, 1.0, 0.0, 2.0])
    solver = LeastSquares(2, column_names=["a", "b"])
    solver.push(design, np.array([1.0, 2.0, 3.0, 4.0]), weights)
    with pytest.raises(accelcore.SingularSystemError) as info:
        solver.finish()
    assert list(info.value.columns) == ["b"]


def test_integer_weights_equal_repeated_rows() -> None:
    rng = np.random.default_rng(11)
    design = np.column_stack([np.ones(12), rng.normal(size=12), rng.normal(size=12)])
    response = rng.normal(size=12)
    weights = rng.integers(1, 4, 12).astype(np.float64)
    weighted = LeastSquares(3)
    weighted.push(design, response, weights)
    repeats = weights.astype(int)
    repeated = LeastSquares(3)
    repeated.push(np.repeat(design, repeats, axis=0), np.repeat(response, repeats))
    expected = reference.LeastSquares(3)
    expected.push(design, response, weights)
    # Same minimiser (the objectives are identical), different n_rows and dof.
    assert_lstsq_close(repeated.finish().coefficients, expected.finish(), design, response, weights)
    assert_lstsq_close(weighted.finish().coefficients, expected.finish(), design, response, weights)


def test_square_system_has_nan_covariance() -> None:
    design = np.array([[1.0, 0.0], [1.0, 1.0]])
    solver = LeastSquares(2)
    solver.push(design, np.array([3.0, 5.0]))
    solution = solver.finish()
    assert (solution.n_rows, solution.dof) == (2, 0)
    # An exact 2x2 solve of small integers: exact up to a few roundings.
    np.testing.assert_allclose(solution.coefficients, [3.0, 2.0], rtol=4 * EPS)
    assert abs(solution.residual_sum_squares) <= 1e-28  # (a few eps * ||b||)^2
    assert np.all(np.isnan(np.asarray(solution.covariance)))
    assert list(solution.column_names) == ["x0", "x1"]


@pytest.mark.parametrize("kernel", [LeastSquares, reference.LeastSquares])
def test_insufficient_data(kernel: type[Kernel]) -> None:
    errors = (accelcore.InsufficientDataError, reference.InsufficientDataError)
    with pytest.raises(errors):
        kernel(2).finish()  # no rows at all
    empty = kernel(2)
    empty.push(np.empty((0, 2)), np.empty(0))  # an empty chunk is fine
    with pytest.raises(errors):
        empty.finish()
    too_few = kernel(3)
    too_few.push(np.ones((2, 3)), np.ones(2))
    with pytest.raises(errors):
        too_few.finish()
    all_zero_weight = kernel(1)
    all_zero_weight.push(np.ones((4, 1)), np.ones(4), np.zeros(4))
    with pytest.raises(errors):
        all_zero_weight.finish()


@pytest.mark.parametrize("where", ["design", "response", "weights"])
@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_non_finite_input_is_rejected(where: str, value: float) -> None:
    arrays = {"design": np.ones((3, 2)), "response": np.ones(3), "weights": np.ones(3)}
    arrays[where].flat[1] = value
    with pytest.raises(accelcore.NonFiniteError):
        LeastSquares(2).push(arrays["design"], arrays["response"], arrays["weights"])
    with pytest.raises(reference.NonFiniteError):
        reference.LeastSquares(2).push(arrays["design"], arrays["response"], arrays["weights"])


def test_negative_weight_is_rejected() -> None:
    args = (np.ones((3, 2)), np.ones(3), np.array([1.0, -1e-300, 1.0]))
    with pytest.raises(accelcore.ParameterError):
        LeastSquares(2).push(*args)
    with pytest.raises(reference.ParameterError):
        reference.LeastSquares(2).push(*args)


@pytest.mark.parametrize(
    ("design", "response", "weights"),
    [
        (np.ones((3, 3)), np.ones(3), None),  # wrong column count
        (np.ones((3, 2)), np.ones(2), None),  # response too short
        (np.ones((3, 2)), np.ones(3), np.ones(4)),  # weights too long
        pytest.param(np.ones(3), np.ones(3), None, id="design-1d"),
        pytest.param(np.ones((3, 2)), np.ones((3, 1)), None, id="response-2d"),
    ],
)
def test_shape_errors(design: FloatArray, response: FloatArray, weights: FloatArray | None) -> None:
    with pytest.raises(accelcore.ShapeError):
        LeastSquares(2).push(design, response, weights)
    with pytest.raises(reference.ShapeError):
        reference.LeastSquares(2).push(design, response, weights)


def test_merge_rejects_other_columns() -> None:
    with pytest.raises(accelcore.IncompatibleError):
        LeastSquares(2).merge(LeastSquares(3))
    with pytest.raises(accelcore.IncompatibleError):
        LeastSquares(2, column_names=["a", "b"]).merge(LeastSquares(2, column_names=["a", "c"]))


def test_custom_names_are_reported() -> None:
    rng = np.random.default_rng(2)
    design = rng.normal(size=(10, 2))
    solver = LeastSquares(2, column_names=["offset_lsb", "tempco_lsb_per_c"])
    solver.push(design, rng.normal(size=10))
    assert list(solver.finish().column_names) == ["offset_lsb", "tempco_lsb_per_c"]


@pytest.mark.parametrize(
    ("n_columns", "names"),
    [(0, None), (65, None), (2, ["a"]), (2, ["a", "b", "c"]), (2, ["a", "a"])],
)
def test_invalid_config(n_columns: int, names: list[str] | None) -> None:
    with pytest.raises(accelcore.ParameterError):
        LeastSquares(n_columns, column_names=names)
    with pytest.raises(reference.ParameterError):
        reference.LeastSquares(n_columns, column_names=names)
