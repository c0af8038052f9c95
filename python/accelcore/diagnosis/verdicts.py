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

from accelcore.model import AXES

from .between import (
    adds_only_run_constant,
    between_runs_p,
    n_runs,
    run_level_cut,
    within_runs,
)
from .engine import CV, Engine
from .space import Spec
from .stats import accept

__all__ = ["Candidate", "Tried", "judge", "judge_between_runs"]

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
    finite = [o for o in opts if math.isfinite(o[2].rms_out)] or list(opts[:1])
    best_rms = min(o[2].rms_out for o in finite)
    _, label, cv, spec = next((o for o in finite if o[2].rms_out <= best_rms * 1.01), finite[0])
    runs_only = adds_only_run_constant(eng, axis, cur.terms, cv.terms)
    v = accept(cur.sse_blocks, cv.sse_blocks, min_improvement=min_improvement, alpha=alpha)
    # Judged inside runs (the held-out error less each run's mean, :mod:`.between`)
    # when it does not raise the held-out error itself.
    inside = not runs_only and n_runs(eng) >= 2 and v.cut > 0
    if inside:
        v = within_runs(
            eng, axis, cur.terms, cv.terms, min_improvement=min_improvement, alpha=alpha
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
        "t": t,
        "p_value": p,
        "cut_between_runs_pct": 100.0 * cut_runs,
        "p_between_runs": math.nan,
        "judged": "between runs"
        if runs_only
        else ("held-out blocks inside runs" if inside else "held-out blocks"),
        "accepted": ok,
    }
    return Candidate(family, axis, label, spec, cv, cut, t, p, ok, row)


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
