"""Terms that vary only between runs are judged between runs.

A column constant inside every run (the square of an axis' gravity in static
orientations, a gain on a gravity component, an extra column logged as one value per
run, a run's level) is identified by the runs' mean levels alone. The held-out folds
inside runs (legs, time blocks) cannot judge it: a fold's held-out samples share their
run's level with the training samples of the same run, so a run level that belongs to
the *session* (each power-on with its own offset, a bias that wanders over the run) is
carried into the held-out error as if it were the part's, and a term that follows the
pattern of the runs' levels looks real. With one run per orientation, a second-order
gain and a pattern of turn-on offsets are the same columns at the run level.

So a candidate that adds such columns must also pass a test at the run level
(:func:`between_runs_p`): on each axis it changes, the runs' mean residuals (weighted,
every run one value) with and without the candidate, against the scatter of that
axis' run means the model leaves. An axis model whose run-constant columns span ``q``
dimensions over ``K`` runs leaves ``K - q`` degrees of freedom between runs (a
six-position session with the full 3x3 gain: 6 - 4 = 2 per axis, one with a
second-order gain). The axes' F tests are combined by Fisher's method: the axes need
not scatter alike between runs (a tempco on z alone turns each run's temperature
offset into a level of z only, and against the scatter of all axes pooled a draw of
z's passed for a second-order gain or a misalignment). An axis with no degree of
freedom left is judged against the pool of the others; with none anywhere, there is
no evidence, and the candidate is not accepted.

Columns that vary within runs (temperature, time, a logged supply) have run means too
and take a little of the runs' scatter: the scatter left is then slightly small, and
the test slightly lenient, never stricter than it should be.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from accelcore.model import AXES, Term

from .engine import Engine
from .inside import excess, heldout_window_residuals
from .space import Spec, with_cross
from .stats import Verdict, accept, chi2_sf, f_sf
from .steps import Step

__all__ = [
    "RunLevelTest",
    "adds_only_run_constant",
    "between_runs_p",
    "cross_given_back",
    "cross_left_out",
    "heldout_window_residuals",
    "hold_cross",
    "n_runs",
    "one_run_caveats",
    "run_constant_keys",
    "run_level_cut",
    "window_residuals",
    "within_run_sse_blocks",
    "within_runs",
]

FloatArray = NDArray[np.float64]

#: A column is constant inside every run, too, when its basis' weighted square deviations
#: from its run means are at most this share of those from its mean: its variation inside
#: runs is then at most 3 % of its whole in RMS, and what it can explain there at most
#: 0.1 % of what it explains between runs (a supply set per run and logged with a
#: meter's noise: the run-level test judges it, the test inside runs would see only
#: the noise).
RUN_CONSTANT_SHARE = 1e-3

#: A column is constant inside a run when it spans at most this fraction of its
#: largest magnitude there (window means of a constant are that constant to rounding:
#: a few eps of the weighted sums; 1e-9 leaves room for sums of millions of samples).
_CONSTANT_RTOL = 1e-9


@dataclass(frozen=True)
class _Runs:
    """The runs of an engine's windows.

    Each window's run (0..k-1), its weight (0 in a run without weight) and each run's
    total weight (1 where it is 0).
    """

    index: NDArray[np.int64]
    k: int
    weight: FloatArray
    total: FloatArray


def _window_runs(eng: Engine) -> _Runs:
    """Return the runs of the engine's windows (kept per engine)."""
    found: _Runs | None = eng.__dict__.get("_window_runs")
    if found is None:
        run = eng.sample_run[eng.window_start]
        present = np.unique(run[eng.window_weight > 0])
        index = np.full(int(run.max()) + 1 if run.size else 0, -1, dtype=np.int64)
        index[present] = np.arange(present.size)
        of_window = index[run]
        k = int(present.size)
        weight = np.where(of_window >= 0, eng.window_weight, 0.0)
        of_window = of_window.clip(min=0)
        total = np.bincount(of_window, weights=weight, minlength=k)
        found = _Runs(of_window, k, weight, np.where(total > 0, total, 1.0))
        eng.__dict__["_window_runs"] = found
    return found


