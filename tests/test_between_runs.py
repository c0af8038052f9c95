"""Terms that vary only between runs are judged between runs (``accelcore.diagnosis.between``).

Each run of a session powers on with its own offset (the part's turn-on repeatability,
``simulate.events.TurnOnBias``); another session of the same part has other offsets. With
one run per orientation, the default full 3x3 gain and a second-order gain fit those
offsets, and folds inside runs cannot tell: a held-out block shares its run's offset with
the training blocks of the run. Scored as a user would: fit on one session, the RMS error
against nominal gravity on an independent session of the same part (another profile,
other turn-on offsets), against the seed paper's model.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from accelcore import simulate
from accelcore.diagnosis import diagnose
from accelcore.diagnosis.between import (
    between_runs_p,
    heldout_window_residuals,
    within_run_sse_blocks,
)
from accelcore.diagnosis.ends import starting_point
from accelcore.diagnosis.engine import Engine
from accelcore.input.session import Session
from accelcore.model import AXES
from accelcore.simulate import effects as se
from accelcore.simulate import events as sev

HOURS = 0.5


def turn_on_case(bench: ModuleType, seed: int, *part: object) -> Any:
    """A part (``part``) whose every run powers on with its own 2 mg sd offset."""
    return bench.ValidationCase(
        "turn-on scatter",
        part=(*part, sev.TurnOnBias(2.0, seed=seed)),
        validation_part=(*part, sev.TurnOnBias(2.0, seed=seed + 1000)),
        expect="rise <= 5%",
    )


@pytest.mark.parametrize("seed", [2, 3, 5])
def test_turn_on_scatter_is_not_fitted_as_the_parts(bench: ModuleType, seed: int) -> None:
    """Nothing of the part to learn: the diagnosed model is not worse than the paper's.

    Before the run-level judgement the full 3x3 gain alone took these sessions from
    1.9-2.7 mg to 2.1-3.2 mg on the validation session (0.66-0.89x). 5 % is the
    validation rule for "nothing to learn"; the error here is the validation session's
    own turn-on offsets (about 2 mg), which no calibration can predict.
    """
    out = bench.run_case(turn_on_case(bench, seed), seed, HOURS)
    assert out.diagnosed_mg <= 1.05 * out.base_mg, (out.added, out.base_mg, out.diagnosed_mg)
    assert out.added == (), out.added


def test_the_note_says_why_the_cross_axis_gains_were_left_out(bench: ModuleType) -> None:
    session = bench.simulate_session(
        (sev.TurnOnBias(2.0, seed=3),), 3, HOURS, bench.CALIBRATION_PROFILE
    )
    d = diagnose(session)
    notes = [w for w in d.warnings if w.startswith("the starting calibration's cross-axis")]
    assert len(notes) == 1, d.warnings
    rows = d.candidates[d.candidates.family == "misalignment"]
    assert set(rows.judged) == {"between runs"} and not rows.accepted.any(), rows
    for a in AXES:
        assert not any(t.kind == "gain" and t.source != a for t in d.calibration.axes[a].terms)
    assert "misalignment" not in d.effects


def test_a_real_misalignment_is_kept_beside_the_turn_on_scatter(bench: ModuleType) -> None:
    """0.5-0.9 degrees of misalignment (9-16 mg) stand far out of a 2 mg run scatter."""
    case = turn_on_case(bench, 4, se.Misalignment())
    out = bench.run_case(case, 4, HOURS)
    # The seed paper's model has no cross-axis gain: the kept ones cut its error.
    assert out.diagnosed_mg * 2.0 <= out.base_mg, (out.added, out.base_mg, out.diagnosed_mg)
    d = diagnose(bench.simulate_session(case.part, 4, HOURS, bench.CALIBRATION_PROFILE))
    assert not any(w.startswith("the starting calibration's") for w in d.warnings), d.warnings
    assert "misalignment" in d.effects, d.effects
    for a in AXES:
        assert {t.source for t in d.calibration.axes[a].terms if t.kind == "gain"} == set(AXES)


def test_a_clean_second_order_gain_is_judged_between_runs(bench: ModuleType) -> None:
    """K2 is constant in every run: the run-level test accepts it, not the blocks'."""
    session = bench.simulate_session((se.Nonlinearity(),), 2, HOURS, bench.CALIBRATION_PROFILE)
    d = diagnose(session)
    assert "nonlinearity" in d.effects, d.effects
    rows = d.candidates[(d.candidates.family == "nonlinearity") & d.candidates.accepted]
    assert set(rows.judged) == {"between runs"}, rows
    # Noise of a run's mean residual here is ~0.01 mg against K2 of several mg.
    assert float(rows.p_between_runs.max()) < 1e-6, rows


