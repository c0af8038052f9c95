"""A fitted sensitivity the runs' own levels contradict is said, never silent.

Two static holds, each orientation at its own temperature (a cold hold at -1 g on z,
a hot one at 0 g), as a real BMI270 recording of two holds gave: the temperature and
gravity terms of z explain the same difference between the runs, and only each
hold's drift over its degree of warming tells them apart. A settling drift inside each
hold (not the temperature's doing) then sets the offset tempco, and the sensitivity
takes what is left of the 1 g between the runs: a small standard error, a wrong value.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import accelcore
from accelcore.errors import DataQualityWarning
from accelcore.fitting.plausibility import SENSITIVITY_TOLERANCE
from accelcore.input.session import Session

COLUMNS = {"time": "time_s", "temperature": "temp_c", "x": "x", "y": "y", "z": "z"}


def _hold(
    n: int, start_c: float, gravity: tuple[float, float, float], settle_mg: float
) -> dict[str, np.ndarray]:
    """A static hold at 50 Hz that warms by 1 °C; z settles by ``settle_mg`` meanwhile."""
    rng = np.random.default_rng(int(start_c))
    t = np.arange(n) / 50.0
    temp = start_c + t / t[-1] + 0.01 * rng.standard_normal(n)
    out = np.tile(np.asarray(gravity, dtype=float), (n, 1))
    out[:, 2] += settle_mg * 1e-3 * (1.0 - np.exp(-t / 20.0))
    out += 0.002 * rng.standard_normal((n, 3))
    return {"time_s": t, "temp_c": temp, "x": out[:, 0], "y": out[:, 1], "z": out[:, 2]}


def _two_holds(settle_mg: float) -> Session:
    return Session.from_arrays(
        [
            ("OZ-", _hold(3250, 13.0, (0.0, 0.0, -1.0), settle_mg)),
            ("OX+", _hold(6550, 48.0, (1.0, 0.0, 0.0), settle_mg)),
        ],
        units="g",
        rate_hz=50.0,
        columns=COLUMNS,
    )


@pytest.mark.parametrize("settle_mg", [20.0, 60.0])
def test_a_sensitivity_the_run_levels_contradict_is_warned_and_noted(settle_mg: float) -> None:
    with pytest.warns(DataQualityWarning, match=r"z: the fitted sensitivity at T_ref") as record:
        cal = accelcore.calibrate(_two_holds(settle_mg))
    assert len(record) == 1, [str(r.message) for r in record]
    s_z = cal.axis("z").sensitivity
    # The runs' levels say 1 g/g; the fit, pulled by the settling, is far off it.
    assert abs(s_z - 1.0) > SENSITIVITY_TOLERANCE, s_z
    assert any(n.startswith("z: the fitted sensitivity") for n in cal.notes), cal.notes
    # The table's RMS is a size, whatever the sign of the sensitivity it is scaled by.
    rms = cal.summary()["rms_residual_mg"]
    assert (rms > 0).all() and math.isclose(
        rms["z"], 1000.0 * cal.axes["z"].rms_residual / abs(s_z), rel_tol=1e-12
    ), rms


def test_holds_that_settle_little_pass_without_a_word() -> None:
    """1 mg of settling: the sensitivity stays within the tolerance of the levels'."""
    cal = accelcore.calibrate(_two_holds(1.0))  # warnings are errors in this suite
    assert abs(cal.axis("z").sensitivity - 1.0) < SENSITIVITY_TOLERANCE