def _is_run_constant(eng: Engine, key: object) -> bool:
    """Tell whether a column (an engine key) is constant inside every run (kept per engine)."""
    cache: dict[object, bool] = eng.__dict__.setdefault("_run_constant", {})
    found = cache.get(key)
    if found is None:
        runs = _window_runs(eng)
        keep = runs.weight > 0
        col = eng._window_column(key)[keep]  # type: ignore[arg-type]
        r = runs.index[keep]
        hi = np.full(runs.k, -np.inf)
        lo = np.full(runs.k, np.inf)
        np.maximum.at(hi, r, col)
        np.minimum.at(lo, r, col)
        size = np.maximum(np.abs(hi), np.abs(lo))
        found = bool(np.all(np.isfinite(col)) and np.all(hi - lo <= _CONSTANT_RTOL * size))
        if not found and np.all(np.isfinite(col)):
            # Nearly constant: what its basis moves inside the runs (a meter's noise on a
            # supply set per run) is a tiny share of what it moves between them. The basis,
            # not the column: a gain's gravity is constant in each run, and between runs
            # it would make any basis look constant.
            x = eng._window_column((key[0], None))[keep]  # type: ignore[index]
            w = runs.weight[keep]
            means = np.bincount(r, weights=w * x, minlength=runs.k) / runs.total
            inside = float(np.sum(w * (x - means[r]) ** 2))
            total = float(np.sum(w * (x - np.sum(w * x) / np.sum(w)) ** 2))
            found = inside <= RUN_CONSTANT_SHARE * total
        cache[key] = found
    return found


def n_runs(eng: Engine) -> int:
    """Return the number of runs with weight."""
    return _window_runs(eng).k


def run_constant_keys(eng: Engine, axis: str, terms: Sequence[Term]) -> frozenset[int]:
    """Return the positions (in the axis' free columns) of the columns constant in every run."""
    return frozenset(
        j for j, key in enumerate(eng._keys(axis, terms)) if _is_run_constant(eng, key)
    )


def run_level_cut(
    eng: Engine, axis: str, current: Sequence[Term], candidate: Sequence[Term], rms_mg: float
) -> float:
    """Return the relative cut of an axis' RMS error that a candidate makes between runs.

    The runs' squared mean residuals it removes, per run, taken off the mean square of
    ``rms_mg`` (the axis' in-sample RMS error now, the same fit): the cut of the RMS
    error were every sample's run level moved as its run's mean. The least improvement
    of a candidate judged between runs (its held-out cut means nothing there) is on
    this figure.
    """
    (rss0, _), (rss1, _) = _run_level(eng, axis, current), _run_level(eng, axis, candidate)
    runs = _window_runs(eng).k
    ms = rms_mg * rms_mg
    if not (runs and ms > 0):
        return 0.0
    return 1.0 - math.sqrt(max(ms - max(rss0 - rss1, 0.0) / runs, 0.0) / ms)


def adds_only_run_constant(
    eng: Engine, axis: str, current: Sequence[Term], candidate: Sequence[Term]
) -> bool:
    """Tell whether every column ``candidate`` adds to ``current`` is constant in every run."""
    before = set(eng._keys(axis, current))
    added = [k for k in eng._keys(axis, candidate) if k not in before]
    return bool(added) and all(_is_run_constant(eng, k) for k in added)


def _run_level(eng: Engine, axis: str, terms: Sequence[Term]) -> tuple[float, int]:
    """Return the runs' sum of squared mean residuals of an axis model and its dof.

    The model is fitted on every sample (its held-out fit's coefficients on all data);
    the dof is the runs less the rank of the run means of its run-constant columns.
    Kept per engine: a candidate's figures serve its least improvement and then the
    family's joint test.
    """
    return eng.kept("_run_level", (axis, tuple(terms)), lambda: _run_level_of(eng, axis, terms))