def test_the_run_level_test_counts_its_degrees_of_freedom(bench: ModuleType) -> None:
    """Six runs; per axis the offset and own gain leave 4 dof, the full gain 2, K2 one less."""
    session = bench.simulate_session(
        (sev.TurnOnBias(2.0, seed=7),), 7, HOURS, bench.CALIBRATION_PROFILE
    )
    base, specs, _ = starting_point(session, None, 25.0, None)
    assert all(s.cross for s in specs.values())
    eng = Engine(session, base, folds="auto", block_s=300.0, steady_c_per_min=0.1)
    full = {a: specs[a].terms(a) for a in AXES}
    test = between_runs_p(
        eng,
        {a: replace(specs[a], cross=()).terms(a) for a in AXES},
        full,
    )
    assert test is not None
    assert (test.dfn, test.dfd) == (6, 6)
    # Nothing added between runs: no test.
    assert between_runs_p(eng, full, full) is None
    # The 2 mg scatter: the pooled scatter of run means is that size (6 dof: within x2).
    assert 0.5 < test.scatter_mg < 6.0, test
    assert np.isfinite(test.p) and test.p >= 0.01


@pytest.mark.parametrize(
    ("effect", "family"),
    [(se.OffsetCurvature(), "offset_curvature"), (se.ThermalLag(120.0), "thermal_lag")],
)
def test_an_effect_inside_runs_is_found_under_the_runs_scatter(
    bench: ModuleType, effect: object, family: str
) -> None:
    """The calibration session's runs each power on with their own 2 mg offset; the
    validation session is the part's alone. With whole runs as folds the runs' offsets
    dominate the held-out error; judged on the held-out error inside runs, the part's
    effect is found and the validation error cut at least twice (before: the
    curvature 1.11x, the lag 3.2x with a K2 and a run event it did not have)."""
    case = bench.ValidationCase(
        "effect beside turn-on scatter", part=(effect,), events=(sev.TurnOnBias(2.0, seed=11),)
    )
    out = bench.run_case(case, 1, HOURS)
    assert family in out.added, out.added
    assert all(a == family for a in out.added), out.added
    assert out.diagnosed_mg * 2.0 <= out.base_mg, (out.added, out.base_mg, out.diagnosed_mg)


def test_window_residuals_give_the_engines_held_out_error(bench: ModuleType) -> None:
    """The held-out window residuals, squared per block with the within-window part,
    are the engine's ``sse_blocks``: the inside-runs error differs only by the levels."""
    session = bench.simulate_session((se.ThermalLag(90.0),), 5, HOURS, bench.CALIBRATION_PROFILE)
    base, specs, _ = starting_point(session, None, 25.0, None)
    eng = Engine(session, base, folds="auto", block_s=300.0, steady_c_per_min=0.1)
    for a in AXES:
        terms = specs[a].terms(a)
        r = heldout_window_residuals(eng, a, terms)
        sse = np.bincount(eng.window_block, weights=eng.window_weight * r * r) + eng._within[a]
        expected = eng.cv(a, terms).sse_blocks
        # The core scores a block from its factor's rotated residuals, here from
        # coefficients times columns: the same sums to a few hundred eps of the total
        # (the design is well conditioned, |r| ~ 1-10 mg).
        np.testing.assert_allclose(sse, expected, rtol=1e-9, atol=1e-9 * expected.sum())
        # Less each run's weighted mean: each run's total can only fall (the mean is
        # the level that minimises it), block by block it may rise.
        inside = within_run_sse_blocks(eng, a, terms)
        run_of_block = eng.sample_run[eng.block_start]
        before, after = np.bincount(run_of_block, sse), np.bincount(run_of_block, inside)
        assert np.all(after <= before * (1 + 1e-12)), (before, after)
        assert after.sum() < before.sum()


def _twelve_runs(seed: int, profile: Mapping[str, float | bool]) -> Session:
    """Six orientations twice, each run powering on with its own 2 mg sd offset."""
    halves = [
        simulate.arrays(
            "ADXL335",
            seed=s,
            duration_h=HOURS,
            effects=(sev.TurnOnBias(2.0, seed=s),),
            **profile,  # type: ignore[arg-type]
        )
        for s in (seed, seed + 500)
    ]
    runs = [(r.orientation, r.columns) for h in halves for r in h.runs]
    sim = halves[0]
    return Session.from_arrays(
        runs, units=sim.units, rate_hz=sim.rate_hz, sensor=sim.sensor, decimation_factor=10
    )


@pytest.mark.parametrize("seed", [2, 3, 4])
def test_the_run_level_test_is_not_run_on_the_axes_that_looked_largest(
    bench: ModuleType, seed: int
) -> None:
    """Twelve runs of scatter alone: a K2 is tested jointly on every axis it was tried
    on, not on those whose run-level cut was large (which made seed 3 add one: 0.92 ->
    1.14 mg on a clean session of the part)."""
    d = diagnose(_twelve_runs(seed, bench.CALIBRATION_PROFILE))
    assert d.effects == (), d.effects
    rows = d.candidates[d.candidates.family == "nonlinearity"]
    assert set(rows.judged) == {"between runs"} and not rows.accepted.any(), rows


