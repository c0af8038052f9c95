"""Whole runs are folds only when every fold's training data spans the temperatures.

Five runs of a 1 h cycle and OZ- cut to its first two minutes (the cold soak): with
whole runs as folds, holding OZ+ out left z's other gravity value on those two minutes
at -2 °C, and z's sensitivity tempco rested on them. The held-out error measured that
extrapolation (626 mg on z) and the selection chased it: a drift of -35 mg/h, a lag of
5 s and a gain against temperature on z, 5.04 -> 6.34 mg on an independent session
(0.80x). The folds are now not whole runs (blocks in turn, each run's heating and
cooling in every fold's training data): the lag, 0.61 mg, the truth's.
"""

from __future__ import annotations

from types import ModuleType

import numpy as np
import pytest

from accelcore import calibrate, simulate
from accelcore.diagnosis import diagnose
from accelcore.input.session import Session
from accelcore.model import AXES
from accelcore.simulate import effects as se


@pytest.mark.parametrize("seed", [1, 2])
def test_a_run_of_two_minutes_does_not_make_runs_the_folds(bench: ModuleType, seed: int) -> None:
    part = (se.ThermalLag(90.0),)
    sim = simulate.arrays(
        "ADXL335", seed=seed, duration_h=1.0, effects=part, **bench.CALIBRATION_PROFILE
    )
    runs = []
    for r in sim.runs:
        cols = {k: np.asarray(v) for k, v in r.columns.items()}
        if r.orientation == "OZ-":
            keep = cols["time_s"] < 120.0
            cols = {k: v[keep] for k, v in cols.items()}
        runs.append((r.orientation, cols))
    session = Session.from_arrays(
        runs, units=sim.units, rate_hz=sim.rate_hz, sensor=sim.sensor, decimation_factor=10
    )
    d = diagnose(session)
    assert d.scheme != "runs", d.folds
    assert d.effects == ("thermal_lag",), d.effects
    valid = bench.simulate_session(part, seed + 1000, 1.0, bench.VALIDATION_PROFILE)
    truth = calibrate(session, terms={a: bench._lagged(a) for a in AXES})
    base = bench.validation_rms_mg(d.base, valid)
    found = bench.validation_rms_mg(d.calibration, valid)
    ideal = bench.validation_rms_mg(truth, valid)
    # Measured: base 5.04, diagnosed = ideal = 0.61 mg (the noise floor). The 5 % is
    # the validation bench's rule for "as good as the truth's model".
    assert found <= 1.05 * ideal < base, (base, found, ideal)