def _run_level_of(eng: Engine, axis: str, terms: Sequence[Term]) -> tuple[float, int]:
    """:func:`_run_level`, computed."""
    runs = _window_runs(eng)
    keys = eng._keys(axis, terms)
    resid = window_residuals(eng, axis, terms)
    constant = sorted(run_constant_keys(eng, axis, terms))
    z = np.zeros((runs.k, len(constant)))
    if eng._heldout_of(axis, terms) is not None:
        for i, j in enumerate(constant):
            z[:, i] = _run_means(runs, eng._window_column(keys[j]))
    means = _run_means(runs, resid)
    free = _event_levels(eng, runs)
    if free.shape[1]:
        # A run with a session event on some axis (found on an earlier pass): its
        # level is free on every axis. What happened to the run (a knock, a power
        # cycle) moves each axis, and on an axis where one run's level lies in the
        # span of the model's run constants (the +1 g run of an axis: its level is half
        # a second-order gain and half a sensitivity) it would pass for the part's.
        z = np.column_stack([z, free])
        basis, sv, _ = np.linalg.svd(z, full_matrices=False)
        basis = basis[:, sv > sv.max() * runs.k * np.finfo(float).eps]
        means = means - basis @ (basis.T @ means)
        return float(means @ means), runs.k - basis.shape[1]
    rank = int(np.linalg.matrix_rank(z)) if z.size else 0
    return float(means @ means), runs.k - rank


def _event_levels(eng: Engine, runs: _Runs) -> FloatArray:
    """Return one indicator column (over the runs) per run of :attr:`Engine.event_runs`."""
    if not eng.event_runs:
        return np.zeros((runs.k, 0))
    run = eng.sample_run[eng.window_start]
    cols = []
    for r in np.unique(runs.index[runs.weight > 0]):
        label = eng.record_names[int(run[np.flatnonzero(runs.index == r)[0]])]
        if label in eng.event_runs:
            cols.append(np.eye(runs.k)[r])
    return np.array(cols, dtype=np.float64).reshape(-1, runs.k).T


def window_residuals(eng: Engine, axis: str, terms: Sequence[Term]) -> FloatArray:
    """Return each window's mean residual of an axis model fitted on every sample, mg.

    A window's samples share its model columns' means: exactly the weighted mean of the
    samples' in-sample residuals.
    """
    resid = eng._yc[axis].copy()
    held = eng._heldout_of(axis, terms)
    if held is not None:
        beta = np.asarray(held.coefficients, dtype=np.float64)
        for j, key in enumerate(eng._keys(axis, terms)):
            if beta[j] != 0.0 and np.isfinite(beta[j]):
                resid -= beta[j] * eng._window_column(key)
    return resid


def _run_means(runs: _Runs, values: FloatArray) -> FloatArray:
    """Return the weighted mean of a window column over each run."""
    return np.bincount(runs.index, weights=runs.weight * values, minlength=runs.k) / runs.total


@dataclass(frozen=True)
class RunLevelTest:
    """The nested F tests of some run-constant columns at the run level.

    ``f`` is the F statistic of every changed axis' cut against the runs' scatter
    pooled over the axes (``scatter_mg``, mg), shown; ``p`` is Fisher's combination
    of each changed axis' own F test (its cut against its own scatter, with ``dfd``
    the degrees of freedom they use in all), the one the selection uses. ``p`` is
    NaN when no degree of freedom is left between runs (no evidence either way).
    """

    f: float
    dfn: int
    dfd: int
    p: float
    scatter_mg: float


def between_runs_p(
    eng: Engine, current: Mapping[str, Sequence[Term]], candidate: Mapping[str, Sequence[Term]]
) -> RunLevelTest | None:
    """Return the run-level test of a step's run-constant columns (see the module).

    ``current``: the model of every axis before the step; ``candidate``: the models
    of the axes the step changes. The nested F test at the run level on each changed
    axis: the cut of its runs' squared mean residuals, per run-level dimension the step
    adds there, against the scatter its model after the step leaves (the pool of every
    axis' when it leaves none); the p-values combined by Fisher's method. None when the
    step adds no run-level dimension (nothing to judge between runs).
    """
    rss0 = rss1 = pooled = 0.0
    added = dof = 0
    # Per changed axis: (its cut, the dimensions it adds, the scatter left, its dof).
    changed: list[tuple[float, int, float, int]] = []
    for axis, terms in current.items():
        after = _run_level(eng, axis, candidate.get(axis, terms))
        if axis in candidate:
            before = _run_level(eng, axis, terms)
            rss0 += before[0]
            rss1 += after[0]
            added += before[1] - after[1]
            changed.append((before[0] - after[0], before[1] - after[1], *after))
        if after[1] > 0:
            pooled += after[0]
            dof += after[1]
    if added <= 0:
        return None
    if dof <= 0:
        return RunLevelTest(math.nan, added, 0, math.nan, math.nan)
    scatter = pooled / dof
    f = max(rss0 - rss1, 0.0) / added / scatter if scatter > 0 else math.inf
    # Each axis' cut against its own scatter between runs, the p-values combined by
    # Fisher's method: the axes need not scatter alike (a tempco on z alone turns each
    # run's temperature offset into a level of z only; against the pool, a draw of z's
    # scatter passed for an effect). An axis with no degree of freedom left is judged
    # against the pool.
    stat, k, used = 0.0, 0, 0
    for cut, dims, left, left_dof in changed:
        if dims <= 0:
            continue
        ref, ref_dof = (left / left_dof, left_dof) if left_dof > 0 else (scatter, dof)
        f_axis = max(cut, 0.0) / dims / ref if ref > 0 else math.inf
        stat -= 2.0 * math.log(max(f_sf(f_axis, dims, ref_dof), 1e-300))
        k, used = k + 1, used + ref_dof
    p = chi2_sf(stat, 2 * k) if k else math.nan
    return RunLevelTest(f, added, used, p, math.sqrt(scatter))


