"""A lag's time constant is searched up to a third of the session's shortest heating or cooling leg.

Two effects nobody named to the diagnosis, scored as a user would (fit on a calibration
session, the RMS error against nominal gravity on an independent session of the same
part: another temperature profile, another seed). Neither is a lag; with time constants
up to 3600 s the loop took a "lag" of 1000-2000 s for each, whose column never settled
inside a leg of the calibration session and carried each leg's memory of where it
started; the validation session (a soak at 64 °C, one slower cooling ramp) got what that
memory extrapolates to:

- an offset that shifts once the die has passed 50 °C (package stress relaxing, the
  memory of the hottest point): 1.50 -> 2.82 mg (0.53x); capped at half a leg, 1.27 mg
  (1.18x); at a third, 1.08 mg (1.39x);
- a die that heats faster than it cools (a lag of 60 s heating, 240 s cooling) on a
  0.4-0.6 mg/°C offset tempco: 5.61 -> 9.36 mg (0.60x); capped at half a leg, 3.37 mg
  (1.67x) on seed 1 but 6.54 mg (0.86x) on seed 2, its lags at 720-750 s; at a third,
  3.91-3.92 mg (1.43x) on both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import ModuleType

import numpy as np
import pytest

from accelcore.diagnosis import diagnose
from accelcore.diagnosis.engine import Engine
from accelcore.diagnosis.search import LAG_LEG_SHARE, TAU_RANGE_S, lag_range_s
from accelcore.simulate.chain import RunState, Stage

HOURS = 1.0


@dataclass(frozen=True)
class StressRelief:
    """Offset shifted by (2, -2, 4) mg once the die has passed 50 °C, to the end of the run."""

    name: str = "stress_relief"
    stage: Stage = "response"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        hot = (np.maximum.accumulate(state.die_temp_c) > 50.0)[:, None]
        mg = np.array([2.0, -2.0, 4.0]) * hot
        state.output = state.output + mg / 1000.0 * state.truth.sensitivity_per_g


@pytest.mark.parametrize("seed", [1, 2])
def test_a_memory_of_the_hottest_point_is_not_made_worse(bench: ModuleType, seed: int) -> None:
    """Nothing the model space holds exactly: not worse than the seed paper's model.

    Measured 1.39x on both seeds (0.53x and 0.69x with lags up to 3600 s).
    """
    case = bench.ValidationCase("stress relief", part=(StressRelief(),), expect="rise <= 5%")
    out = bench.run_case(case, seed, HOURS)
    assert out.diagnosed_mg <= 1.05 * out.base_mg, (out.added, out.base_mg, out.diagnosed_mg)


@dataclass(frozen=True)
class AsymmetricLag:
    """The die follows the chamber with 60 s heating and 240 s cooling (convection differs)."""

    heating_s: float = 60.0
    cooling_s: float = 240.0
    name: str = "asymmetric_lag"
    stage: Stage = "temperature"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        t, chamber = state.time_s, state.chamber_temp_c
        die = np.empty_like(chamber)
        die[0] = chamber[0]
        for i in range(1, chamber.size):
            tau = self.heating_s if chamber[i] > die[i - 1] else self.cooling_s
            die[i] = die[i - 1] + (1.0 - math.exp(-(t[i] - t[i - 1]) / tau)) * (
                chamber[i] - die[i - 1]
            )
        state.die_temp_c = die


@dataclass(frozen=True)
class OffsetTempco:
    """A strong linear offset tempco of the die, so its lag shows (0.5/-0.4/0.6 mg/°C)."""

    name: str = "offset_tempco"
    stage: Stage = "response"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        mg = np.array([0.5, -0.4, 0.6]) * (state.die_temp_c - 25.0)[:, None]
        state.output = state.output + mg / 1000.0 * state.truth.sensitivity_per_g


@pytest.mark.parametrize("seed", [1, 2])
def test_a_die_that_heats_faster_than_it_cools_is_not_made_worse(
    bench: ModuleType, seed: int
) -> None:
    """A lag that differs by direction is not in the model space: the error still falls.

    Measured 5.61 -> 3.91-3.92 mg (1.43x) on both seeds; up to half a leg 1.67x and 0.86x.
    """
    case = bench.ValidationCase("asymmetric lag", part=(AsymmetricLag(), OffsetTempco()))
    out = bench.run_case(case, seed, HOURS)
    assert out.diagnosed_mg < out.base_mg, (out.added, out.base_mg, out.diagnosed_mg)


def _engine_with_legs(legs_s: dict[tuple[int, int], float]) -> Engine:
    eng = Engine.__new__(Engine)
    eng.leg_s = legs_s
    return eng


def test_the_range_ends_at_a_third_of_the_shortest_leg() -> None:
    eng = _engine_with_legs({(0, 0): 2100.0, (0, 1): 1500.0, (1, 0): 1800.0})
    # One rounding of a third times the leg: within an ulp of 500 s.
    assert LAG_LEG_SHARE == pytest.approx(1.0 / 3.0, rel=1e-15)
    assert lag_range_s(eng) == pytest.approx((TAU_RANGE_S[0], 500.0), rel=1e-15)
    # Never above what is asked, never below its lower end.
    assert lag_range_s(eng, (5.0, 300.0)) == (5.0, 300.0)
    short = _engine_with_legs({(0, 0): 4.0})
    assert lag_range_s(short) == (5.0, 5.0)


def test_a_run_cut_short_does_not_take_the_lag_away() -> None:
    # A 4-minute record's one leg: below the shortest leg a longer record holds.
    eng = _engine_with_legs({(0, 0): 2100.0, (0, 1): 1500.0, (1, 0): 240.0})
    assert lag_range_s(eng) == pytest.approx((TAU_RANGE_S[0], 500.0), rel=1e-15)
    # Only short records: their legs are all there is.
    only_short = lag_range_s(_engine_with_legs({(0, 0): 240.0, (1, 0): 210.0}))
    assert only_short == pytest.approx((5.0, 70.0), rel=1e-15)


def test_a_steady_session_keeps_the_whole_range() -> None:
    assert lag_range_s(_engine_with_legs({})) == TAU_RANGE_S


def test_leg_durations_are_the_whole_legs(bench: ModuleType) -> None:
    """Profile A of 1 h: a 10 min soak joined to the heating ramp, then the cooling ramp."""
    session = bench.simulate_session((), 1, HOURS, bench.CALIBRATION_PROFILE)
    d = diagnose(session, max_steps=0)
    assert d.options["tau_range_s"][0] == TAU_RANGE_S[0]
    # Six runs of the same profile: the shortest leg is a ramp of 67 °C over ~25 min.
    assert math.isclose(d.options["tau_range_s"][1], 1500.0 / 3.0, rel_tol=0.1)
