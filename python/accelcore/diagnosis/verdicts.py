"""The verdict on a candidate: which variant of a family, and whether it is accepted.

:func:`judge` picks the most parsimonious variant of one family on one axis within 1 %
of the best held-out error and applies the diagnosis' rule: the held-out cut and the
paired test over blocks (:func:`.stats.accept`). Then, by what the candidate's new
columns are (:mod:`.between`): columns that move inside runs, when the candidate cuts
the held-out error at all and the session has two runs or more, are judged by the
same test on the held-out residuals less each run's mean (with one run, its level is
the offset every model holds); columns constant in every run by the run level's least
improvement, and :func:`judge_between_runs` then tests the run-level part of one
family's accepted candidates jointly over their axes.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from accelcore.model import AXES

from .between import (
    adds_only_run_constant,
    between_runs_p,
    n_runs,
    run_level_cut,
    within_runs,
)
from .engine import CV, Engine
from .inside import alike, is_rough, per_sample
from .space import Spec, is_event, without
from .stats import MIN_SYSTEMATIC_MG, accept, paired_test

__all__ = [
    "GENERIC_MARGIN",
    "Candidate",
    "Tried",
    "best_family",
    "judge",
    "judge_between_runs",
    "redundant",
]

#: A generic family (``smooth``) is chosen over the best named one only when it cuts
#: the held-out squared error by this factor more: the named ones are its special
#: cases with fewer parameters.
GENERIC_MARGIN = 1.1

FloatArray = NDArray[np.float64]

#: (family, variant label, CV, spec) of one variant tried.
Tried = tuple[str, str, CV, Spec]


@dataclass
class Candidate:
    """The best variant of one family on one axis at one step, and its verdict.

    ``row`` is its line of :attr:`accelcore.diagnosis.Diagnosis.candidates`.
    """

    family: str
    axis: str
    variant: str
    spec: Spec
    cv: CV
    cut: float
    t: float
    p: float
    accepted: bool
    row: dict[str, Any]
    #: The current model's figures it was judged against (scored as ``cv`` is).
    before: CV


def judge(
    eng: Engine,
    step: int,
    axis: str,
    family: str,
    opts: Sequence[Tried],
    cur: CV,
    min_improvement: float,
    alpha: float,
) -> Candidate:
    """Pick the most parsimonious variant within 1 % of the best; test it (see the module)."""
    # Where a model that cuts, or the current one, moves roughly inside windows, they
    # are scored per sample (:mod:`.inside`); all of them where the current one does
    # (its error per sample is then well above its window-level one).
    cutting = [o[2].rms_out < cur.rms_out for o in opts]
    rough_now = cur.per_sample or is_rough(eng, axis, cur.terms)
    _, exact = alike(eng, axis, [cur, *(o[2] for o, c in zip(opts, cutting, strict=True) if c)])
    if exact:
        cur = per_sample(eng, axis, cur)
        opts = [
            (f, label, per_sample(eng, axis, cv) if c or rough_now else cv, s)
            for (f, label, cv, s), c in zip(opts, cutting, strict=True)
        ]
    finite = [o for o in opts if math.isfinite(o[2].rms_out)] or list(opts[:1])
    best_rms = min(o[2].rms_out for o in finite)
    _, label, cv, spec = next((o for o in finite if o[2].rms_out <= best_rms * 1.01), finite[0])
    runs_only = adds_only_run_constant(eng, axis, cur.terms, cv.terms)
    # The floor of every model's held-out error (its noise) and the least a candidate
    # judged on its systematic cut must take off (:func:`.stats.accept`).
    floor = eng.noise_floor[axis]
    least = MIN_SYSTEMATIC_MG**2 * eng._wsum
    v = accept(
        cur.sse_blocks,
        cv.sse_blocks,
        min_improvement=min_improvement,
        alpha=alpha,
        floor=floor,
        least=least,
    )
    # Judged inside runs (the held-out error less each run's mean, :mod:`.between`)
    # when it does not raise the held-out error itself.
    inside = not runs_only and n_runs(eng) >= 2 and v.cut > 0
    if inside:
        v = within_runs(
            eng,
            axis,
            cur.terms,
            cv.terms,
            min_improvement=min_improvement,
            alpha=alpha,
            per_sample=exact,
            floor=floor,
            least=least,
        )
    cut, t, p, ok = v.cut, v.t, v.p, v.accepted
    # Columns constant in every run: no held-out fold can judge them (run folds cannot
    # identify them, folds inside runs share the run's level); the run-level test does
    # (:func:`judge_between_runs`), for a candidate that does not raise the held-out error.
    cut_runs = math.nan
    if runs_only:
        cut_runs = run_level_cut(eng, axis, cur.terms, cv.terms, cur.rms_in)
        ok = cut > 0 and cut_runs >= min_improvement
    row = {
        "step": step,
        "family": family,
        "axis": axis,
        "variant": label,
        "rms_out_before_mg": cur.rms_out,
        "rms_out_after_mg": cv.rms_out,
        "cut_pct": 100.0 * cut,
        "cut_systematic_pct": 100.0 * v.cut_systematic,
        "t": t,
        "p_value": p,
        "cut_between_runs_pct": 100.0 * cut_runs,
        "p_between_runs": math.nan,
        "judged": "between runs"
        if runs_only
        else ("held-out blocks inside runs" if inside else "held-out blocks"),
        "accepted": ok,
    }
    return Candidate(family, axis, label, spec, cv, cut, t, p, ok, row, cur)


def judge_between_runs(
    eng: Engine, cands: Sequence[Candidate], current: Mapping[str, CV], alpha: float
) -> None:
    """Judge between runs the run-constant columns of one family's accepted candidates.

    Jointly (:func:`.between.between_runs_p`, each axis' model now in ``current``)
    over the accepted candidates and every other axis the family was judged on between
    runs: when some of their new columns are constant in every run, the test must give
    ``p < alpha`` too, else none of them is accepted; a candidate judged between runs
    only is not accepted without it. The verdicts are updated in place.
    """
    chosen = [c for c in cands if c.accepted]
    # Every axis the family was tried on between runs enters the test, not only those
    # whose run-level cut was large: picking the large ones first would make a draw of
    # the runs' scatter look like an effect.
    tested = [c for c in cands if c.accepted or c.row["judged"] == "between runs"]
    models = {a: current[a].terms for a in AXES}
    test = chosen and between_runs_p(eng, models, {c.axis: c.cv.terms for c in tested})
    for c in chosen:
        if test:
            c.accepted = c.row["accepted"] = test.p < alpha
            c.row["p_between_runs"] = test.p
        elif c.row["judged"] == "between runs":
            c.accepted = c.row["accepted"] = False


def redundant(
    eng: Engine,
    specs: Mapping[str, Spec],
    added: Sequence[tuple[str, Sequence[str]]],
    min_improvement: float,
    alpha: float,
) -> list[Candidate]:
    """Return the chosen families that no longer pass their test beside the others.

    Each (family, axes) of ``added`` is judged as if it were added last: the model of
    each axis without it against the model with it, by :func:`judge`. A family chosen
    early may have stood in, in part, for one chosen later (a linear drift of the
    sensitivity for a sensitivity that follows the heating and cooling legs: the legs
    come in the same order in every run); beside it, it may no longer cut the error.
    Session events and families judged between runs (their joint test is over axes)
    are not tested again.
    """
    out: list[Candidate] = []
    for family, axes in added:
        if is_event(family):
            continue
        for a in axes:
            spec = specs[a]
            bare = without(spec, family)
            if bare == spec:
                continue
            cand = judge(
                eng,
                0,
                a,
                family,
                [(family, "", eng.cv(a, spec.terms(a)), spec)],
                eng.cv(a, bare.terms(a)),
                min_improvement,
                alpha,
            )
            if cand.row["judged"] != "between runs" and not cand.accepted:
                out.append(cand)
    return out


def best_family(by_family: Mapping[str, Sequence[Candidate]], alpha: float = 1.0) -> str | None:
    """Return the family that cuts held-out SSE most over the axes accepting it.

    A generic family (``... vs ...``) or a session event wins only by
    :data:`GENERIC_MARGIN` over the best named family of the part. Then parsimony
    (:func:`_simpler_alike`): a family with fewer parameters that the chosen one does
    not beat by the paired test over blocks (``p < alpha``) is taken instead.
    """
    best: dict[bool, tuple[str | None, float]] = {False: (None, 0.0), True: (None, 0.0)}
    for fam, cands in by_family.items():
        if stands_in_for_event(cands, by_family):
            continue
        blocks = _gain_blocks(cands)
        gain = 0.0 if blocks is None else float(blocks.sum())
        generic = " vs " in fam or is_event(fam)
        if gain > best[generic][1]:
            best[generic] = (fam, gain)
    (named, g_named), (generic_fam, g_generic) = best[False], best[True]
    chosen = named
    if generic_fam is not None and g_generic > GENERIC_MARGIN * g_named:
        chosen = generic_fam
    if chosen is None or alpha >= 1.0:
        return chosen
    return _simpler_alike(by_family, chosen, alpha)


def stands_in_for_event(
    cands: Sequence[Candidate], by_family: Mapping[str, Sequence[Candidate]]
) -> bool:
    """Tell whether a family of the part does worse, on every axis accepting it, than an event.

    The event: a named session event of the same step (a warm-up after power-on, not a
    generic function of time), whose candidate on each of those axes cuts the held-out
    error by more (each against the model it was judged on), accepted there or not.
    A part effect that follows such an event less well than the event itself stands in
    for it: it would carry into other data what may have happened in this session only
    (in one record heated from power-on, a lag's rate term and a warm-up both decay from
    the start). Session events are never rivals of one another here.
    """
    accepted = [c for c in cands if c.accepted]
    if not accepted or is_event(accepted[0].family):
        return False
    for fam, events in by_family.items():
        if not is_event(fam) or " vs " in fam:
            continue
        by_axis = {e.axis: e for e in events}
        if all(c.axis in by_axis and _kept(by_axis[c.axis]) < _kept(c) for c in accepted):
            return True
    return False


def _kept(c: Candidate) -> float:
    """Held-out RMS error of a candidate over the one of the model it was judged on."""
    before = c.before.rms_out
    return c.cv.rms_out / before if before > 0 and math.isfinite(c.cv.rms_out) else math.inf


def _parameters(cands: Sequence[Candidate]) -> int:
    """Parameters a family adds over the axes accepting it: columns and time constants.

    A lag's time constant, searched from the data, is a parameter as its columns are.
    """
    n = 0
    for c in (c for c in cands if c.accepted):
        lags = {t.basis.lag_key for t in c.cv.terms if t.basis.lag_key is not None}
        lags -= {t.basis.lag_key for t in c.before.terms if t.basis.lag_key is not None}
        n += len(c.cv.terms) - len(c.before.terms) + sum(len(k) for k in lags)
    return n


def _gain_blocks(cands: Sequence[Candidate]) -> FloatArray | None:
    """Per-block cut of held-out squared error of a family, summed over its axes."""
    gains = [c.before.sse_blocks - c.cv.sse_blocks for c in cands if c.accepted]
    return np.sum(gains, axis=0) if gains else None


def _simpler_alike(by_family: Mapping[str, Sequence[Candidate]], chosen: str, alpha: float) -> str:
    """Return the family with fewer parameters than ``chosen`` that it does not beat.

    Two families that explain the data alike on this session (a function of the
    temperature with sixteen pieces and a line of the rate with one knot, when every
    run soaks only at its cold end) are told apart only by how many parameters each
    spends; the data cannot tell which one another session follows, and the one with
    fewer extrapolates less. Among the families with fewer parameters, accepted on
    every axis ``chosen`` is, whose per-block cut ``chosen`` does not exceed by the
    one-sided paired test (``p >= alpha``), the one that cuts most; ``chosen`` when
    there is none. Session events are not rivals of the part's effects (they are found
    on the residual, see :mod:`.events`).
    """
    top = _gain_blocks(by_family[chosen])
    if top is None or is_event(chosen):
        return chosen
    n_top = _parameters(by_family[chosen])
    axes = {c.axis for c in by_family[chosen] if c.accepted}
    found, found_gain = chosen, -math.inf
    for fam, cands in by_family.items():
        gain = _gain_blocks(cands)
        if fam == chosen or gain is None or is_event(fam) or _parameters(cands) >= n_top:
            continue
        if stands_in_for_event(cands, by_family):
            continue
        if not axes <= {c.axis for c in cands if c.accepted}:
            continue  # a rival explains every axis the chosen one does
        _, p = paired_test(top - gain)
        total = float(gain.sum())
        if p >= alpha and total > found_gain:
            found, found_gain = fam, total
    return found