def hold_cross(eng: Engine, specs: Mapping[str, Spec]) -> dict[str, Spec] | None:
    """Return ``specs`` without the cross-axis gains the runs' levels can judge, or None.

    The starting calibration's cross-axis gains (the full 3x3 gain) are constant in
    every run: the misalignment family adds them back when the runs support them.
    One on a gravity that only one record sees stays as calibrated (it is that
    record's level, :attr:`Engine.gain_sources`), and all stay when no degree of
    freedom is left between runs to judge them either way (four orientations: as many
    runs as each axis' levels have parameters; held out, a clean misaligned part was
    7.7 mg off on another session). None: nothing is held out.
    """
    held = {
        a: replace(spec, cross=tuple(b for b in spec.cross if b not in eng.gain_sources))
        for a, spec in specs.items()
    }
    changed = {a: specs[a].terms(a) for a in specs if held[a] != specs[a]}
    if not changed:
        return None
    test = between_runs_p(eng, {a: spec.terms(a) for a, spec in held.items()}, changed)
    return held if test is not None and math.isfinite(test.p) else None


def cross_given_back(
    eng: Engine, specs: Mapping[str, Spec], start: Mapping[str, Spec]
) -> dict[str, Spec] | None:
    """Return ``specs`` with the starting cross-axis gains back when no test can judge them.

    After the session events are found, a run whose level is an event is free in the
    tests between runs (:attr:`Engine.event_runs`): with five orientations and one run
    tilted, no degree of freedom was left for the cross-axis gains held out at the
    start, and they were left out (9.5 mg on another session against 5.7 for
    ``calibrate``). As at the start (:func:`hold_cross`), what no test can judge stays
    as calibrated. None: a test can be made (its verdict stands).
    """
    back = {a: with_cross(spec, start[a].cross) for a, spec in specs.items()}
    if back == dict(specs) or hold_cross(eng, back) is not None:
        return None
    return back


def cross_left_out(rows: Sequence[Mapping[str, object]], min_improvement: float) -> str:
    """Return the warning line of a starting model's cross-axis gains left out.

    ``rows``: the selection's candidate rows; the ``misalignment`` ones of the last
    step that tried it give the figures (the run-level cut of each axis, the F test's
    p when one was made): the verdict that stands. A first step's figures may be those
    of what another family took at that step (a gravity direction drifting in every
    run holds a misalignment's shape on average).
    """
    tried = [r for r in rows if r["family"] == "misalignment"]
    last = max((int(r["step"]) for r in tried), default=0)  # type: ignore[call-overload]
    first = [r for r in tried if r["step"] == last]
    figures = ", ".join(
        f"{r['axis']} {float(r['cut_between_runs_pct']):.2g} %"  # type: ignore[arg-type]
        + (
            f" (held-out error {-float(r['cut_pct']):+.2g} %)"  # type: ignore[arg-type]
            if float(r["cut_pct"]) <= 0  # type: ignore[arg-type]
            and float(r["cut_between_runs_pct"]) >= 100 * min_improvement  # type: ignore[arg-type]
            else ""
        )
        for r in first
    )
    tested = [float(r["p_between_runs"]) for r in first]  # type: ignore[arg-type]
    tested = [p for p in tested if not math.isnan(p)]
    why = (
        f"the runs' F test gives p = {min(tested):.2g}"
        if tested
        else f"least {100 * min_improvement:g} %, with a held-out error that falls"
    )
    return (
        "the starting calibration's cross-axis gains (misalignment) are left out: they "
        "are constant in every run, and the runs' levels do not support them (their cut "
        f"of the runs' levels: {figures or 'none tried'}; {why}); fitted anyway, they "
        "would take the runs' own offsets (each power-on's), which another session "
        "does not repeat"
    )


