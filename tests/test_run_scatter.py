"""Run levels that scatter over every run are not session events; one run off is."""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType

import numpy as np
import pytest

from accelcore import simulate
from accelcore.diagnosis import Diagnosis, diagnose
from accelcore.simulate import effects as se
from accelcore.simulate.chain import RunState, Stage
from helpers import simulated_session

#: The validation bench's calibration profile: soak at -2 °C, up to 65 °C and back.
PROFILE = {"t_start_c": -2.0, "t_end_c": 65.0, "soak_min": 10.0, "cool_back": True}


def levels(d: Diagnosis) -> list[str]:
    """The run levels fitted as session events."""
    return sorted({e["event"] for e in d.session_events if e["event"].startswith("level of run")})


def test_turn_on_scatter_is_not_taken_for_tilted_runs() -> None:
    """Every run with its own offset (2 mg sd per axis): each run's level is far out
    of its own noise, so each passes the level test; none stands out of the others,
    so none is an event. (Before the outlier rule, four to six runs were.)"""
    for seed in (3, 4):
        sim = simulate.arrays(
            "ADXL335",
            seed=seed,
            duration_h=0.5,
            effects=(se.TurnOnBias(2.0, seed=seed),),
            **PROFILE,  # type: ignore[arg-type]
        )
        d = diagnose(simulated_session(sim))
        assert levels(d) == [], d.session_events


def test_a_tilted_run_stands_out_of_a_turn_on_scatter() -> None:
    """1.5 degrees of tilt (26 mg on y in OZ+) beside a 0.3 mg turn-on scatter."""
    sim = simulate.arrays(
        "ADXL335",
        seed=5,
        duration_h=0.5,
        effects=(se.TurnOnBias(0.3, seed=5), se.RunTilt("OZ+", 1.5, "x")),
        **PROFILE,  # type: ignore[arg-type]
    )
    d = diagnose(simulated_session(sim))
    assert "level of run OZ+" in levels(d), d.session_events


def test_turn_on_scatter_on_one_axis_is_not_taken_for_tilted_runs() -> None:
    """Run-to-run scatter on z only (2.5 mg sd): z's levels stand out of the levels of
    x and y, which scatter little, so each passed the outlier rule; fitted as events
    they left z's offset to its two ±g runs, and the error on an independent session
    rose (0.60x and 0.76x on seeds 1 and 2). Levels off in half an axis' zero-g runs
    or more are its scatter, as jumps in most runs are not steps."""
    for seed in (1, 2):
        sim = simulate.arrays(
            "ADXL335",
            seed=seed,
            duration_h=0.5,
            effects=(se.TurnOnBias((0.0, 0.0, 2.5), seed=seed),),
            **PROFILE,  # type: ignore[arg-type]
        )
        d = diagnose(simulated_session(sim))
        on_z = [e for e in d.session_events if e["axis"] == "z" and "level" in e["event"]]
        assert len(on_z) <= 1, d.session_events


@dataclass(frozen=True)
class RunTemperatureOffset:
    """The logged temperature off by a constant drawn per run, uniform in ±1 °C (a probe
    seated anew for every orientation)."""

    max_c: float = 1.0
    name: str = "run_temperature_offset"
    stage: Stage = "temperature"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        state.logged_temp_c = state.logged_temp_c + rng.uniform(-self.max_c, self.max_c)


@pytest.mark.parametrize("seed", [1, 2])
def test_a_temperature_offset_per_run_is_not_taken_for_an_effect(
    bench: ModuleType, seed: int
) -> None:
    """Through z's offset tempco (-3.6 mg/°C; x and y 0.18) each run's temperature offset
    is a level of z alone. Judged against the levels of all axes pooled, z's stood out:
    seed 1 took a run level and a `g_z^2` term from them (1.48 -> 1.79 mg on the
    validation session, 0.83x), seed 2 four run levels on z (0.57x). Against z's own
    scatter, they are scatter: nothing is added (1.00x on both)."""
    case = bench.ValidationCase("T offset per run", part=(RunTemperatureOffset(),))
    out = bench.run_case(case, seed, 1.0)
    assert out.diagnosed_mg <= 1.05 * out.base_mg, (out.added, out.base_mg, out.diagnosed_mg)


def test_turn_on_scatter_on_one_axis_is_not_taken_for_a_misalignment(bench: ModuleType) -> None:
    """2.5 mg of turn-on scatter on z alone (seed 4): the cross-axis gains of z fit two
    of its four zero-g runs' levels. Against the scatter of all axes pooled (x and y
    scatter little) that cut passed the run-level test and the misalignment was taken,
    1.74 -> 2.23 mg on the validation session (0.78x); judged against z's own scatter,
    it is not (1.00x)."""
    from accelcore.simulate import events as sev

    case = bench.ValidationCase(
        "turn-on scatter on z",
        part=(sev.TurnOnBias((0.0, 0.0, 2.5), seed=4),),
        validation_part=(sev.TurnOnBias((0.0, 0.0, 2.5), seed=1004),),
        expect="rise <= 5%",
    )
    out = bench.run_case(case, 4, 1.0)
    assert "misalignment" not in out.added, out.added
    assert out.diagnosed_mg <= 1.05 * out.base_mg, (out.added, out.base_mg, out.diagnosed_mg)
