"""The residual's correlation, and the standard errors it widens (batch means over blocks)."""

from __future__ import annotations

import pytest

from accelcore import simulate
from accelcore.diagnosis import diagnose
from accelcore.diagnosis.parameters import variance_inflation
from accelcore.diagnosis.space import Spec
from accelcore.model import AXES
from accelcore.simulate import effects as se
from helpers import simulated_session


@pytest.fixture(scope="module")
def drifting() -> object:
    # Six orientations, 1 h runs heating and cooling back, a drift of 7 / -7 / 10 mg/h.
    sim = simulate.arrays(
        "ADXL335", seed=3, duration_h=1.0, cool_back=True, effects=(se.Drift((7.0, -7.0, 10.0)),)
    )
    return diagnose(simulated_session(sim))


def test_white_residuals_of_decimated_samples_are_not_inflated(drifting: object) -> None:
    eng = drifting._data()  # type: ignore[attr-defined]
    # Every decimated sample averages 10 raw ones (weight 10). Before, the samples'
    # mean square was taken per unit of weight, and white residuals came out 8-12x.
    assert set(eng.w.tolist()) == {10.0}
    right = Spec(drift=True)
    for a in AXES:
        # The model that holds the drift leaves white noise: 72 blocks of 300 s, so the
        # batch-means ratio scatters by about sqrt(2/72) = 17 %; 1.5 is three of those.
        assert 1.0 <= variance_inflation(eng, a, right) < 1.5, a


def test_a_missing_drift_leaves_correlated_residuals(drifting: object) -> None:
    eng = drifting._data()  # type: ignore[attr-defined]
    # Without the drift, 3.5-5 mg of it stays in every run over 0.4-0.8 mg of noise per
    # sample, the same within each 300 s block: the blocks' means carry it, many times
    # over what independent samples would.
    assert all(variance_inflation(eng, a, Spec()) > 5.0 for a in AXES)


def test_reported_standard_errors_cover_the_truth(drifting: object) -> None:
    d = drifting
    assert d.effects == ("drift",)  # type: ignore[attr-defined]
    truth = dict(zip(AXES, (7.0, -7.0, 10.0), strict=True))
    for p in d.steps[1].parameters:  # type: ignore[attr-defined]
        assert p["unit"] == "mg/h"
        # Within four standard errors (three such checks: a false failure has odds
        # of about 2e-4).
        assert abs(p["value"] - truth[p["axis"]]) <= 4.0 * p["se"], p
