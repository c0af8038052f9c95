"""The joint fit through each stretch's QR of its few functions (``accelcore.fitting.reduced``).

An axis' design on a stretch is ``B · M``: a few functions of the samples times the
stretch's constants. ``LeastSquares.push_mapped`` pushes the triangle of ``B`` through
``M`` instead of the rows; every fit made that way is checked here against the NumPy
reference's least squares of the full design, within the bounds of a backward-stable
solver (``tests/helpers.assert_solution_matches``: the scaled condition number and
the residual set the tolerances).
"""

from __future__ import annotations

import numpy as np
import pytest

from accelcore import reference, simulate
from accelcore.core import LeastSquares
from accelcore.errors import AccelcoreError
from accelcore.fitting.calibrate import fit_axis
from accelcore.fitting.reduced import Reduced, functions_of
from accelcore.fitting.stacking import Stacked, stack_session
from accelcore.input.session import Session
from accelcore.model import AXES, Term, design_columns, full_gain_terms
from accelcore.model.bases import SquaredGravity, TemperaturePower
from helpers import assert_lstsq_close, assert_solution_matches, simulated_session

GRAVITY = [np.array(g, dtype=float) for g in ((1, 0, 0), (-1, 0, 0), (0, 0.7, -0.7), (0, 0, 1))]


def _stretches(seed: int, n: int = 300) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per stretch: functions (1, dT, dT²) of a sweep, three outputs, weights (some 0)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in GRAVITY:
        dt = np.sort(rng.uniform(-27.0, 40.0, n))
        b = np.column_stack([np.ones(n), dt, dt * dt])
        y = rng.normal(0.0, 1.0, (n, 3)) + b @ rng.normal(0.0, 1.0, (3, 3))
        w = rng.integers(5, 11, n).astype(float)
        w[::17] = 0.0
        out.append((b, y, w))
    return out


def _map(g: np.ndarray) -> np.ndarray:
    """Offset 1, dT; own gain 1, dT on g_x; cross gains on g_y, g_z (as an axis' terms)."""
    m = np.zeros((3, 6))
    m[0, 0], m[1, 1] = 1.0, 1.0
    m[0, 2], m[1, 3] = g[0], g[0]
    m[0, 4], m[0, 5] = g[1], g[2]
    return m


@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("response", [0, 2])
@pytest.mark.parametrize("shifted", [False, True])
def test_push_mapped_matches_the_reference_fit_of_the_mapped_rows(
    seed: int, response: int, shifted: bool
) -> None:
    stretches = _stretches(seed)
    rng = np.random.default_rng(seed + 100)
    mapped = LeastSquares(6)
    designs, responses, weights = [], [], []
    for (b, y, w), g in zip(stretches, GRAVITY, strict=True):
        source = LeastSquares(3, n_responses=3)
        source.push(b, y, w)
        shift = rng.normal(0.0, 1.0, (3, 1)) if shifted else None
        mapped.push_mapped(source, _map(g), [response], shift)
        designs.append(b @ _map(g))
        responses.append(y[:, response] - (b @ shift[:, 0] if shift is not None else 0.0))
        weights.append(w)
    x, r, w = np.vstack(designs), np.concatenate(responses), np.concatenate(weights)
    expected = reference.LeastSquares(6)
    expected.push(x, r, w)
    assert mapped.n_rows == int(np.count_nonzero(w))
    assert_solution_matches(mapped.finish(), expected.finish(), x, r, w)


def test_push_mapped_checks_its_inputs() -> None:
    b, y, w = _stretches(4)[0]
    source = LeastSquares(3, n_responses=3)
    source.push(b, y, w)
    target = LeastSquares(6)
    with pytest.raises(AccelcoreError):
        target.push_mapped(source, np.ones((2, 6)))  # the source has 3 columns
    with pytest.raises(AccelcoreError):
        target.push_mapped(source, np.ones((3, 6)), [3])  # 3 responses: 0, 1, 2
    with pytest.raises(AccelcoreError):
        target.push_mapped(source, np.full((3, 6), np.nan), [0])
    with pytest.raises(AccelcoreError):
        source.push(b, y[:, 0], w)  # three responses need (n, 3)
    assert target.n_rows == 0