def within_run_sse_blocks(
    eng: Engine, axis: str, terms: Sequence[Term], per_sample: bool = False
) -> FloatArray:
    """Return the held-out squared error per block less each run's mean held-out residual.

    What a model predicts of the runs' levels is taken out: the error left is how the
    residual moves *inside* runs, which the blocks of one run see independently.
    Computed on window means (exactly: a window's samples share its model columns), the
    deviations of the samples about their window means added as in :meth:`Engine.cv`;
    ``per_sample``: and what the model's moves inside windows add
    (:func:`.inside.excess`), the error per sample.
    """

    def make() -> FloatArray:
        runs = _window_runs(eng)
        resid = heldout_window_residuals(eng, axis, terms)
        d = resid - _run_means(runs, resid)[runs.index]
        found = (
            np.bincount(
                eng.window_block, weights=runs.weight * d * d, minlength=eng.block_start.size
            ).astype(np.float64)
            + eng._within[axis]
        )
        return found + excess(eng, axis, terms) if per_sample else found

    return eng.kept("_within_run_sse", (axis, tuple(terms), per_sample), make)


def within_runs(
    eng: Engine,
    axis: str,
    current: Sequence[Term],
    candidate: Sequence[Term],
    *,
    min_improvement: float,
    alpha: float,
    per_sample: bool = False,
    floor: float = 0.0,
    least: float = 0.0,
) -> Verdict:
    """Judge a candidate on its held-out error inside runs (the diagnosis' paired test).

    :func:`within_run_sse_blocks` of the current model and of the candidate, judged by
    :func:`.stats.accept`: the candidate's held-out cut must come from how the residual
    moves inside runs. The runs' levels, each power-on's own offset, would otherwise
    dominate the held-out error with whole runs as folds (hiding a real effect under
    their scatter), and a term that only moves a run's level (a function of the
    logged rate nearly constant on each leg, times a gravity component) would pass on
    the blocks of one held-out run counted as independent; the run-level test judges
    those (:func:`between_runs_p`).
    """
    return accept(
        within_run_sse_blocks(eng, axis, current, per_sample),
        within_run_sse_blocks(eng, axis, candidate, per_sample),
        min_improvement=min_improvement,
        alpha=alpha,
        floor=floor,
        least=least,
    )


def one_run_caveats(eng: Engine, steps: Sequence[Step]) -> list[str]:
    """Return a caveat for each second-order gain (``K2``) an axis gets from one run per sign.

    With one run at +1 g and one at -1 g, an axis has three run levels (those runs and
    its zero-g runs) for offset, sensitivity and ``K2``: a gain or level error of one of
    those two runs alone (a run a percent low for its whole length) gives the same
    levels, and the run-level test cannot tell them apart however small its p.
    """
    run = eng.sample_run[eng.window_start]
    out: list[str] = []
    for step in steps:
        pairs = []
        for axis in step.axes if step.effect == "nonlinearity" else ():
            g = eng.gravity[eng.window_start, AXES.index(axis)]
            ends = [
                {eng.record_names[int(r)] for r in np.unique(run[g * s > 0.5])} for s in (1, -1)
            ]
            if all(len(e) == 1 for e in ends):
                pairs.append(f"{axis} ({'/'.join(e.pop() for e in ends)})")
        if pairs:
            out.append(
                f"nonlinearity (K2) on {', '.join(pairs)} rests on one run at +1 g and one at "
                "-1 g: a gain or level error of one of those runs alone (a run a fraction of a "
                "percent off for its whole length) gives the same run levels; repeat those "
                "orientations to tell them apart"
            )
    return out
