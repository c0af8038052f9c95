"""A session whose temperature runs one way only says what it cannot show.

Heating-only calibrations of a part with a 90 s lag and an offset curvature: the
curvature absorbed what the ramp's lag did (a shift of the temperature at one rate),
0.6 mg held out, 6-11 mg on a session that cools (1.0-1.1x). The data cannot tell;
the diagnosis says so in one line.
"""

from __future__ import annotations

from types import ModuleType

import pytest

from accelcore import simulate
from accelcore.diagnosis import diagnose
from accelcore.input.session import Session
from accelcore.simulate import effects as se

HEAT = {"t_start_c": -2.0, "t_end_c": 65.0, "soak_min": 10.0, "cool_back": False}
COOL = {"t_start_c": 65.0, "t_end_c": -2.0, "soak_min": 10.0, "cool_back": False}


@pytest.mark.parametrize(("profile", "way"), [(HEAT, "rises"), (COOL, "falls")])
def test_a_session_that_runs_one_way_says_the_lag_is_not_shown(
    bench: ModuleType, profile: dict[str, float | bool], way: str
) -> None:
    d = diagnose(bench.simulate_session((se.ThermalLag(90.0),), 1, 0.5, profile))
    said = [w for w in d.warnings if w.startswith(f"the temperature only {way}")]
    assert len(said) == 1, d.warnings
    assert "heats and cools back" in said[0]


def test_a_cycle_that_heats_and_cools_back_says_nothing_of_it(bench: ModuleType) -> None:
    d = diagnose(bench.simulate_session((se.ThermalLag(90.0),), 1, 0.5, bench.CALIBRATION_PROFILE))
    assert not any(w.startswith("the temperature only") for w in d.warnings), d.warnings


def test_short_runs_that_cool_back_are_not_said_to_only_heat() -> None:
    """Six 10 min runs: 2 min soak, 4 min heating, 4 min cooling back. Legs shorter
    than 5 min join a neighbour, so each run had one leg, "heating", and the session
    was said to only heat."""
    sim = simulate.arrays(
        "ADXL335",
        seed=1,
        duration_h=1 / 6,
        soak_min=2.0,
        cool_back=True,
        effects=(se.ThermalLag(30.0),),
    )
    session = Session.from_arrays(
        [(r.orientation, r.columns) for r in sim.runs],
        units=sim.units,
        rate_hz=sim.rate_hz,
        sensor=sim.sensor,
        decimation_factor=10,
    )
    d = diagnose(session)
    assert not any(w.startswith("the temperature only") for w in d.warnings), d.warnings
