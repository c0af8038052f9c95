"""The greedy selection of the diagnosis and :func:`diagnose` itself.

:func:`diagnose` searches a catalogue of candidate effects
(:data:`~accelcore.diagnosis.space.FAMILIES`), each a named set of model terms, and
adds them greedily by *held-out* error only. Cross-validation is blocked: whole runs
are held out (three runs or more, when every fold keeps the orientations that identify
each axis), else the legs of the temperature cycle, else every third block of each run. A
family is added to an axis when the axis' held-out RMS error falls by at least
``min_improvement`` *and* the paired one-sided test over held-out blocks of ``block_s``
seconds (:class:`accelcore.core.AcceptanceRule`: the per-block change of the squared
error, its log ratio and its sign) is significant at ``alpha``. Each step adds the family with the
largest total cut of held-out squared error over the axes that accept it, then revisits
the lag of every axis, and repeats.

The steps, in order: check the options (:func:`.scope.check_options`), find the starting
point in the model space (:func:`_starting_point`), cut the data
(:class:`~accelcore.diagnosis.engine.Engine`), list the usable extra columns and the
confounded effects, run the selection (:class:`_Selection`), fit the improved
calibration (:func:`_improved_calibration`) and check the final residual for structure.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from functools import partial
from typing import Any, Literal

import numpy as np
import pandas as pd

from accelcore.input.quality import QualityIssue
from accelcore.input.session import Session
from accelcore.model import AXES, Decay
from accelcore.result.calibration import Calibration

from . import search
from .between import cross_given_back, cross_left_out, hold_cross, one_run_caveats
from .confounds import base_spanned, confounding
from .ends import engine_beside_checks, improved_calibration, starting_point, usable_extras
from .engine import Engine
from .events import event_corrections, find_run_events, level_runs, levels_on_every_axis
from .generic import LINE, TEMPERATURE_OBSERVABLES, generic_variants
from .inside import alike
from .lags import two_way_variants
from .observables import STEADY_C_PER_MIN
from .parameters import added_parameters, event_parameters, fit_models
from .parts import one_way
from .result import Diagnosis, Step
from .scope import (
    QUALITY_EXPLAINS,
    check_options,
    explained,
    found_in,
    not_explained_by,
    without_findings,
)
from .search import variants
from .space import BETWEEN_RUNS, FAMILIES, TWO_WAY_LAG, Spec, with_tau
from .stats import pooled_rms, wrms
from .structure import (
    MIN_TEMPERATURE_SPAN_C,
    TEMPERATURE_FAMILIES,
    structures,
    temperature_span_c,
)
from .verdicts import Candidate, Tried, best_family, judge, judge_between_runs, redundant

__all__ = ["QUALITY_EXPLAINS", "diagnose"]

#: Most times the selection starts again without families made redundant by later ones.
MAX_RESTARTS = 2


#: Arguments of :func:`diagnose` that are not options of the method.
_NOT_OPTIONS = frozenset({"session", "calibration", "quality"})


@dataclass(frozen=True)
class _Rules:
    """What the selection may try and when it accepts."""

    families: Sequence[str]
    extras: Sequence[str]
    skip_observables: frozenset[str]
    max_order: int
    tau_range_s: tuple[float, float]
    min_improvement: float
    alpha: float


class _Selection:
    """State of the greedy selection: each axis' spec, its held-out error, steps, candidates."""

    def __init__(self, eng: Engine, specs: dict[str, Spec], rules: _Rules) -> None:
        self.eng = eng
        self.rules = rules
        self._start(specs)
        self.notes: list[str] = []
        self.session_events: list[dict[str, Any]] = []
        #: (family, axis) left out: redundant beside later effects (see :meth:`run`).
        self.banned: set[tuple[str, str]] = set()

    def _start(self, specs: Mapping[str, Spec]) -> None:
        """Set every axis' model to ``specs``, with no step and no candidate yet."""
        self.specs = dict(specs)
        self.cv_cur = {a: self.eng.cv(a, self.specs[a].terms(a)) for a in AXES}
        self.steps: list[Step] = []
        self.cand_rows: list[dict[str, Any]] = []

    def run(self, max_steps: int) -> None:
        """Add effects until none is accepted; again without any that others made redundant.

        When a family chosen at one step no longer passes its test beside those chosen
        after it (:func:`.verdicts.redundant`), the selection starts again with that
        family left out on that axis, at most :data:`MAX_RESTARTS` times.
        """
        start = dict(self.specs)
        for attempt in range(MAX_RESTARTS + 1):
            self._run(max_steps)
            added = [(s.effect, s.axes) for s in self.steps[1:]]
            rules = self.rules
            extra = redundant(self.eng, self.specs, added, rules.min_improvement, rules.alpha)
            if not extra or attempt == MAX_RESTARTS:
                return
            self.banned |= {(c.family, c.axis) for c in extra}
            self.notes.append(
                "; ".join(
                    f"{c.family} on {c.axis} left out: beside the effects chosen after it, "
                    f"it no longer passes (cut {c.cut:.1%}, p {c.p:.2g})"
                    for c in extra
                )
                + "; the effects were chosen again without it"
            )
            self._start(start)

    def _run(self, max_steps: int) -> None:
        """Record the base model as step 0, then add effects until none is accepted."""
        self.steps.append(self._step(0, "base", [], []))
        for step in range(1, max_steps + 1):
            if self.eng.n_folds < 2:
                break
            by_family = self._candidates(step)
            best = best_family(by_family, self.rules.alpha)
            if best is None:
                break
            chosen = [c for c in by_family[best] if c.accepted]
            for c in chosen:
                self.specs[c.axis] = c.spec
                self.cv_cur[c.axis] = c.cv
            if best not in ("thermal_lag", TWO_WAY_LAG):
                self._revisit_lags()
            self.eng.keep_lags(
                [
                    s.tau if s.tau_cool is None else (s.tau, s.tau_cool)
                    for s in self.specs.values()
                    if s.tau is not None
                ],
                [s.rate_tau for s in self.specs.values() if s.rate_tau is not None],
            )
            axes = tuple(c.axis for c in chosen)
            models, _, _ = fit_models(self.eng, self.specs, axes)
            params = added_parameters(self.eng, models, axes, best, self.specs)
            self.steps.append(self._step(step, best, chosen, params))

    # -------------------------------------------------------------- one step
    def _tau_range(self, family: str) -> tuple[float, float]:
        """Return the range of the time constant that ``family`` searches, s."""
        if family == "warm_up":
            return search.warm_up_range_s(self.eng)
        return self.rules.tau_range_s

    def _tau_searches(
        self, family: str, axis: str
    ) -> list[tuple[str, str, Callable[[float], Spec]]]:
        """Return the time-constant searches of ``family`` on ``axis``.

        Each as (family of its candidate, its label before the tau, model of tau); none
        for a family that searches no time constant, or whose one the axis' model holds.
        """
        spec = self.specs[axis]
        if family == "warm_up" and not any(isinstance(t.basis, Decay) for t in spec.events):
            return [(search.WARM_UP, "", partial(search.with_warm_up, spec))]
        if family == "thermal_lag" and spec.tau is None and spec.rate_tau is None:
            return [
                (family, what, partial(with_tau, spec, variant))
                for variant, what in (("die", "die lag, "), ("rate", "rate term, "))
            ]
        return []

    def _search_together(self, family: str) -> None:
        """Run the time-constant searches of ``family`` on every axis at once.

        Each gives what it gives alone (:func:`.search.search_many`); :meth:`_tried`
        takes them.
        """
        searches = [(a, make) for a in AXES for _, _, make in self._tau_searches(family, a)]
        if searches:
            search.search_many(self.eng, searches, self._tau_range(family))

    def _tried(self, family: str, axis: str) -> list[Tried]:
        """Every variant of ``family`` on ``axis``, cross-validated."""
        spec, rules = self.specs[axis], self.rules
        if family in ("warm_up", "thermal_lag"):
            range_s = self._tau_range(family)
            tried: list[Tried] = []
            for fam, what, make in self._tau_searches(family, axis):
                tau, cv = search.search_1d(self.eng, axis, make, range_s)
                if family == "warm_up" and search.at_upper_end(tau, range_s):
                    continue  # slower than any warm-up the runs show: a drift's shape
                tried.append((fam, f"{what}tau {tau:.3g} s", cv, make(tau)))
            return tried
        if family == TWO_WAY_LAG:
            return two_way_variants(self.eng, axis, spec, self._tau_range("thermal_lag"))
        if family == "smooth":
            return self._tried_generic(axis, spec)
        return [
            (fam, label, self.eng.cv(axis, s.terms(axis)), s)
            for fam, label, s in variants(
                family,
                axis,
                spec,
                self.eng,
                rules.max_order,
                rules.extras,
                rules.skip_observables,
            )
        ]

    def _tried_generic(self, axis: str, spec: Spec) -> list[Tried]:
        """Cross-validate the generic variants: the line, the hinges, finer ones where they cut."""
        tried: list[Tried] = []
        cur = self.cv_cur[axis].rms_out
        least = 0.5 * self.rules.min_improvement
        skip = self.rules.skip_observables
        for family, label, s, finer in generic_variants(axis, spec, self.eng, skip):
            cv = self.eng.cv(axis, s.terms(axis))
            tried.append((family, label, cv, s))
            for fine_label, fine in finer:
                # The first hinges are tried whatever the line alone does.
                coarser_cuts = cur > 0 and 1.0 - cv.rms_out / cur >= least
                if not coarser_cuts and tried[-1][1] != LINE:
                    break  # the coarser one does not cut: no finer one is tried
                cv = self.eng.cv(axis, fine.terms(axis))
                tried.append((family, fine_label, cv, fine))
        return tried

    def _candidates(self, step: int) -> dict[str, list[Candidate]]:
        """Return the best variant of every family (``extra:NAME`` separately) on every axis."""
        self.eng.set_models({a: self.specs[a].terms(a) for a in AXES})
        by_family: dict[str, list[Candidate]] = {}
        for family in self.rules.families:
            self._search_together(family)
            for a in AXES:
                groups: dict[str, list[Tried]] = {}
                for o in self._tried(family, a):
                    groups.setdefault(o[0], []).append(o)
                for fam, opts in groups.items():
                    cand = self._judge(step, a, fam, opts)
                    if (fam, a) in self.banned:
                        cand.accepted = cand.row["accepted"] = False
                        cand.row["judged"] = "left out (redundant beside later effects)"
                    by_family.setdefault(fam, []).append(cand)
        for cands in by_family.values():
            judge_between_runs(self.eng, cands, self.cv_cur, self.rules.alpha)
        return by_family

    def _judge(self, step: int, axis: str, family: str, opts: Sequence[Tried]) -> Candidate:
        """Judge one family's variants on one axis (:func:`.verdicts.judge`); record it."""
        rules = self.rules
        cand = judge(
            self.eng,
            step,
            axis,
            family,
            opts,
            self.cv_cur[axis],
            rules.min_improvement,
            rules.alpha,
        )
        self.cand_rows.append(cand.row)
        return cand

    def add_run_events(self) -> None:
        """Find steps and run levels in the residual (:mod:`.events`); fit them as events.

        They enter the specs (so the final fit is not biased by them) and
        :attr:`session_events` (one row per event parameter), not the steps: no
        held-out fold can judge a thing that happened in one run.
        """
        specs, lines, notes = find_run_events(self.eng, self.specs, self.rules.alpha)
        self.notes += notes
        if not lines:
            return
        self.specs = specs
        self.record_events()

    def record_events(self) -> None:
        """Fill :attr:`session_events` from the fit of the current specs (their run events)."""
        models, _, _ = fit_models(self.eng, self.specs)
        self.session_events = event_parameters(self.eng, models, self.specs)

    def _revisit_lags(self) -> None:
        """Search again the lag of every axis that has one (variant and tau), keep the better."""
        bare = {
            a: replace(s, tau=None, tau_cool=None, rate_tau=None)
            for a, s in self.specs.items()
            if s.tau is not None or s.rate_tau is not None
        }
        tried = [(a, partial(with_tau, s, v)) for a, s in bare.items() for v in ("die", "rate")]
        search.search_many(self.eng, tried, self.rules.tau_range_s)
        for a, make in tried:
            tau, cv = search.search_1d(self.eng, a, make, self.rules.tau_range_s)
            (cur, cv), _ = alike(self.eng, a, [self.cv_cur[a], cv])
            if cv.rms_out < cur.rms_out * 0.999:
                self.specs[a], self.cv_cur[a] = make(tau), cv

    def _step(
        self, index: int, effect: str, chosen: Sequence[Candidate], params: list[dict[str, Any]]
    ) -> Step:
        """Return the figures of the current models as step ``index``."""
        eng = self.eng
        rms_in, rms_out, max_out, max_in = {}, {}, {}, {}
        fold_axis: dict[str, dict[str, float]] = {name: {} for name in eng.fold_names}
        for a in AXES:
            r_in, r_out = eng.residuals(a, self.specs[a].terms(a))
            rms_in[a] = wrms(r_in, eng.w)
            rms_out[a] = wrms(r_out, eng.w)
            max_out[a] = float(np.abs(r_out).max())
            max_in[a] = float(np.abs(r_in).max())
            for k, name in enumerate(eng.fold_names):
                rows = eng.fold_rows[k]
                if rows.size:
                    fold_axis[name][a] = wrms(r_out[rows], eng.w[rows])
        return Step(
            index,
            effect,
            tuple(c.axis for c in chosen),
            {c.axis: c.variant for c in chosen},
            params,
            pooled_rms(rms_in),
            max(max_in.values()),
            pooled_rms(rms_out),
            max(max_out.values()),
            rms_in,
            rms_out,
            max_out,
            fold_axis,
            {c.axis: c.cut for c in chosen},
            {c.axis: c.p for c in chosen},
            {a: self.specs[a].terms(a) for a in AXES},
        )


