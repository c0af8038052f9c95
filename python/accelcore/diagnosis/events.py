"""Session events in one run: an offset step mid-run, a run whose gravity was tilted.

A part knocked mid-sweep, or a positioner that left one run a degree or two off,
is not a property of the part: it happened in this session, in one run. No
held-out fold can predict it from the other runs, so it is found on the fit's own
residual, after the part's effects are chosen, and fitted beside them (so that it
does not bias them) as a term of that run only; it is reported and never carried
into the calibration (:func:`accelcore.diagnosis.space.is_event`).

* **Step** (:class:`~accelcore.model.RunStep` at ``t0``): in each run, the local
  jump of the residual, ``mean(r[k:k+W]) - mean(r[k-W:k])`` over windows of ``W``
  samples, in units of its white-noise standard error and pooled over the three
  axes (chi-square, 3 degrees of freedom); a smooth leftover trend gives no jump.
  The largest is a step when its p-value, Bonferroni-corrected over every
  position of every run, is below ``alpha``. Its term frees the side of it the rest
  of the session disagrees with: the level after it (a knock, ``step(RUN@t0)``) or
  the level before it (an offset that went away, ``until(RUN@t0)``).
* **Run level** (a step at the run's start: a tilted gravity direction, seen on
  the axes that should read 0 g in that run). With the full 3x3 gain a tilt of
  one run of a ± pair is, in the least-squares sense, half misalignment and half
  an offset the other runs contradict. Each zero-g run of each axis is tried as
  an event; the one that cuts the residual most is kept, and between runs that
  cut it alike (the two runs of a pair) the one that leaves the smaller sum of
  |cross-axis gain| + |event| (one event explains it, rather than a misalignment
  and an event that cancel). It is kept when the run's level, against the
  scatter of its own 5-minute block means, passes the same corrected test.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from accelcore.input.medians import median_of_finite
from accelcore.model import AXES, Constant, RunRate, RunStep, Term
from accelcore.result.calibration import AxisModel

from .between import window_residuals
from .engine import Engine
from .parameters import fit_models, variance_inflation
from .rates import trailing_runs
from .search import cross_sources
from .space import EVENT_PREFIX, Spec, is_event, with_cross
from .stats import chi2_sf, corrected_p, t_sf

__all__ = ["event_corrections", "find_run_events", "level_runs", "levels_on_every_axis"]

FloatArray = NDArray[np.float64]

#: Most run events looked for in one session.
MAX_EVENTS = 6

#: Robust z (against the other runs' levels) beyond which a run's level is an event.
#: Eight simulated sessions whose runs each power on with their own offset (2 mg sd,
#: no run off) gave a largest z of 2.2–5.4 (a MAD of 11 levels is itself uncertain by
#: about ±40 %); a run tilted by 1.5° beside a 0.3 mg scatter gives 26–30.
LEVEL_OUTLIER_Z = 8.0

#: Length of the blocks whose means give a run level's scatter, s.
_LEVEL_BLOCK_S = 300.0


def _noise_mg(r: FloatArray) -> float:
    """White-noise level of a residual from its first differences (robust)."""
    if r.size < 3:
        return math.nan
    d = np.diff(r)
    mid = median_of_finite(d)
    d -= mid
    np.abs(d, out=d)
    return median_of_finite(d, overwrite=True) / 0.6745 / math.sqrt(2.0)


def _runs(eng: Engine) -> list[NDArray[np.int64]]:
    """Sample indices of each run, in time order."""
    out = []
    for r in np.unique(eng.sample_run):
        idx = np.flatnonzero(eng.sample_run == r)
        out.append(idx[np.argsort(eng.elapsed_s[idx], kind="stable")])
    return out


def _labels(eng: Engine, runs: list[NDArray[np.int64]]) -> list[str]:
    """Record name of each run of :func:`_runs`."""
    return [eng.record_names[int(eng.sample_run[idx[0]])] for idx in runs]


def _best_jump(
    resid: Mapping[str, FloatArray], idx: NDArray[np.int64], time_s: FloatArray
) -> tuple[int, float, int]:
    """Position, pooled chi-square and window of the largest local jump in one run.

    Only positions whose two windows are contiguous in time count: across a gap
    (samples outside the window, a dropout) any slow structure jumps.
    """
    n = idx.size
    w = max(10, min(120, n // 20))
    if n < 4 * w:
        return -1, 0.0, w
    t = time_s[idx]
    dt = median_of_finite(np.diff(t))
    k_all = np.arange(w, n - w + 1)
    contiguous = (t[k_all + w - 1] - t[k_all - w]) <= 1.5 * (2 * w - 1) * dt
    stat = np.zeros(n - 2 * w + 1)
    for a in AXES:
        r = resid[a][idx]
        c = np.concatenate([[0.0], np.cumsum(r)])
        k = np.arange(w, n - w + 1)
        jump = (c[k + w] - c[k]) / w - (c[k] - c[k - w]) / w
        # Scale of the jump from the run itself (robust: a step moves ~2W of the
        # positions only), so that slow structure and correlated noise widen it.
        deviation = np.abs(jump - median_of_finite(jump))
        scale = 1.4826 * median_of_finite(deviation, overwrite=True)
        scale = max(scale, _noise_mg(r) * math.sqrt(2.0 / w))
        if not scale > 0:
            continue
        stat += (jump / scale) ** 2
    stat[~contiguous] = 0.0
    j = int(np.argmax(stat))
    return j + w, float(stat[j]), w


def find_run_events(
    eng: Engine, specs: Mapping[str, Spec], alpha: float
) -> tuple[dict[str, Spec], list[str], list[str]]:
    """Find steps and run levels in the residual of ``specs``; return specs with them.

    Returns the specs with the events' terms added (``Spec.events``), one line per
    event found, and notes (jumps seen in most runs, which are not events).
    """
    specs = dict(specs)
    lines: list[str] = []
    notes: list[str] = []
    runs = _runs(eng)
    labels = _labels(eng, runs)
    # Runs whose temperature is out of step with the part's, each alone beside the models.
    trailing, rate_notes = trailing_runs(eng, specs, runs, labels, alpha, LEVEL_OUTLIER_Z)
    trailing = trailing[:MAX_EVENTS]
    notes += rate_notes
    resid = {a: eng.residuals(a, specs[a].terms(a))[0] for a in AXES}
    # Steps: one pass over every run, the corrected test over all windows.
    # Every position of every run counts as a test (conservative: the windows overlap).
    n_windows = sum(idx.size for idx in runs)
    steps: list[Term] = []
    for idx, label in zip(runs, labels, strict=True):
        k, stat, _ = _best_jump(resid, idx, eng.elapsed_s)
        if k < 0 or corrected_p(chi2_sf(stat, 3), n_windows) >= alpha:
            continue
        t0 = float(f"{eng.elapsed_s[idx[k]]:.4g}")
        effect = f"{EVENT_PREFIX}step in {label} at {t0:g} s"
        step = _part_side(eng, specs, RunStep(label, t0), effect)
        if _step_holds(eng, specs, step, n_windows, alpha):
            steps.append(step)
    if len(runs) >= 2 and 2 * len(steps) >= len(runs):
        # A jump in most runs is the part's (a step at one temperature, a cycle of the
        # chamber), not something that happened to one run: not an event.
        notes.append(
            f"jumps in {len(steps)} of {len(runs)} runs: not treated as session events "
            "(an effect that repeats in most runs is the part's or the chamber's)"
        )
        steps = []
    elif trailing and steps:
        # A run's temperature out of step reads, to the jump, as a step where the ramp
        # turns; a step mid-run reads, to a run's rate, as the rate of the ramp it
        # falls in. Each is kept only if it still holds beside the other.
        beside = {a: replace(sp, events=(*sp.events, *steps)) for a, sp in specs.items()}
        trailing = [
            t
            for t in trailing
            if corrected_p(chi2_sf(_pooled_stat(eng, beside, t), 3), len(runs)) < alpha
        ]
        beside = {a: replace(sp, events=(*sp.events, *trailing)) for a, sp in specs.items()}
        steps = [st for st in steps if _step_holds(eng, beside, st, n_windows, alpha)]
    if len(runs) == 1 and steps:
        # With one record nothing tells a step from the part's own response where the
        # temperature's course turns (a lag's onset as a soak ends): no run without it.
        notes.append(
            f"{steps[0].effect[len(EVENT_PREFIX) :]} (the session's only record) is not "
            "treated as a session event: with one record, no other run tells a step "
            "from the part's own response there"
        )
        steps = []
    for term in [*trailing, *steps][:MAX_EVENTS]:
        for a in AXES:
            specs[a] = replace(specs[a], events=(*specs[a].events, term))
        lines.append(term.effect)
    # Run levels on the axes that read 0 g in the run, greedily.
    before = dict(specs)
    levels: dict[str, list[str]] = {a: [] for a in AXES}
    for _ in range(MAX_EVENTS - len(lines)):
        found = _best_level(eng, specs, runs, labels, alpha)
        if found is None:
            break
        axis, spec, effect = found
        specs[axis] = spec
        levels[axis].append(f"{effect} on {axis}")
    for a in AXES:
        zero_g = [i for i, idx in enumerate(runs) if _reads_zero_g(eng, idx, a)]
        units = {_level_unit(eng, before[a], runs[i], a, i) for i in zero_g}
        # Of two ± pairs' levels (the six orientations), one off is one run, both off
        # the axis' scatter.
        paired = len(units) == 2 < len(zero_g)
        off = 2 * len(levels[a])
        if levels[a] and (off > len(units) if paired else off >= len(units) >= 2):
            # As for steps: levels off in half the runs or more are this axis' scatter
            # from run to run (a turn-on offset, a logged temperature off by run), which
            # its offset averages over; as events they would leave it to the runs left.
            notes.append(
                f"levels off in {len(levels[a])} of {len(zero_g)} zero-g runs of {a}: not treated "
                "as session events (the axis' scatter from run to run, which its offset "
                "averages over)"
            )
            specs[a] = before[a]
            levels[a] = []
        lines += levels[a]
    return specs, lines, notes


def _pooled_fit(
    eng: Engine, specs: Mapping[str, Spec], term: Term
) -> tuple[float, FloatArray, FloatArray]:
    """Fit one event term on every sample beside the models: chi-square, sizes, errors.

    Each axis' coefficient against its standard error, widened by the residual's own
    correlation (:func:`variance_inflation`); the chi-square (3 dof) sums them over the
    axes. Sizes and widened standard errors per axis (NaN where not estimated).
    """
    trial = {a: replace(spec, events=(*spec.events, term)) for a, spec in specs.items()}
    models, _, _ = fit_models(eng, trial)
    stat = 0.0
    size = np.full(len(AXES), np.nan)
    error = np.full(len(AXES), np.nan)
    for i, (a, m) in enumerate(models.items()):
        j = m.terms.index(term)
        var = float(m.covariance[j, j]) * variance_inflation(eng, a, trial[a])
        if m.estimated[j] and var > 0:
            size[i], error[i] = float(m.coefficients[j]), math.sqrt(var)
            stat += size[i] ** 2 / var
    return stat, size, error


def _pooled_stat(eng: Engine, specs: Mapping[str, Spec], term: Term) -> float:
    """Chi-square (3 dof) of one event term fitted beside the models (:func:`_pooled_fit`)."""
    return _pooled_fit(eng, specs, term)[0]


def level_runs(specs: Mapping[str, Spec]) -> list[str]:
    """Return the records whose level some axis' events hold (a step at the run's start)."""
    return sorted(
        {
            t.basis.run
            for spec in specs.values()
            for t in spec.events
            if isinstance(t.basis, RunStep) and t.basis.at_s == 0.0 and not t.basis.before
        }
    )


def levels_on_every_axis(
    eng: Engine, specs: Mapping[str, Spec], alpha: float
) -> dict[str, Spec] | None:
    """Find the level of each run of :attr:`Engine.event_runs` on the axes that read ±1 g.

    A run's level is looked for first on the axes that read 0 g in it
    (:func:`find_run_events`): on an axis that reads ±1 g, one run's level is, between
    runs, half a sensitivity and half a second-order gain. Once a run's level is off
    on some axis (a knock, a power glitch: what happened to the run moved every axis),
    its level on the other axes is tried too, on an earlier pass' output less the
    events found (``eng``), beside the effects chosen there (``specs``): kept when the
    run's mean residual passes the test of :func:`find_run_events` (corrected over the
    levels tried) and the fit on every sample gains. Returns the specs with the levels
    found (None: none found).
    """
    specs = dict(specs)
    runs = _runs(eng)
    labels = _labels(eng, runs)
    tried = [
        (a, i)
        for i, label in enumerate(labels)
        if label in eng.event_runs
        for a in AXES
        if not _reads_zero_g(eng, runs[i], a)
    ]
    found = False
    for a, i in tried:
        effect = f"{EVENT_PREFIX}level of run {labels[i]}"
        spec = specs[a]
        if any(t.effect == effect for t in spec.events):
            continue
        resid = eng.residuals(a, spec.terms(a))[0]
        if not _level_passes(eng, resid, runs[i], len(tried), alpha):
            continue
        trial = replace(
            spec, events=(*spec.events, Term("offset", RunStep(labels[i], 0.0), effect=effect))
        )
        if eng.cv(a, trial.terms(a)).sse_in < eng.cv(a, spec.terms(a)).sse_in:
            specs[a], found = trial, True
    return specs if found else None


def _part_side(eng: Engine, specs: Mapping[str, Spec], after: RunStep, effect: str) -> Term:
    """Return the step as the offset of the side of it that is not the part's.

    A step in one run splits it in two levels; the term holds one of them free, and
    the other is the part's, tied to the models by the rest of the session. A part
    knocked mid-run is itself before the step (``step(RUN@t0)``); an offset that went
    away (a shift annealed out by the first hot soak) is the part after it
    (``until(RUN@t0)``). The side the session agrees with is the part's: of the two
    terms, the one whose fit beside the models leaves the smaller in-sample error,
    summed over the axes each relative to its error now. (Tied the wrong way, the
    part's side is freed and the other one pulls the models: an offset held by one run
    of a ± pair passes as a second-order gain.)
    """
    terms = [
        Term("offset", after, effect=effect),
        Term("offset", replace(after, before=True), effect=effect),
    ]
    now = {a: eng.cv(a, spec.terms(a)).sse_in for a, spec in specs.items()}

    def left(term: Term) -> float:
        total = 0.0
        for a, spec in specs.items():
            trial = replace(spec, events=(*spec.events, term))
            total += eng.cv(a, trial.terms(a)).sse_in / now[a] if now[a] > 0 else 0.0
        return total

    return min(terms, key=left)


def _step_holds(
    eng: Engine, specs: Mapping[str, Spec], step: Term, n_windows: int, alpha: float
) -> bool:
    """Tell whether a step, fitted on every sample beside the models, passes the jump's test.

    The local jump responds to any sharp feature of the residual (a kink the model
    leaves at a ramp's start, noise that grows at the hot end); a step is an offset
    that stays: its size fitted with the rest, against its standard error, pooled over
    the axes (chi-square, 3 dof) and corrected as the jump is.
    """
    return corrected_p(chi2_sf(_pooled_stat(eng, specs, step), 3), n_windows) < alpha


def event_corrections(eng: Engine, models: Mapping[str, AxisModel]) -> list[FloatArray]:
    """Return what the fitted session events add to each part's output (n, 3), mg.

    Every event's term of ``models`` (a step or a run's level, a :class:`RunStep`; a
    run's temperature out of step, a :class:`RunRate`)
    evaluated on the part's samples, times its coefficient.
    """
    out = []
    for f in eng.data.features:
        c = np.zeros((len(f), len(AXES)))
        for i, a in enumerate(AXES):
            m = models[a]
            for t, coef in zip(m.terms, m.coefficients, strict=True):
                if is_event(t.effect) and isinstance(t.basis, (RunStep, RunRate)) and coef:
                    c[:, i] += coef * t.basis.evaluate(f)
        out.append(c)
    return out


def _best_level(
    eng: Engine,
    specs: Mapping[str, Spec],
    runs: list[NDArray[np.int64]],
    labels: list[str],
    alpha: float,
) -> tuple[str, Spec, str] | None:
    """Return the run level that cuts an axis' residual most, if it passes the test."""
    # Every (axis, run) where the axis reads 0 g: the levels tried, and the tests counted.
    zero_g = [(a, i) for a in AXES for i, idx in enumerate(runs) if _reads_zero_g(eng, idx, a)]
    n_tests = len(zero_g)
    # An event is tried, and fitted, beside every cross-axis gain the runs can hold (the
    # full 3x3 gain): its size is not half taken by a misalignment. It must stand out of
    # the levels the selection's models leave, or of those the full gain leaves (an
    # axis whose misalignment the event itself kept from passing the selection's test
    # shows it there, and its levels look like its scatter).
    full = {a: with_cross(specs[a], cross_sources(eng, a)) for a in AXES}
    base = {a: eng.cv(a, full[a].terms(a)) for a in AXES}
    screens = [(model, *_screen(eng, model, runs, zero_g)) for model in (specs, full)]
    best: tuple[float, float, str, Spec, str] | None = None
    for a, i in zero_g:
        spec, idx, label = specs[a], runs[i], labels[i]
        effect = f"{EVENT_PREFIX}level of run {label}"
        if any(t.effect == effect for t in spec.events):
            continue
        if not any(
            _stands_out(levels, unit[(a, i)])
            and _level_passes(eng, eng.residuals(a, m[a].terms(a))[0], idx, n_tests, alpha)
            for m, unit, levels in screens
        ):
            continue
        term = Term("offset", RunStep(label, 0.0), effect=effect)
        trial = replace(full[a], events=(*spec.events, term))
        cut = base[a].sse_in - eng.cv(a, trial.terms(a)).sse_in
        fit = eng.fit(a, trial.terms(a))
        free = eng.free_terms(a, trial.terms(a))
        l1 = sum(
            abs(float(c))
            for t, c in zip(free, fit.beta_in, strict=True)
            if t.effect == effect or (t.kind == "gain" and t.source != a and t.basis == Constant())
        )
        key = (round(cut, 6), -l1)
        if best is None or key > (best[0], best[1]):
            best = (key[0], key[1], a, trial, effect)
    if best is None or best[0] <= 0:
        return None
    return best[2], best[3], best[4]


def _screen(
    eng: Engine,
    specs: Mapping[str, Spec],
    runs: list[NDArray[np.int64]],
    zero_g: list[tuple[str, int]],
) -> tuple[dict[tuple[str, int], _Unit], dict[_Unit, float]]:
    """Return the level each zero-g (axis, run) of ``specs``' residual counts in, and the levels.

    With a cross-axis gain from b, the runs at +1 g and -1 g on b share one level (the
    gain takes their difference; a tilt of one shows as half its size in both): the
    pair is one level, their mean. Each level is taken against the middle of its
    axis' others: a level every zero-g run of an axis shares is that axis' offset
    (moved by what its ±g runs hold: a tilted run's cosine loss), not one run's.
    """
    # Run means from the window means (exactly the samples' own, in a fraction of the
    # time): only the levels that stand out are tested on the samples.
    run_of = eng.sample_run[eng.window_start]
    resid_w = {a: window_residuals(eng, a, specs[a].terms(a)) for a in AXES}
    raw = {}
    for a, i in zero_g:
        sel = run_of == eng.sample_run[runs[i][0]]
        total = float(eng.window_weight[sel].sum())
        raw[(a, i)] = (
            float(np.dot(eng.window_weight[sel], resid_w[a][sel])) / total if total > 0 else 0.0
        )
    unit = {(a, i): _level_unit(eng, specs[a], runs[i], a, i) for a, i in zero_g}
    mean = {u: float(np.mean([raw[k] for k in zero_g if unit[k] == u])) for u in unit.values()}
    levels = {
        u: v - _middle([w for o, w in mean.items() if o[0] == u[0] and o != u])
        for u, v in mean.items()
    }
    return unit, levels


#: A level of the screen: (axis, run index), or (axis, "±b") for a ± pair on ``b``.
_Unit = tuple[str, int | str]


def _level_unit(eng: Engine, spec: Spec, idx: NDArray[np.int64], axis: str, i: int) -> _Unit:
    """Return the level a zero-g run of ``axis`` counts in: its own, or its ± pair's.

    ``(axis, i)`` for run ``i``; ``(axis, "±b")`` when the run reads ±1 g on ``b`` and
    the axis' model holds a cross-axis gain from ``b``.
    """
    g = np.abs(eng.gravity[idx[0]])
    b = AXES[int(np.argmax(g))]
    return (axis, f"±{b}") if g.max() > 0.5 and b in spec.cross else (axis, i)


def _reads_zero_g(eng: Engine, idx: NDArray[np.int64], axis: str) -> bool:
    """Tell whether ``axis`` reads 0 g in the run of samples ``idx`` (one orientation)."""
    return bool(abs(eng.gravity[idx[0], AXES.index(axis)]) < 0.5)


def _middle(values: list[float]) -> float:
    """Median of ``values``; 0 for none."""
    return float(np.median(values)) if values else 0.0


def _stands_out(levels: Mapping[_Unit, float], key: _Unit) -> bool:
    """Tell whether a run's level stands out of the levels of every zero-g (axis, run).

    A tilted run is one run off; runs whose levels all scatter (each power-on with its
    own offset, the part's turn-on repeatability) are the session's scatter, which the
    part's offset averages over: fitted as events, they would leave it to the few runs
    left. A level is an event only beyond :data:`LEVEL_OUTLIER_Z` robust standard
    deviations (1.4826 MAD) of the others, and of the same axis' levels when they
    scatter more; with fewer than four others, always.
    """
    others = np.array([v for k, v in levels.items() if k != key])
    if others.size < 4:
        return True
    mid = float(np.median(others))
    spread = 1.4826 * float(np.median(np.abs(others - mid)))
    # An axis that scatters more than the others between runs (a tempco on z alone
    # turns each run's temperature offset into a level of z only) is judged against
    # its own scatter too: against the pool, each of its levels would stand out. Its
    # own levels, this one included: the MAD of four values is not moved far by one
    # run off, and that of three is too often small by chance.
    same = np.array([v for k, v in levels.items() if k[0] == key[0]])
    if same.size >= 3:
        spread = max(spread, 1.4826 * float(np.median(np.abs(same - np.median(same)))))
    return abs(levels[key] - mid) > LEVEL_OUTLIER_Z * spread


def _level_passes(
    eng: Engine, resid: FloatArray, idx: NDArray[np.int64], n_tests: int, alpha: float
) -> bool:
    """Tell whether a run's mean residual stands out of the scatter of its block means."""
    t = eng.elapsed_s[idx]
    block = np.floor((t - t[0]) / _LEVEL_BLOCK_S).astype(np.int64)
    if block.max() < 2:
        return False
    w = eng.w[idx]
    sums = np.bincount(block, weights=w * resid[idx])
    wts = np.bincount(block, weights=w)
    means = sums[wts > 0] / wts[wts > 0]
    m = means.size
    if m < 3:
        return False
    se = float(np.std(means, ddof=1)) / math.sqrt(m)
    if not se > 0:
        return False
    # Student's t of the run's level against its block means' scatter (which holds
    # the run's own slow structure), two-sided, over every (axis, run) tried.
    t_stat = abs(float(np.mean(means))) / se
    return corrected_p(2.0 * t_sf(t_stat, m - 1), n_tests) < alpha