def _session(seed: int, orientations: tuple[str, ...] = simulate.DEFAULT_ORIENTATIONS) -> Session:
    sim = simulate.arrays(
        "ADXL335", seed=seed, duration_h=0.25, cool_back=True, orientations=orientations
    )
    return simulated_session(sim)


def _reference_fit(
    terms: tuple[Term, ...], data: Stacked, axis: str, columns: list[int], fixed: np.ndarray
) -> tuple[reference.LstsqSolution, np.ndarray, np.ndarray, np.ndarray]:
    """The NumPy reference's fit of the full design's ``columns``, the others' part fixed."""
    x = np.vstack(
        [design_columns(terms, f, g, {}) for f, g in zip(data.features, data.gravity, strict=True)]
    )
    y = np.concatenate([o[:, AXES.index(axis)] for o in data.output])
    w = np.concatenate(data.weight)
    y = y - x @ fixed
    solver = reference.LeastSquares(len(columns))
    solver.push(x[:, columns], y, w)
    return solver.finish(), x[:, columns], y, w


@pytest.mark.parametrize("axis", AXES)
def test_fit_axis_equals_the_reference_fit_of_the_whole_design(axis: str) -> None:
    # The default model plus a curvature and a g² term (a constant of each stretch).
    terms = (
        *full_gain_terms(axis),
        Term("offset", TemperaturePower(2)),
        Term("offset", SquaredGravity(axis)),
    )
    data = stack_session(_session(11), 25.0, None)
    model, fixed, _notes = fit_axis(axis, terms, data, None, {})
    assert fixed == []
    expected, x, y, w = _reference_fit(terms, data, axis, list(range(len(terms))), np.zeros(8))
    assert_lstsq_close(model.coefficients, expected, x, y, w)
    assert model.n_samples == x.shape[0]
    # rms: sqrt(rss / sum w); the rss agrees to the solver's rounding (relative 1e-9
    # leaves room for kappa_scaled up to ~1e6 at eps).
    assert model.rms_residual == pytest.approx(
        np.sqrt(expected.residual_sum_squares / w.sum()), rel=1e-9
    )


def test_fit_axis_with_a_shared_reduction_equals_its_own() -> None:
    data = stack_session(_session(12), 25.0, None)
    terms = full_gain_terms("y")
    wider = Reduced.of(data, (*functions_of(terms), TemperaturePower(3)), {})
    assert wider.covers(terms)
    narrower = Reduced.of(data, functions_of(terms[:1]), {})
    assert not narrower.covers(terms)
    own = fit_axis("y", terms, data, None, {})[0]
    shared = fit_axis("y", terms, data, None, {}, reduced=wider)[0]
    rebuilt = fit_axis("y", terms, data, None, {}, reduced=narrower)[0]
    expected, x, y, w = _reference_fit(terms, data, "y", list(range(6)), np.zeros(6))
    for model in (own, shared, rebuilt):
        assert_lstsq_close(model.coefficients, expected, x, y, w)


def test_sensitivity_held_at_nominal_is_taken_from_the_output() -> None:
    # z seen at +1 g only: its sensitivity is held at nominal and the offset absorbs
    # the rest; the fit of the other terms is the reference's of y - nominal * g_z
    # (the map's shift). The cross-axis gains see no gravity: dropped.
    data = stack_session(_session(13, ("OZ+",)), 25.0, None)
    terms = full_gain_terms("z")
    nominal = 0.3
    model, fixed, notes = fit_axis("z", terms, data, nominal, {})
    assert "z:sensitivity" in fixed
    assert any("held at nominal" in n for n in notes)
    held = np.zeros(len(terms))
    held[2] = nominal
    columns = [j for j in range(len(terms)) if model.estimated[j]]
    expected, x, y, w = _reference_fit(terms, data, "z", columns, held)
    assert model.coefficients[2] == nominal
    assert_lstsq_close(model.coefficients[columns], expected, x, y, w)