def diagnose(
    session: Session,
    calibration: Calibration | None = None,
    *,
    max_steps: int = 4,
    t_ref_c: float = 25.0,
    window_c: tuple[float, float] | None = None,
    folds: Literal["auto", "runs", "legs", "blocks"] = "auto",
    min_improvement: float = 0.10,
    alpha: float = 0.01,
    block_s: float = 300.0,
    max_order: int = 5,
    tau_range_s: tuple[float, float] | None = None,
    families: Sequence[str] = FAMILIES,
    extras: Sequence[str] | None = None,
    confound_r: float = 0.95,
    steady_c_per_min: float = STEADY_C_PER_MIN,
    n_bins: int = 30,
    alpha_structure: float = 1e-3,
    min_structure_mg: float = 0.1,
    quality: Sequence[QualityIssue] | None = None,
) -> Diagnosis:
    """Find what a calibration model misses and add it, choosing by held-out error only.

    Parameters
    ----------
    session : Session
    calibration : Calibration, optional
        The model to start from; default ``calibrate(session, t_ref_c=...,
        window_c=...)`` (the seed paper's model, joint fit). Its ``t_ref_c``
        and window are used when given.
    max_steps : int, default 4
        Most effects to add.
    t_ref_c : float, default 25
        Reference temperature (without ``calibration``).
    window_c : (float, float) or None, default None
        Temperature window of the samples used (without ``calibration``);
        None: the whole logged range.
    folds : {"auto", "runs", "legs", "blocks"}, default "auto"
        Held-out blocks: whole runs (three runs or more that keep every axis
        identified), legs of the temperature cycle, or every third block of each run.
    min_improvement : float, default 0.10
        Least relative cut of an axis' held-out RMS error for an effect to be added.
    alpha : float, default 0.01
        Level of the paired one-sided test over held-out blocks
        (:class:`accelcore.core.AcceptanceRule`).
    block_s : float, default 300
        Length of the blocks of the paired test, s.
    max_order : int, default 5
        Highest order of the curvature families.
    tau_range_s : (float, float), optional
        Search range of the lag time constant, s. Default: from 5 s to half the
        session's shortest heating or cooling leg, at most 3600 s
        (:func:`accelcore.diagnosis.search.lag_range_s`: a longer one never settles
        inside a leg and fits the profile, not the part).
    families : sequence of str, default :data:`FAMILIES`
        Families of the catalogue to try.
    extras : sequence of str, optional
        Extra columns to try (default: every one logged in all runs that varies).
    confound_r : float, default 0.95
        Correlation above which two effects are reported as confounded.
    steady_c_per_min : float, default 0.1
        Rate below which temperature counts as steady (legs, branch).
    n_bins : int, default 30
        Bins of the generic structure check per observable (per run for time).
    alpha_structure : float, default 1e-3
        Level of the generic structure check.
    min_structure_mg : float, default 0.1
        Smallest structure reported, mg rms.
    quality : sequence of QualityIssue, optional
        The session's data-quality findings; default: those of
        :func:`accelcore.input.quality.check_session` (without warnings). A
        family a finding could explain (:data:`QUALITY_EXPLAINS`, e.g. no
        ``thermal_lag`` when a run was cut short) is not tried, and a warning
        says which and why.

    Returns
    -------
    Diagnosis

    Notes
    -----
    Never emits Python warnings; caveats are in :attr:`Diagnosis.warnings`.
    """
    # The options as given (the session's own and its findings aside), to diagnose again.
    options_given = {k: v for k, v in locals().items() if k not in _NOT_OPTIONS}
    check_options(families, max_steps, min_improvement, alpha)
    base, specs, notes = starting_point(session, calibration, t_ref_c, window_c)
    eng, quality = engine_beside_checks(
        session,
        base,
        quality,
        folds=folds,
        block_s=block_s,
        steady_c_per_min=steady_c_per_min,
        max_order=max_order,
    )
    extras_used = usable_extras(session, eng, extras, notes)
    confounded = confounding(eng, specs, extras_used, confound_r)
    warn = list(notes)
    if eng.n_folds < 2:
        warn.append("fewer than two held-out folds: nothing can be selected")
    tried = list(families)
    span = temperature_span_c(eng) if session.has_temperature else 0.0
    if span < MIN_TEMPERATURE_SPAN_C:
        tried = [f for f in tried if f not in TEMPERATURE_FAMILIES]
        warn.append(
            (
                f"the temperature spans {span:.2f} °C (less than {MIN_TEMPERATURE_SPAN_C:g} °C)"
                if session.has_temperature
                else "no temperature was logged"
            )
            + ": no temperature-driven effect is tried or reported"
        )
    elif caveat := one_way(eng.leg_kinds, eng.rate, eng.elapsed_s):
        warn.append(caveat)
    # What a finding could explain, tried when the runs it is not about show it too.
    probe, cleared = without_findings(session, quality or ()), list[str]()
    if probe is not None:
        cleared = found_in(diagnose(probe, **options_given, quality=()).effects)
    tried, skipped = not_explained_by(tried, quality or (), cleared)
    warn += skipped
    skip = {
        f.split(":", 1)[1]
        for f in explained(quality or ())
        if f.startswith("smooth:") and f not in cleared
    }
    if span < MIN_TEMPERATURE_SPAN_C:
        skip |= set(TEMPERATURE_OBSERVABLES)
    if tau_range_s is None:
        tau_range_s = search.lag_range_s(eng)
    rules = _Rules(
        tried,
        extras_used,
        frozenset(skip),
        max_order,
        tau_range_s,
        min_improvement,
        alpha,
    )
    # Starting cross-axis gains the runs can judge are held out (:func:`.hold_cross`).
    held = hold_cross(eng, specs) if "misalignment" in tried else None
    held_cross, calibrated = held is not None, dict(specs)
    specs = held or specs
    sources = {a: search.cross_sources(eng, a) for a in AXES}
    specs_at_start = dict(specs)
    selection = _Selection(eng, specs, rules)
    selection.run(max_steps)
    if "run_events" in tried and eng.n_folds >= 1:
        selection.add_run_events()
        if selection.session_events:
            selection, eng = _again_with_events(eng, specs_at_start, selection, rules, max_steps)
    added = [s.effect for s in selection.steps[1:]]
    if any(set(spec.cross) & set(sources[a]) for a, spec in specs_at_start.items()):
        added.append("misalignment")  # the model holds the cross-axis gain throughout
    elif held_cross and (back := cross_given_back(eng, selection.specs, calibrated)):
        selection.specs = back  # no test can judge them now: as calibrated
        if selection.session_events:
            selection.record_events()
    elif held_cross and not any(set(s.cross) & set(sources[a]) for a, s in selection.specs.items()):
        warn.append(cross_left_out(selection.cand_rows, rules.min_improvement))
    warn = [c.text(added) for c in confounded] + warn + selection.notes
    warn += [s.text() for s in base_spanned(eng, confounded, confound_r, added)]
    warn += one_run_caveats(eng, selection.steps)
    improved = improved_calibration(base, eng, selection.specs, selection.steps)
    resid = {a: eng.residuals(a, selection.specs[a].terms(a))[0] for a in AXES}
    found = structures(
        eng, resid, n_bins=n_bins, alpha=alpha_structure, min_structure_mg=min_structure_mg
    )
    options: dict[str, Any] = {
        **{k: v for k, v in options_given.items() if k != "steady_c_per_min"},
        "t_ref_c": base.t_ref_c,
        "window_c": list(base.window_c),
        "tau_range_s": list(tau_range_s),
        "families": list(families),
        "extras": extras_used,
    }
    return Diagnosis(
        base=base,
        calibration=improved,
        steps=tuple(selection.steps),
        candidates=pd.DataFrame(selection.cand_rows),
        structures=tuple(found),
        warnings=tuple(warn),
        folds=tuple(eng.fold_names),
        scheme=eng.scheme,
        options=options,
        session_events=tuple(selection.session_events),
        _engine=eng,
    )


