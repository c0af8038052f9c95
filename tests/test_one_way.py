"""A session whose temperature runs one way only says what it cannot show.

Heating-only calibrations of a part with a 90 s lag and an offset curvature: the
curvature absorbed what the ramp's lag did (a shift of the temperature at one rate),
0.6 mg held out, 6-11 mg on a session that cools (1.0-1.1x). The data cannot tell;
the diagnosis says so in one line.
"""

from __future__ import annotations

from types import ModuleType

import numpy as np
import pytest
from numpy.typing import ArrayLike, NDArray

from accelcore import simulate
from accelcore.diagnosis import diagnose
from accelcore.diagnosis.parts import one_way
from accelcore.input.session import Session
from accelcore.simulate import effects as se
from accelcore.simulate import runs as simulate_runs
from helpers import simulated_session

FloatArray = NDArray[np.float64]

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


def test_a_short_tail_the_other_way_is_still_one_way() -> None:
    """Legs of both kinds, but the way back travels 5 % of the way there: one way.

    The caveat was dropped whenever a leg ran the other way, however little (a 4 h
    heating ramp that ends cooling 2 °C in 7 min); the share decides now.
    """
    kinds = {(0, 0): "heating", (0, 1): "cooling"}
    elapsed = np.arange(1100, dtype=np.float64) * 0.5
    tail = np.concatenate([np.full(1000, 1.0), np.full(100, -0.5)])  # °C/min
    said = one_way(kinds, tail, elapsed)
    assert said is not None and said.startswith("the temperature only rises")
    assert "term in dT/dt" in said
    cycle = np.concatenate([np.full(550, 1.0), np.full(550, -1.0)])
    assert one_way(kinds, cycle, elapsed) is None
    # Falling most of the way: "falls", whatever leg comes first.
    assert str(one_way(kinds, -tail, elapsed)).startswith("the temperature only falls")


def test_a_heating_session_with_a_cooling_tail_says_so(monkeypatch: pytest.MonkeyPatch) -> None:
    """A 1 h heating ramp (-2 -> 65 °C) whose last 6 min cool 3 °C: a leg of its own.

    A 90 s lag: the session cannot show it whole, and says so.
    """

    def heat_then_tail(time_s: ArrayLike, **_: object) -> FloatArray:
        t_min = np.asarray(time_s, dtype=np.float64) / 60.0
        return np.interp(t_min, [0.0, 10.0, 54.0, 60.0], [-2.0, -2.0, 65.0, 62.0])

    monkeypatch.setattr(simulate_runs, "temperature_profile", heat_then_tail)
    sim = simulate.arrays("ADXL335", seed=1, duration_h=1.0, effects=(se.ThermalLag(90.0),))
    d = diagnose(simulated_session(sim))
    assert sum(w.startswith("the temperature only rises") for w in d.warnings) == 1, d.warnings
