"""Second-order nonlinearity in the force (``g_b^2``): model, fit, compensation, diagnosis."""

from __future__ import annotations

import math

import numpy as np
import pytest

from accelcore import calibrate, simulate
from accelcore.diagnosis import diagnose
from accelcore.errors import ParameterError
from accelcore.model import (
    AXES,
    Basis,
    Features,
    SquaredGravity,
    Term,
    design_columns,
    full_gain_terms,
)
from accelcore.simulate import effects as se
from helpers import simulated_session

K2_MG_PER_G2 = (4.0, -3.0, 5.0)


@pytest.fixture(scope="module")
def nonlinear() -> simulate.SimulatedArrays:
    return simulate.arrays(
        "ADXL335", seed=41, duration_h=0.5, effects=(se.Nonlinearity(K2_MG_PER_G2),)
    )


def test_the_basis_is_named_parsed_and_read_from_the_force() -> None:
    basis = Basis.parse("g_y^2")
    assert basis == SquaredGravity("y")
    assert basis.name == "g_y^2" and basis.needs_gravity
    term = Term("offset", "g_y^2", effect="nonlinearity")
    assert Term.from_dict(term.to_dict()) == term
    with pytest.raises(ParameterError, match="axis x, y or z"):
        SquaredGravity("w")
    feats = Features(np.array([20.0, 30.0]), None, {}, 25.0)
    # Without a force the basis cannot be read (a compensation supplies its estimate).
    with pytest.raises(ParameterError, match="specific force"):
        basis.evaluate(feats)
    cols = design_columns(
        (Term("offset", "g_x^2"), Term("offset", "g_y^2"), Term("gain", "g_y^2", source="y")),
        feats,
        np.array([0.0, -1.0, 0.0]),
    )
    # g_x^2 = 0, g_y^2 = 1, and as a gain on g_y: g_y^3 = -1 (exact small integers).
    np.testing.assert_array_equal(cols, [[0.0, 1.0, -1.0], [0.0, 1.0, -1.0]])


def test_a_fit_with_the_term_recovers_k2(nonlinear: simulate.SimulatedArrays) -> None:
    terms = {a: (*full_gain_terms(a), Term("offset", f"g_{a}^2")) for a in AXES}
    cal = calibrate(simulated_session(nonlinear), terms=terms)
    for i, a in enumerate(AXES):
        m = cal.axes[a]
        value, se = m.value("offset", f"g_{a}^2")
        mg = value / nonlinear.truth.sensitivity_per_g[i] * 1000.0
        se_mg = se / nonlinear.truth.sensitivity_per_g[i] * 1000.0
        # Six orientations identify K2 from the runs' levels: within 5 standard errors
        # (about 0.01 mg here: 0.5 h of white noise averaged per run).
        assert abs(mg - K2_MG_PER_G2[i]) <= 5 * se_mg + 1e-3, (a, mg, se_mg)


def test_compensation_solves_for_the_force_of_a_quadratic_model(
    nonlinear: simulate.SimulatedArrays,
) -> None:
    """raw = o(T) + S(T) g + K2 g^2 written from the fitted coefficients at forces that
    are not the six orientations; the compensation's fixed point gives g back. Each
    pass shrinks the error by about 2 K2 |g| / S (1e-2 here), so it settles at the
    passes' tolerance (1e-12 g); the 3x3 solve adds a few ulps."""
    terms = {a: (*full_gain_terms(a), Term("offset", f"g_{a}^2")) for a in AXES}
    cal = calibrate(simulated_session(nonlinear), terms=terms)
    rng = np.random.default_rng(5)
    n = 64
    g = rng.uniform(-1.5, 1.5, size=(n, 3))
    temp = rng.uniform(0.0, 60.0, size=n)
    raw = np.empty((n, 3))
    feats = Features(temp, None, {}, cal.t_ref_c)
    for i, a in enumerate(AXES):
        m = cal.axes[a]
        for k in range(n):
            row = design_columns(m.terms, feats, g[k])[k]
            raw[k, i] = row @ m.coefficients
    back = cal.compensate(raw, temp)
    np.testing.assert_allclose(back, g, rtol=0, atol=1e-11)
    # The same in chunks: each chunk solves its own samples.
    comp = cal.compensator()
    chunked = np.vstack([comp.push(raw[s : s + 7], temp[s : s + 7]) for s in range(0, n, 7)])
    np.testing.assert_array_equal(chunked, back)


def test_the_diagnosis_adds_k2_and_reports_it_in_mg_per_g2(
    nonlinear: simulate.SimulatedArrays,
) -> None:
    d = diagnose(simulated_session(nonlinear))
    assert "nonlinearity" in d.effects, d.effects
    step = next(s for s in d.steps if s.effect == "nonlinearity")
    assert set(step.axes) == set(AXES)
    for p in step.parameters:
        i = AXES.index(p["axis"])
        assert p["unit"] == "mg/g²"
        # The fit's standard error, plus the linearisation by the nominal sensitivity
        # (the parameters are in mg through the fitted sensitivity, 0.1 % off).
        assert math.isfinite(p["se"]) and p["se"] > 0
        assert abs(p["value"] - K2_MG_PER_G2[i]) <= 5 * p["se"] + 0.01 * abs(K2_MG_PER_G2[i])
    # Carried into the calibration: compensating its own session leaves the noise.
    assert any(t.basis == SquaredGravity("x") for t in d.calibration.axes["x"].terms)
