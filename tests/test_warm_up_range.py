"""A warm-up whose time constant ends at the top of its range is a drift's shape, not a warm-up."""

from __future__ import annotations

import pytest

from accelcore import simulate
from accelcore.diagnosis import diagnose
from accelcore.diagnosis.search import at_upper_end, warm_up_range_s
from accelcore.simulate import effects as se
from helpers import simulated_session


def test_at_upper_end_is_the_search_tolerance_at_the_top() -> None:
    # The search stops within 0.5 % of the best time constant (TAU_TOL): a result
    # that close to the top cannot be told from one beyond it.
    assert at_upper_end(1200.0, (5.0, 1200.0))
    assert at_upper_end(1195.0, (5.0, 1200.0))
    assert not at_upper_end(1150.0, (5.0, 1200.0))
    assert not at_upper_end(300.0, (5.0, 1200.0))


@pytest.fixture(scope="module")
def three_orientations_drifting() -> object:
    # Three orientations (OX+, OY+, OZ+), 1 h runs heating to 65 °C and back, a part
    # with offset curvature, a 90 s die lag and a drift of 7 / -7 / 10 mg/h from each
    # run's start (a property of the part: every run drifts).
    sim = simulate.arrays(
        "ADXL335",
        seed=1,
        duration_h=1.0,
        cool_back=True,
        orientations=("OX+", "OY+", "OZ+"),
        effects=(se.OffsetCurvature(), se.ThermalLag(90.0), se.Drift((7.0, -7.0, 10.0))),
    )
    return diagnose(simulated_session(sim))


def test_a_drift_is_not_taken_for_a_warm_up_at_the_end_of_its_range(
    three_orientations_drifting: object,
) -> None:
    d = three_orientations_drifting
    # Before: a warm-up event of tau 1200 s (a third of the runs, the top of its range)
    # on x and y, fitted on this session only, and no drift; on a cooling session of
    # the same part the diagnosed calibration's error was 2.04 mg, now 1.52 (ideal 0.61).
    assert "drift" in d.effects  # type: ignore[attr-defined]
    top = warm_up_range_s(d._data())[1]  # type: ignore[attr-defined]
    for step in d.steps:  # type: ignore[attr-defined]
        for p in step.parameters:
            if p["name"] == "tau" and step.effect == "event: warm-up":
                assert not at_upper_end(p["value"], (5.0, top)), p