def test_a_second_order_gain_beside_turn_on_scatter_on_every_axis_is_found(
    bench: ModuleType,
) -> None:
    """K2 with 1 mg of turn-on scatter on every axis: each axis judged on its own
    scatter (3 degrees of freedom) still finds it here (2.35 -> 1.29 mg, 1.82x).

    What judging each axis alone costs (the axes' scatters need not be alike): on
    seed 1 the same part's K2 is not found (1.00x; 1.47x against the pool of the
    three axes); on two seeds of 2 mg, 1.00x and 1.00x (1.00x and 1.32x). The pool
    would take, on 2 mg of turn-on scatter alone, a K2 that raises the error 10 %.
    """
    seed = 2
    case = bench.ValidationCase(
        "K2 + turn-on scatter",
        part=(se.Nonlinearity(), sev.TurnOnBias(1.0, seed=seed)),
        validation_part=(se.Nonlinearity(), sev.TurnOnBias(1.0, seed=seed + 1000)),
    )
    out = bench.run_case(case, seed, HOURS)
    assert "nonlinearity" in out.added, out.added
    assert out.diagnosed_mg < out.base_mg, (out.base_mg, out.diagnosed_mg)


@dataclass(frozen=True)
class _SupplyPerRun:
    """A bench supply set per run (2.2-3.6 V), logged with a meter's noise; the offset follows.

    The offset moves (3, -2, 8) mg per volt from 3 V. ``seed`` draws the runs' settings
    (another session of the part: other settings); the meter's noise (``noise_v`` rms)
    is its own draw per run.
    """

    noise_v: float = 0.0005
    seed: int = 7

    @property
    def name(self) -> str:
        return "supply_per_run"

    @property
    def stage(self) -> str:
        return "output"

    def volts(self, orientation: str) -> float:
        return float(np.random.default_rng([self.seed, *map(ord, orientation)]).uniform(2.2, 3.6))

    def apply(self, state: Any, rng: np.random.Generator) -> None:
        mg = np.array([3.0, -2.0, 8.0]) * (self.volts(state.orientation) - 3.0)
        per_g = state.truth.sensitivity_per_g  # output units per g
        state.output = state.output + mg / 1000.0 * per_g * np.ones((state.time_s.size, 1))

    def extra_columns(self, time_s: np.ndarray, orientation: str) -> dict[str, np.ndarray]:
        rng = np.random.default_rng([self.seed + 100, *map(ord, orientation)])
        noise = rng.normal(0.0, self.noise_v, np.asarray(time_s).size)
        return {"supply_v": np.round(self.volts(orientation) + noise, 5)}


@pytest.mark.parametrize("noise_v", [0.0, 0.0005])
def test_a_column_set_per_run_is_judged_between_runs_through_its_noise(
    bench: ModuleType, noise_v: float
) -> None:
    """The supply's information is all in its run means; inside runs it is the meter's
    noise, which drives nothing. Logged exactly constant it was judged between runs and
    found (3.45x); with 0.5 mV of noise it went to the test inside runs, which takes each
    run's mean out, and nothing was added (1.00x). Now a column whose variation inside
    runs is a tiny share of its whole is constant in every run for the tests."""
    case = bench.ValidationCase(
        "supply set per run",
        part=(_SupplyPerRun(noise_v, seed=7),),
        validation_part=(_SupplyPerRun(noise_v, seed=8),),
    )
    out = bench.run_case(case, 1, HOURS)
    assert out.added == ("extra:supply_v",), out.added
    assert out.diagnosed_mg * 2.0 <= out.base_mg, (out.base_mg, out.diagnosed_mg)


def test_a_k2_from_one_run_per_sign_says_so(bench: ModuleType) -> None:
    """Six runs: each axis' K2 rests on its +1 g and -1 g run, which a warning names;
    twelve runs (each orientation twice) do not, and nothing is said."""
    six = diagnose(
        bench.simulate_session((se.Nonlinearity(),), 2, HOURS, bench.CALIBRATION_PROFILE)
    )
    assert "nonlinearity" in six.effects, six.effects
    said = [w for w in six.warnings if w.startswith("nonlinearity (K2) on ")]
    assert len(said) == 1, six.warnings
    assert "x (OX+/OX-)" in said[0] and "z (OZ+/OZ-)" in said[0], said
    halves = [
        simulate.arrays(
            "ADXL335",
            seed=s,
            duration_h=HOURS,
            effects=(se.Nonlinearity(),),
            **bench.CALIBRATION_PROFILE,
        )
        for s in (2, 502)
    ]
    runs = [(r.orientation, r.columns) for h in halves for r in h.runs]
    twelve = diagnose(
        Session.from_arrays(
            runs,
            units=halves[0].units,
            rate_hz=halves[0].rate_hz,
            sensor=halves[0].sensor,
            decimation_factor=10,
        )
    )
    assert "nonlinearity" in twelve.effects, twelve.effects
    assert not [w for w in twelve.warnings if w.startswith("nonlinearity (K2)")], twelve.warnings
