"""A session of one record: the board still in one orientation while it heats.

PX4's and ArduPilot's thermal calibrations log such sessions (a cold soak, then heating
to 60 °C or so). With one record, a jump of the residual where the temperature's course
turns (the soak ends, a lag's onset on an axis that was not given the lag) cannot be
told from the part's own response: no other run lacks it. It was taken as a session
event, left out of the calibration, and the offsets became the level of the soak
before it (x and y 0.50 -> 1.33 mg on a validation session of the same part).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from accelcore.diagnosis import diagnose, residuals
from accelcore.fitting.calibrate import calibrate
from accelcore.input.session import Session
from accelcore.model import AXES, base_terms
from accelcore.simulate import Effect, RunState, Stage
from accelcore.simulate import effects as se
from test_diagnosis import make_session


@dataclass(frozen=True)
class _Heating:
    """Chamber and die follow ``t0 -> t1`` after a soak: Newtonian, ``tau_min``."""

    t0_c: float
    t1_c: float
    tau_min: float
    soak_min: float

    @property
    def name(self) -> str:
        return "heating_profile"

    @property
    def stage(self) -> Stage:
        return "temperature"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        t_min = (state.time_s - state.time_s[0]) / 60.0
        rise = 1.0 - np.exp(-np.clip(t_min - self.soak_min, 0.0, None) / self.tau_min)
        temp = self.t0_c + (self.t1_c - self.t0_c) * rise
        state.chamber_temp_c, state.die_temp_c = temp.copy(), temp.copy()
        state.logged_temp_c = temp + rng.normal(0.0, 0.02, temp.shape)


@dataclass(frozen=True)
class _Ramps:
    """Chamber and die piecewise linear through ``points`` (minutes, °C)."""

    points: tuple[tuple[float, float], ...]

    @property
    def name(self) -> str:
        return "ramps_profile"

    @property
    def stage(self) -> Stage:
        return "temperature"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        t_min, temp_c = np.asarray(self.points, dtype=np.float64).T
        temp = np.interp((state.time_s - state.time_s[0]) / 60.0, t_min, temp_c)
        state.chamber_temp_c, state.die_temp_c = temp.copy(), temp.copy()
        state.logged_temp_c = temp + rng.normal(0.0, 0.02, temp.shape)


def _one_record(
    profile: _Heating | _Ramps, seed: int, part: tuple[Effect, ...] = (se.ThermalLag(120.0),)
) -> Session:
    """One orientation (OZ-), the chamber following ``profile``, 1 h at 20 Hz -> 2 Hz."""
    return make_session(
        (profile, *part),
        seed,
        orientations=("OZ-",),
        soak_min=0.0,
        probe_noise_c=0.0,
    )


def _rms_mg(calibration: Any, session: Session) -> float:
    res = residuals(calibration, session)
    temp = res["temperature_c"].to_numpy()
    keep = (temp >= 0.0) & (temp <= 60.0)
    err = res.loc[keep, [f"err_{a}_mg" for a in AXES]].to_numpy()
    return float(np.sqrt(np.mean(err**2)))


def test_a_jump_in_the_only_record_is_not_a_session_event() -> None:
    fit_on = _one_record(_Heating(-8.0, 62.0, 18.0, 3.0), 1)
    check_on = _one_record(_Heating(-3.0, 62.0, 12.0, 8.0), 1001)
    d = diagnose(fit_on)
    assert d.session_events == (), d.session_events
    assert any("the session's only record" in w for w in d.warnings), d.warnings
    assert "thermal_lag" in d.effects, d.effects
    base = calibrate(fit_on, terms={a: base_terms(a) for a in AXES})
    # Before: a step at 224.5 s and 1.35 mg against 4.11 for the seed paper's model
    # (x and y at the soak's level); now 0.69. The noise floor of a 2 Hz sample is
    # 0.60 mg; a lag fitted from one heating leaves a few tenths of a mg on z.
    assert 2.0 * _rms_mg(d.calibration, check_on) <= _rms_mg(base, check_on)
    assert _rms_mg(d.calibration, check_on) <= 0.8


def test_a_record_that_only_heats_is_held_out_across_its_temperatures() -> None:
    """Uneven heating (2.6, 0.7, 2.2, 0.5, 0.3 °C/min) of a part with a 60 s lag and a
    cubic offset. Held out in contiguous thirds of the run, each fold was a third of the
    temperature range, extrapolated: the curvature lost to a lag at the end of its
    range, 3.58 mg on another session of the part against 3.52 for the seed paper's
    model. Blocks in turn span the range: the curvature and the lag, 0.66 mg."""
    part = (se.ThermalLag(60.0), se.OffsetCurvature((0.004, -0.003, 0.008), (2e-4, -2e-4, 3e-4)))
    heating = ((0, -6), (4, -6), (14, 20), (20, 24), (32, 50), (45, 56), (60, 60))
    fit_on = _one_record(_Ramps(heating), 1, part)
    check_on = _one_record(_Heating(-4.0, 64.0, 28.0, 6.0), 1001, part)
    d = diagnose(fit_on)
    assert d.scheme == "blocks", d.scheme
    assert {"offset_curvature", "thermal_lag"} <= set(d.effects), d.effects
    base = calibrate(fit_on, terms={a: base_terms(a) for a in AXES})
    # The noise floor is 0.60 mg; the fitted lag and curvature leave a few hundredths.
    assert _rms_mg(d.calibration, check_on) <= 0.75
    assert 2.0 * _rms_mg(d.calibration, check_on) <= _rms_mg(base, check_on)


#: The validation sessions' heating: uneven ramps (1.6, 1.6, 2.6, 0.2 °C/min) after a soak.
_OTHER_HEATING = ((0, -3), (8, -3), (16, 10), (35, 40), (42, 58), (60, 62))


def test_a_warm_up_from_power_on_is_not_taken_for_the_part() -> None:
    """A warm-up of 10 mg (300 s) from power-on, where Newtonian heating starts too.

    In this one record a lag's rate term decays from the start as the warm-up does:
    it cut the held-out error by 62 % on x and y, the warm-up (a session event) by 71 %.
    The lag was added, carried into another session of the part that had no warm-up,
    and raised its error (1.98 -> 2.33 mg). A part effect that follows a session event
    less well than the event itself, on every axis it would be added to, is not taken.
    """
    fit_on = _one_record(_Heating(-8.0, 62.0, 18.0, 3.0), 1, (se.WarmUp(10.0, 300.0),))
    check_on = _one_record(_Ramps(_OTHER_HEATING), 1001, ())
    d = diagnose(fit_on)
    assert not {"thermal_lag", "offset_curvature"} & set(d.effects), d.effects
    base = calibrate(fit_on, terms={a: base_terms(a) for a in AXES})
    assert "event: warm-up" in d.effects, d.effects
    # The warm-up biases the base fit: 1.98 mg on the other session (2.33 with the lag).
    # Fitted beside the model as an event (x and y; on z, twice as noisy, it does not
    # pass alone), 1.28 mg: the rule for session events is a cut of 1.5x.
    assert 1.5 * _rms_mg(d.calibration, check_on) <= _rms_mg(base, check_on)


def test_a_self_heating_part_is_not_given_a_lag_the_warm_up_beats() -> None:
    """The die self-heats 3 °C (300 s) after every power-on, the logged board
    temperature does not see it: its offset decays from power-on in both sessions. In
    one record heated from power-on a lag's rate term took it on z (1.18 -> 1.37 mg on
    another session); a warm-up follows it better (z 0.96 against 1.04 mg held out),
    and neither is the part's to carry from one record: the base model is kept."""
    part = (_SelfHeat(3.0, 300.0),)
    fit_on = _one_record(_Heating(-8.0, 62.0, 18.0, 3.0), 1, part)
    check_on = _one_record(_Ramps(_OTHER_HEATING), 1001, part)
    d = diagnose(fit_on)
    assert "thermal_lag" not in d.effects, d.effects
    base = calibrate(fit_on, terms={a: base_terms(a) for a in AXES})
    # At most the 5 % the diagnosis may add where the part has nothing it can carry.
    assert _rms_mg(d.calibration, check_on) <= 1.05 * _rms_mg(base, check_on)


@dataclass(frozen=True)
class _SelfHeat:
    """The die self-heats ``rise_c`` (first order, ``tau_s``) from power-on, unlogged."""

    rise_c: float
    tau_s: float

    @property
    def name(self) -> str:
        return "self_heating"

    @property
    def stage(self) -> Stage:
        return "temperature"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        t = state.time_s - state.time_s[0]
        state.die_temp_c = state.die_temp_c + self.rise_c * (1.0 - np.exp(-t / self.tau_s))
