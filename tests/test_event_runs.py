"""A run whose level is off on some axis has its level free on every axis.

A knock or a power glitch at the start of a run moves every axis of that run. The
events search finds such a level on the axes that read 0 g in the run
(``accelcore.diagnosis.events``); on the axis that reads +1 or -1 g there, one run's
level is, between runs, half a sensitivity and half a second-order gain (K2), so the
selection took it for a K2 of the part (``nonlinearity``), and the validation session
of the same part paid for it. Now, on the pass that chooses the effects again on the
output less the events, the run's level is free on every axis in the tests between
runs (``between.between_runs_p``), and it is looked for on the ±1 g axes too
(``events.levels_on_every_axis``). Scored as a user would: fit on the calibration
session, the RMS error against nominal gravity on an independent session of the same
part (another profile and seed) without the event.

And a step (``events.find_run_events``) must hold fitted on every sample: a local jump
that stands out of a run's one noise scale (the noise grows at the hot end) is not one.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from accelcore import simulate
from accelcore.diagnosis import diagnose
from accelcore.diagnosis.between import RunLevelTest, between_runs_p
from accelcore.diagnosis.ends import starting_point
from accelcore.diagnosis.engine import Engine
from accelcore.diagnosis.space import Spec
from accelcore.input.session import Session
from accelcore.model import AXES
from accelcore.simulate import effects as se
from accelcore.simulate import events as sev
from accelcore.simulate.chain import Effect
from helpers import simulated_session

HOURS = 0.5

#: One run's level on every axis (mg): what a shared reference or a knock would do.
LEVEL_MG = (-3.0, 3.0, -4.5)


@pytest.mark.parametrize(("run", "seed"), [("OY+", 1), ("OX-", 2)])
def test_one_runs_level_on_every_axis_is_an_event_not_a_k2(
    bench: ModuleType, run: str, seed: int
) -> None:
    """Before: ``nonlinearity`` added on the ±1 g axis of the run and 0.93 mg on the
    validation session (1.06x the paper's model); now the run's level on all three
    axes and 0.61 mg, the part's clean calibration (ideal)."""
    case = bench.ValidationCase(
        "one run's level on every axis", events=(sev.OutputStep(run, 0.0, LEVEL_MG),)
    )
    out = bench.run_case(case, seed, HOURS)
    assert out.added == (f"event: level of run {run}",), out.added
    # The ideal is the clean session's calibration; the noise of two 0.5 h fits
    # (0.6 mg per sample, ~1e5 samples) moves the validation error by well under 1 %.
    assert out.diagnosed_mg <= 1.02 * out.ideal_mg, (out.diagnosed_mg, out.ideal_mg)
    session = bench.simulate_session(case.events, seed, HOURS, bench.CALIBRATION_PROFILE)
    d = diagnose(session)
    axes = {e["axis"] for e in d.session_events if e["event"] == f"level of run {run}"}
    assert axes == set(AXES), d.session_events
    for e in d.session_events:
        k = AXES.index(e["axis"])
        # Each level within 5 se (a few hundredths of a mg) of what was injected.
        assert abs(e["value"] - LEVEL_MG[k]) <= max(5 * e["se"], 0.05), e
    # No effect added, yet the calibration is not the base's: the report says the base's
    # terms were fitted beside the event, and that both held-out errors are of the
    # output less it (the same words a real log needed: real22).
    text = d.text()
    assert d.effects == () and "refitted beside the session events below" in text, text
    assert "Held-out error per axis (RMS, mg, on the output less the session events)" in text


def test_a_free_run_level_leaves_a_k2_nothing_to_test(bench: ModuleType) -> None:
    """Between runs, K2 on y adds the +1 g run's level to the offset and sensitivity: with
    that run's level free it adds no dimension, and there is no test to pass."""
    session = bench.simulate_session((), 3, HOURS, bench.CALIBRATION_PROFILE)
    base, _, _ = starting_point(session, None, 25.0, None)
    bare = {a: Spec().terms(a) for a in AXES}
    k2 = {"y": Spec(squares=("y",)).terms("y")}

    def k2_test(event_runs: frozenset[str]) -> RunLevelTest | None:
        eng = Engine(session, base, folds="auto", block_s=300.0, steady_c_per_min=0.1)
        eng.event_runs = event_runs  # as Engine.less sets it, before any figure is kept
        return between_runs_p(eng, bare, k2)

    test = k2_test(frozenset())
    assert test is not None and test.dfn == 1
    assert k2_test(frozenset({"OY+"})) is None
    # A run whose level says nothing of y's K2 (y reads 0 g in it) leaves the test: one
    # degree of freedom fewer.
    fewer = k2_test(frozenset({"OZ+"}))
    assert fewer is not None and fewer.dfn == 1 and fewer.dfd == test.dfd - 1


@dataclass(frozen=True)
class _NoiseGrowingHot:
    """White output noise that grows above 25 °C: 1x the part's own at 45 °C, 2x at 65 °C."""

    @property
    def name(self) -> str:
        return "noise_growing_hot"

    @property
    def stage(self) -> str:
        return "output"

    def apply(self, state: Any, rng: np.random.Generator) -> None:
        sigma_g = np.asarray(simulate.default_noise_g("ADXL335"))
        grow = (np.clip(state.die_temp_c - 25.0, 0.0, None) / 20.0)[:, None]
        noise = rng.normal(size=state.output.shape) * sigma_g * grow
        state.output = state.output + noise * state.truth.sensitivity_per_g


@pytest.mark.parametrize("seed", [1, 3])
def test_noise_that_grows_hot_is_not_a_step(bench: ModuleType, seed: int) -> None:
    """The local jump's scale is one per run; where the noise grows, a jump stands out of
    it. Before: a step event in one run of each of these sessions (sizes of a few
    hundredths of a mg against their standard errors) and the effects chosen again
    around it; now a step must also hold fitted on every sample, and none is found."""
    session = bench.simulate_session((_NoiseGrowingHot(),), seed, HOURS, bench.CALIBRATION_PROFILE)
    d = diagnose(session)
    assert d.session_events == (), d.session_events
    assert d.effects == (), d.effects


@pytest.mark.parametrize(
    ("run", "deg", "about"), [("OX+", 2.0, "y"), ("OZ+", 1.5, "x"), ("OZ-", 3.0, "y")]
)
def test_a_tilted_run_on_a_misaligned_part(
    bench: ModuleType, run: str, deg: float, about: str
) -> None:
    """Every real part is misaligned by a fraction of a degree. With the cross-axis gain
    from the tilted run's axis in the model, the tilt shows as half its size in both runs
    of the pair, and the screen of run levels saw two of an axis' four runs off (its
    scatter): no event, half the tilt in the misalignment, 5.6-7.7 mg on the validation
    session (1.44-1.82x the seed paper's model). Levels are now screened beside the full
    3x3 gain, a ± pair counting as one level, and the event fitted beside it: the noise
    floor, as on the same part without the tilt."""
    case = bench.ValidationCase(
        "tilt on a misaligned part",
        part=(se.Misalignment(),),
        events=(sev.RunTilt(run, deg, about),),
    )
    out = bench.run_case(case, 1, HOURS)
    assert f"event: level of run {run}" in out.added, out.added
    assert "misalignment" in out.added, out.added
    # The floor is the noise of a 2 Hz sample (0.60 mg); what two 0.5 h fits leave of
    # a misalignment and a tilt is well under 5 % of it.
    assert out.diagnosed_mg <= 1.05 * out.floor_mg, (out.diagnosed_mg, out.floor_mg)


def _cooling(events: tuple[Effect, ...]) -> Session:
    """A 1 h cool-down 65 -> -2 °C after a 10 min soak; a part with a 60 s lag."""
    sim = simulate.arrays(
        "ADXL335",
        seed=1,
        duration_h=1.0,
        t_start_c=65.0,
        t_end_c=-2.0,
        soak_min=10.0,
        effects=(se.Misalignment(), se.ThermalLag(60.0), *events),
    )
    return simulated_session(sim)


def test_a_kink_where_the_soak_ends_is_not_a_step() -> None:
    """The lag's model leaves a kink where the cooling starts; a step there of
    0.0x mg, with the fit's standard error (independent samples), passed as an event
    in OZ+ at 635 s. The residual's own correlation (batch means over the engine's
    blocks) widens that error: no step now."""
    d = diagnose(_cooling(()))
    assert "thermal_lag" in d.effects
    assert not [e for e in d.session_events if str(e["event"]).startswith("step")], d.session_events


def test_a_one_mg_knock_in_the_same_session_is_still_a_step() -> None:
    """The same session with OZ- knocked by 1 mg on every axis at 1800 s: found."""
    d = diagnose(_cooling((sev.OutputStep("OZ-", 1800.0, 1.0),)))
    steps = {str(e["event"]) for e in d.session_events if str(e["event"]).startswith("step")}
    assert len(steps) == 1 and next(iter(steps)).startswith("step in OZ- at 18"), steps


def test_rates_off_in_both_runs_of_a_pair_are_the_parts(
    bench: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One run's temperature out of step is an event (a probe left on a shelf); the
    same in both runs of a ± pair is the orientation's, the part's (blind round 4's
    orient_lag: its z runs' rates as events left 3.69 mg on the validation session,
    their steps 3.36). The rule alone: each run's window fit replaced by a chosen one
    (a size of 1 mg per °C/min on z, ± 0.01, in the runs named; the others at 0)."""
    from accelcore.diagnosis import events, rates
    from accelcore.diagnosis.space import spec_from_terms

    session = bench.simulate_session((), 1, HOURS, bench.CALIBRATION_PROFILE)
    d = diagnose(session)
    eng = d._data()
    found_specs = {a: spec_from_terms(a, d.calibration.axes[a].terms) for a in AXES}
    specs = {a: s for a, s in found_specs.items() if s is not None}
    assert len(specs) == 3, found_specs
    runs = events._runs(eng)
    labels = events._labels(eng, runs)

    def found(off: set[str]) -> tuple[list[str], list[str]]:
        def window_fit(eng_: object, specs_: object, term: object) -> tuple[np.ndarray, np.ndarray]:
            run = term.basis.run  # type: ignore[attr-defined]
            size = np.array([0.0, 0.0, 1.0 if run in off else 0.0])
            return (size / 0.01) ** 2 + 1e-6, size

        monkeypatch.setattr(rates, "_window_fit", window_fit)
        monkeypatch.setattr(rates, "variance_inflation", lambda *args: 1.0)
        terms, notes = rates.trailing_runs(eng, specs, runs, labels, 0.01, events.LEVEL_OUTLIER_Z)
        return [t.effect for t in terms], notes

    one, notes = found({"OY-"})
    assert one == ["event: temperature out of step in OY-"] and notes == [], (one, notes)
    pair, notes = found({"OZ+", "OZ-"})
    assert pair == [], pair
    assert len(notes) == 1 and "both runs of a pair (OZ+, OZ-)" in notes[0], notes


def test_two_records_of_one_orientation_are_not_a_pair() -> None:
    """Records are named by orientation, numbered when one repeats (``OZ+ #2``): two
    records of OZ+ out of step are not a ± pair (the label's end is its number)."""
    from accelcore.diagnosis import rates
    from accelcore.model import RunRate, Term

    def term(run: str) -> Term:
        return Term("offset", RunRate(run), effect="event: x")

    assert rates._orientation(term("OZ+ #2")) == "OZ+"
    assert rates._opposite("OZ+") == "OZ-" and rates._opposite("OX-") == "OX+"
