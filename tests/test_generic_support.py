"""The generic family where its data dwells, and the sensitivity as one family over axes.

Two effects nobody named to the diagnosis, scored as a user would (fit on a calibration
session, the RMS error against nominal gravity on an independent session of the same
part: another temperature profile, another seed):

- an offset tempco that differs between heating and cooling (0.04-0.08 mg/°C, of
  opposite signs on the two legs): the model space has no term for it. Before, hinges
  of dT/dt at ±1.34 °C/min, between the values a chamber's rate dwells at (0 and the
  ramps' ±2.7 °C/min), were fitted to the few samples of each ramp's start and end; the
  validation session, ramping at 1.5 °C/min, got what those fitted: 1.24 -> 17.6 mg.
- a sensitivity that follows a logged supply (10 %/V on every axis). On z the
  calibration session's supply happened to follow the temperature profile, and a
  sensitivity curvature explained the z runs as well: it was chosen there (a named
  family is preferred), and the supply's terms on x and y as two families of their
  own; the validation session: 2.13 -> 2.23 mg. One family over the axes now: 0.61 mg.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import ModuleType, SimpleNamespace
from typing import Any

import numpy as np
import pytest

from accelcore.diagnosis.generic import KNOT_FRACTIONS, _count_near, _knots, knot_label
from accelcore.model import TemperaturePower, TemperatureRate
from accelcore.simulate.chain import RunState, Stage
from helpers import chamber_rate_c_per_min

HOURS = 1.0


def _mg(state: RunState, mg: np.ndarray) -> np.ndarray:
    return mg / 1000.0 * state.truth.sensitivity_per_g


@dataclass(frozen=True)
class LegTempco:
    """Offset ``±c (T - 25)`` mg, ``+`` heating, ``-`` cooling (smoothly through 0 at a turn)."""

    mg_per_c: tuple[float, float, float] = (0.05, -0.04, 0.08)
    name: str = "leg_tempco"
    stage: str = "response"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        leg = np.tanh(chamber_rate_c_per_min(state) / 0.12)[:, None]
        dt = (state.die_temp_c - 25.0)[:, None]
        state.output = state.output + _mg(state, np.asarray(self.mg_per_c) * leg * dt)


@dataclass(frozen=True)
class SupplyGain:
    """Sensitivity ``S (1 + k (V - 3.3))`` on every axis, ``V`` logged as ``vdd_v``."""

    pct_per_v: float = 10.0
    seed: int = 5
    name: str = "supply_gain"
    stage: str = "output"

    def vdd(self, time_s: np.ndarray, orientation: str) -> np.ndarray:
        t = np.asarray(time_s, dtype=np.float64)
        t = t - t[0]
        key = sum((i + 1) * ord(c) for i, c in enumerate(orientation))
        phase = np.random.default_rng([self.seed, key]).uniform(0.0, 2.0 * math.pi)
        return np.asarray(3.3 + 0.05 * np.sin(2.0 * math.pi * t / 1700.0 + phase))

    def extra_columns(self, time_s: np.ndarray, orientation: str) -> dict[str, np.ndarray]:
        return {"vdd_v": np.round(self.vdd(time_s, orientation), 4)}

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        dv = (self.vdd(state.time_s, state.orientation) - 3.3)[:, None]
        sens = state.truth.sensitivity_per_g
        state.output = state.output + self.pct_per_v / 100.0 * dv * sens * state.specific_force_g


@dataclass(frozen=True)
class SensitivityVsRateZ:
    """Sensitivity ``S (1 + 0.5/100 dT/dt)`` on every axis (°C/min; z is the one that shows)."""

    pct_per_c_per_min: float = 0.5
    name: str = "sensitivity_vs_rate"
    stage: Stage = "response"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        rel = self.pct_per_c_per_min / 100.0 * chamber_rate_c_per_min(state)[:, None]
        state.output = state.output + rel * state.truth.sensitivity_per_g * state.specific_force_g


@pytest.mark.parametrize("seed", [1, 2])
def test_a_leg_dependent_tempco_is_not_made_worse(bench: ModuleType, seed: int) -> None:
    """Nothing the model space can hold: the rule of "nothing to learn", 5 % (was 14x worse)."""
    case = bench.ValidationCase("leg tempco", part=(LegTempco(),), expect="rise <= 5%")
    out = bench.run_case(case, seed, HOURS)
    assert out.diagnosed_mg <= 1.05 * out.base_mg, (out.added, out.base_mg, out.diagnosed_mg)


@pytest.mark.parametrize("seed", [1, 2])
def test_a_supply_driven_sensitivity_is_one_family(bench: ModuleType, seed: int) -> None:
    """The rule of an effect that repeats, 2x: measured 3.50x and 3.52x (at the noise floor)."""
    case = bench.ValidationCase("sensitivity vs vdd", part=(SupplyGain(),))
    out = bench.run_case(case, seed, HOURS)
    assert out.ratio >= 2.0, (out.added, out.base_mg, out.diagnosed_mg)
    assert out.added == ("sensitivity vs vdd_v",), out.added


def test_no_knot_between_the_values_a_rate_dwells_at() -> None:
    """A chamber's rate: soaks at 0 (20 %), ramps at ±2.7 °C/min, a few transients between.

    Evenly spaced over the 5-95 % span, the knots would be at -1.34, 0 and 1.34; within
    half a spacing of ±1.34 there are only transients (2 % of the samples, against the
    12.5 % half an even spread would put there): only the knot at 0 stays.
    """
    rng = np.random.default_rng(0)
    v = np.concatenate(
        [
            rng.normal(0.0, 0.05, 2000),
            rng.normal(-2.7, 0.05, 4000),
            rng.normal(2.7, 0.05, 4000),
            rng.uniform(-2.7, 2.7, 200),
        ]
    )
    lo, hi = (float(x) for x in np.quantile(v, [0.05, 0.95]))
    assert _knots(np.sort(v), (lo, hi), KNOT_FRACTIONS) == (0.0,)


@pytest.mark.parametrize("seed", range(6))
def test_the_count_near_a_knot_is_the_plain_test_s(seed: int) -> None:
    """Counted by bisection of the sorted samples, exactly as ``abs(v - raw) <= reach``.

    Samples are put on the band's edges and one ulp either side of them (and repeated,
    as a logged temperature's are), where a count by place alone could differ.
    """
    rng = np.random.default_rng(seed)
    raw, reach = float(rng.uniform(-30, 30)), float(rng.uniform(1e-3, 10))
    edges = [raw - reach, raw + reach]
    near_edges = [np.nextafter(e, d) for e in edges for d in (-np.inf, np.inf)]
    v = np.sort(
        np.concatenate(
            [
                rng.uniform(raw - 3 * reach, raw + 3 * reach, 500),
                np.repeat(np.round(rng.uniform(raw - 2 * reach, raw + 2 * reach, 40), 2), 5),
                np.repeat([*edges, *near_edges], 3),
            ]
        )
    )
    for r, h in [(raw, reach), (raw, 1e-12), (float(v[10]), reach), (raw + 5 * reach, reach)]:
        assert _count_near(v, r, h) == np.count_nonzero(np.abs(v - r) <= h)


def test_a_temperature_spread_over_its_span_keeps_every_knot() -> None:
    v = np.linspace(-2.0, 65.0, 10_000)
    lo, hi = (float(x) for x in np.quantile(v, [0.05, 0.95]))
    found = _knots(v, (lo, hi), KNOT_FRACTIONS)
    expected = [lo + q * (hi - lo) for q in KNOT_FRACTIONS]
    # Rounded to a hundredth of the span's decade (0.1 °C here).
    np.testing.assert_allclose(found, expected, atol=0.05)


def test_the_rate_s_line_alone_on_two_orientations(bench: ModuleType) -> None:
    """OZ+ and OZ- only: the folds are the heating and the cooling leg.

    A hinge of dT/dt at 0, fitted on the heating leg alone, says nothing of the cooling
    leg (its held-out error was 100 times the base's and the rate was left out: 4.30 mg
    on the validation session, 1.00x); the line alone is a variant of its own: 0.81 mg,
    5.28x. The rule of an effect that repeats: 2x.
    """
    from accelcore import calibrate, simulate
    from accelcore.diagnosis import diagnose
    from accelcore.input.session import Session
    from accelcore.model import AXES, base_terms
    from accelcore.simulate import effects as se

    effect = SensitivityVsRateZ()

    def session(seed: int, profile: Any) -> Session:
        sim = simulate.arrays(
            "ADXL335",
            seed=seed,
            duration_h=HOURS,
            effects=(effect,),
            orientations=("OZ+", "OZ-"),
            **profile,
        )
        se.attach_extra_columns(sim, (effect,))
        runs = [(r.orientation, r.columns) for r in sim.runs]
        return Session.from_arrays(
            runs, units=sim.units, rate_hz=sim.rate_hz, sensor=sim.sensor, decimation_factor=10
        )

    fit_on = session(1, bench.CALIBRATION_PROFILE)
    check_on = session(1001, bench.VALIDATION_PROFILE)
    d = diagnose(fit_on)
    assert "sensitivity vs dtemp_dt_c_per_min" in d.effects, d.effects
    base = calibrate(fit_on, terms={a: base_terms(a) for a in AXES})
    ratio = bench.validation_rms_mg(base, check_on) / bench.validation_rms_mg(
        d.calibration, check_on
    )
    assert ratio >= 2.0, (ratio, d.effects)


def test_knots_are_named_in_the_observable_s_own_values() -> None:
    """A temperature's knots are held in dT = T - t_ref; the label names temperatures
    (it had printed the dT values with the unit °C: "knots -18.8 °C" for 6.2 °C)."""
    eng: Any = SimpleNamespace(t_ref_c=25.0)
    assert knot_label(eng, TemperaturePower(1), (-18.8, 3.1)) == "knots 6.2/28.1 °C"
    assert knot_label(eng, TemperatureRate(), (-0.022, 0.5)) == "knots -0.022/0.5 °C/min"
