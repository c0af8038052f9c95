"""The per-sample error the windows leave out, and families made redundant by later ones.

The case is one nobody named to the diagnosis: the part's sensitivity follows the rate
of change of temperature (a thermal gradient across the package stressing it), 0.3-0.5
%/(°C/min). The logged temperature is a noisy probe, so its rate jitters from sample to
sample. Before these changes the diagnosis fitted sixteen hinges of that rate, whose
window means matched closely (held-out cut 80 % on window means) while per sample the
same coefficients raised the held-out error of z from 7.0 to 11.6 mg; and it chose a
linear sensitivity drift on x and y first (the heating leg comes before the cooling leg
in every run) and kept it after the rate's terms. On an independent session of the
same part: 3.27 -> 1.99 mg (1.64x); now 1.50-1.51 mg (2.2x). (The sensitivity is now
one family over the axes, so the drift is no longer chosen first on this session; the
test of redundancy is below, on the same session's engine.)
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from accelcore.diagnosis import diagnose, selection
from accelcore.diagnosis.inside import excess, is_rough, per_sample
from accelcore.diagnosis.result import Diagnosis
from accelcore.diagnosis.space import Spec, without
from accelcore.diagnosis.verdicts import judge, redundant
from accelcore.model import AXES, Extra, Hinge, TemperatureRate, Term
from accelcore.simulate.chain import RunState
from helpers import chamber_rate_c_per_min

HOURS = 1.0


@dataclass(frozen=True)
class SensitivityVsRate:
    """Sensitivity ``S (1 + c/100 dT/dt)``, ``c`` in %/(°C/min) per axis (not in the catalogue)."""

    pct_per_c_per_min: tuple[float, float, float] = (0.3, -0.3, 0.5)
    name: str = "sensitivity_vs_rate"
    stage: str = "response"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        rel = np.asarray(self.pct_per_c_per_min) / 100.0 * chamber_rate_c_per_min(state)[:, None]
        state.output = state.output + rel * state.truth.sensitivity_per_g * state.specific_force_g


@pytest.fixture(scope="module")
def rate_case(bench: ModuleType) -> Any:
    return bench.ValidationCase("sensitivity vs dT/dt", part=(SensitivityVsRate(),))


@pytest.fixture(scope="module")
def rate_diagnosis(bench: ModuleType) -> Diagnosis:
    session = bench.simulate_session((SensitivityVsRate(),), 1, HOURS, bench.CALIBRATION_PROFILE)
    return diagnose(session)


@pytest.mark.parametrize("seed", [1, 2])
def test_an_unnamed_sensitivity_vs_rate_is_cut_on_another_session(
    bench: ModuleType, rate_case: Any, seed: int
) -> None:
    """The rule of an effect that repeats: the validation error cut by 2x or more.

    Measured 2.19x and 2.17x for seeds 2 and 1 (1.61-1.68x before); a calibration that
    knows the truth reaches 4.4x (its rate is the model's 60 s causal rate, not the
    simulator's centred one, which is why the hinges fit at all).
    """
    out = bench.run_case(rate_case, seed, HOURS)
    assert out.ratio >= 2.0, (out.added, out.base_mg, out.diagnosed_mg)
    assert "drift" not in out.added, out.added


def test_no_step_raises_the_per_sample_held_out_error(rate_diagnosis: Diagnosis) -> None:
    """The step figures are per sample; each accepted step must not raise any axis'.

    Before: z 7.05 -> 11.62 mg at the step the diagnosis claimed an 80 % cut. 1 % is
    room for a step judged inside runs whose run-fold figure moves by its noise.
    """
    steps = rate_diagnosis.steps
    for before, after in itertools.pairwise(steps):
        for a in after.axes:
            assert after.rms_out_axis_mg[a] <= 1.01 * before.rms_out_axis_mg[a], (
                after.effect,
                a,
                before.rms_out_axis_mg[a],
                after.rms_out_axis_mg[a],
            )


def test_the_corrected_error_is_the_per_sample_error(rate_diagnosis: Diagnosis) -> None:
    """The engine's window-level error of a model of sixteen rate hinges, and per sample.

    Per sample (the residuals of the fold that held each sample out, squared and summed
    per block, from the engine's per-sample fit) is the truth; the window-level figure
    is some eighty times too small (0.72 against 58 mg² x 1e6); per sample, each block's
    figure is the truth's.
    """
    eng = rate_diagnosis._engine
    assert eng is not None
    axis, family = "z", "sensitivity vs dtemp_dt_c_per_min"
    terms = (*Spec().terms(axis), *_generic_terms(eng, axis, family))
    cv = eng.cv(axis, terms)
    _, r_out = eng.residuals(axis, terms)
    by_block = np.bincount(eng.sample_block, weights=eng.w * r_out * r_out)
    truth = float(by_block.sum())
    window_level = float(cv.sse_blocks.sum())
    assert is_rough(eng, axis, terms)
    fixed = per_sample(eng, axis, cv)
    assert fixed.per_sample and per_sample(eng, axis, fixed) is fixed
    assert window_level < 0.1 * truth, (window_level, truth)
    # The same sums in another order: rounding of ~1e5 terms of ~1e3 mg².
    np.testing.assert_allclose(fixed.sse_blocks, by_block, rtol=1e-9, atol=1e-6 * truth)


def _generic_terms(eng: Any, axis: str, family: str) -> list[Term]:
    """The line and sixteen-piece hinges of the rate in ``axis``' sensitivity.

    Evenly spaced over the rate's 5-95 % span, as the generic family placed them before
    it kept knots only where the data dwells (``tests/test_generic_support.py``).
    """
    rate = eng.basis(TemperatureRate())[eng.w > 0]
    lo, hi = (float(x) for x in np.quantile(rate, [0.05, 0.95]))
    knots = [round(lo + k / 16 * (hi - lo), 2) for k in range(1, 16)]
    line = Term("gain", TemperatureRate(), source=axis, effect=family)
    return [line] + [
        Term("gain", Hinge(k, TemperatureRate()), source=axis, effect=family) for k in knots
    ]


def test_a_smooth_model_keeps_its_window_figures(rate_diagnosis: Diagnosis) -> None:
    """The paper's model moves along straight lines inside windows: nothing to add."""
    eng = rate_diagnosis._engine
    assert eng is not None
    for a in AXES:
        terms = Spec().terms(a)
        assert not is_rough(eng, a, terms)
        # Its per-sample and window-level errors differ by what the temperature's ramp
        # inside a window explains of this part's within-window moves: 0.04-0.9 % here
        # (x-z), far below the least improvement (10 %) a decision turns on.
        sse = float(eng.cv(a, terms).sse_blocks.sum())
        assert abs(float(excess(eng, a, terms).sum())) < 0.02 * sse


def test_a_drift_beside_the_rate_terms_is_redundant(rate_diagnosis: Diagnosis) -> None:
    """Judged as if added last, a linear drift of x's sensitivity beside the rate's terms.

    On this session (heating before cooling in every run) the drift alone cuts x's
    error by a third; beside the sensitivity's terms of the rate it no longer passes.
    The rate's terms beside the drift still do.
    """
    eng = rate_diagnosis._engine
    assert eng is not None
    rate = "sensitivity vs dtemp_dt_c_per_min"
    found = rate_diagnosis.calibration.axes["x"].terms
    assert any(t.effect == rate for t in found), found
    spec = Spec(gain_drift=True, generic=tuple(t for t in found if t.effect == rate))
    specs = {a: spec for a in AXES}
    added = [("drift", ("x",)), (rate, ("x",))]
    out = redundant(eng, specs, added, min_improvement=0.10, alpha=0.01)
    assert [(c.family, c.axis) for c in out] == [("drift", "x")], [c.row for c in out]
    assert out[0].cut < 0.10, out[0].row


def test_a_redundant_family_is_left_out_and_said(
    bench: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The selection starts again without it, says so, and marks its rows."""
    session = bench.simulate_session((SensitivityVsRate(),), 2, 0.5, bench.CALIBRATION_PROFILE)
    real = redundant
    calls: list[int] = []

    def first_finds_the_rate(*args: Any, **kwargs: Any) -> list[Any]:
        found = real(*args, **kwargs)
        calls.append(len(found))
        if len(calls) > 1:
            return found
        # The first pass' first family, as if a later one had made it redundant on x.
        eng, specs, added = args[0], args[1], args[2]
        family = added[0][0]
        with_it = eng.cv("x", specs["x"].terms("x"))
        cand = judge(eng, 0, "x", family, [(family, "", with_it, specs["x"])], with_it, 0.1, 0.01)
        return [cand]

    monkeypatch.setattr(selection, "redundant", first_finds_the_rate)
    d = diagnose(session)
    notes = [w for w in d.warnings if "left out: beside the effects chosen after it" in w]
    assert len(notes) == 1 and len(calls) == 2, (d.warnings, calls)
    family = notes[0].split(" on x left out")[0]
    rows = d.candidates[(d.candidates.family == family) & (d.candidates.axis == "x")]
    assert len(rows) and set(rows.judged) == {"left out (redundant beside later effects)"}
    assert not rows.accepted.any()
    assert all(t.effect != family for t in d.calibration.axes["x"].terms)


@pytest.mark.parametrize(
    ("family", "changed"),
    [
        ("offset_curvature", {"offset_order": 1}),
        ("sensitivity_curvature", {"gain_order": 1}),
        ("thermal_lag", {"tau": None, "rate_tau": None}),
        ("misalignment", {"cross": ()}),
        ("nonlinearity", {"squares": ()}),
        ("drift", {"drift": False, "gain_drift": False}),
        ("extra:supply_v", {"extras": ("humidity",)}),
    ],
)
def test_without_takes_out_one_family(family: str, changed: dict[str, Any]) -> None:
    hinge = Term("offset", "dTdt", effect="offset vs dtemp_dt_c_per_min")
    spec = Spec(
        tau=90.0,
        rate_tau=None,
        offset_order=3,
        gain_order=2,
        cross=("y", "z"),
        squares=("x",),
        drift=True,
        gain_drift=True,
        extras=("supply_v", "humidity"),
        generic=(hinge,),
    )
    assert without(spec, family) == replace(spec, **changed)


def test_without_takes_out_a_generic_family_by_its_terms() -> None:
    a = Term("offset", "dTdt", effect="offset vs dtemp_dt_c_per_min")
    b = Term("offset", Extra("supply_v"), source=None, effect="offset vs supply_v")
    spec = Spec(generic=(a, b))
    assert without(spec, "offset vs dtemp_dt_c_per_min") == Spec(generic=(b,))
    assert without(spec, "gain on g_x vs temperature_c") == spec