def _again_with_events(
    eng: Engine,
    start: Mapping[str, Spec],
    first: _Selection,
    rules: _Rules,
    max_steps: int,
) -> tuple[_Selection, Engine]:
    """Choose the part's effects again on the output less the run events found.

    The events are found on the residual of the effects chosen without them, so that
    a smooth effect is not taken for one; an effect chosen then may itself have been
    standing in for an event (a term that fits a run's step or level in part). The
    events, fitted beside the chosen effects on every sample, are taken off the
    output, and the effects are chosen again from the start on what is left. (Held
    as free terms in the held-out fits instead, a step late in a run would be a free
    offset between folds.) The events' figures stay those of the first fit.
    """
    models, _, _ = fit_models(eng, first.specs)
    again_eng = eng.less(event_corrections(eng, models), level_runs(first.specs))
    before = [s.effect for s in first.steps[1:]]
    again = _Selection(again_eng, dict(start), rules)
    again.run(max_steps)
    # An effect constant in every run (a gain on gravity) is judged on the output as
    # logged: taken off it, a run's level or a step leaves a contrast between runs that
    # such a term fits, and one session cannot tell the two apart. Chosen only now, it
    # would fit what the events put there (a probe lagging in one run, read as a level
    # of its pair's other run and a step: a cross-axis gain of 1.1 deg on z that cut the
    # session's held-out error by 62 % and took a validation session from 0.63 to 6.3 mg).
    late = [
        e for e in (st.effect for st in again.steps[1:]) if e in BETWEEN_RUNS and e not in before
    ]
    if late:
        rules = replace(rules, families=[f for f in rules.families if f not in late])
        again = _Selection(again_eng, dict(start), rules)
        again.run(max_steps)
        first.notes.append(
            f"{', '.join(late)} not taken on the output less the session events (the "
            "first choice, on the output as logged, did not take it: a run's level taken "
            "off leaves a contrast between runs such a term would fit)"
        )
    if (found := levels_on_every_axis(again_eng, again.specs, rules.alpha)) is not None:
        again.specs = found
        again.record_events()  # the levels found now: the first pass' are in the output
    again.session_events = [*first.session_events, *again.session_events]
    after = [s.effect for s in again.steps[1:]]
    again.notes = first.notes + again.notes
    if before != after:
        again.notes.append(
            "effects chosen again on the output less the session events: "
            f"{', '.join(after) or 'none'} (before the events were known: "
            f"{', '.join(before) or 'none'})"
        )
    return again, again_eng
