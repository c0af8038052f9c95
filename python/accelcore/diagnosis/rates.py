"""A run whose logged temperature is out of step with the part's: a session event.

A probe left out of its place in one run (on a shelf, out of its clip in the air
stream) logs a temperature that trails the air; the part's temperature terms then read
that run off by about its tempco times the lag times the rate of change. The event's
term is that run's rate of change (:class:`~accelcore.model.RunRate`), found here and
fitted, like every session event, beside the models (:mod:`.events`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from accelcore.constants import MIN_TEMPERATURE_SPAN_C
from accelcore.model import AXES, RunRate, Term

from .engine import Engine
from .parameters import variance_inflation
from .space import EVENT_PREFIX, Spec
from .stats import chi2_sf, corrected_p

__all__ = ["trailing_runs"]

FloatArray = NDArray[np.float64]


def _window_fit(
    eng: Engine, specs: Mapping[str, Spec], term: Term
) -> tuple[FloatArray, FloatArray]:
    """Each axis' chi-square of one event term and its size, by the engine's window fits.

    The statistic of :func:`.events._pooled_fit` per axis before the residual's
    correlation widens it, from the drop of the in-sample error the term brings: ``coef² / var =
    drop / s²`` (``s²`` the residual variance per unit weight). No least squares on
    every sample, so that trying each run costs a few window fits. NaN where the term
    is not fitted.
    """
    key = (term.basis, None)  # an offset's column key (the engine's, as between's)
    n = int(np.count_nonzero(eng.w > 0))
    chi2 = np.full(len(AXES), np.nan)
    size = np.full(len(AXES), np.nan)
    for i, a in enumerate(AXES):
        terms = replace(specs[a], events=(*specs[a].events, term)).terms(a)
        keys = eng._keys(a, terms)
        held = eng._heldout_of(a, terms)
        dof = n - len(keys)
        after = eng.cv(a, terms).sse_in
        drop = eng.cv(a, specs[a].terms(a)).sse_in - after
        if held is None or key not in keys or dof <= 0 or not (drop > 0 and after > 0):
            continue
        chi2[i] = drop * dof / after
        size[i] = float(held.coefficients[keys.index(key)])
    return chi2, size


def _orientation(term: Term) -> str:
    """Return the orientation of a :class:`RunRate` term's record (``"OZ-"`` of ``"OZ- #2"``)."""
    return term.basis.run.split(" #")[0] if isinstance(term.basis, RunRate) else ""


def _opposite(orientation: str) -> str:
    """Return the other orientation of a ± pair (``"OZ+"`` for ``"OZ-"``)."""
    return orientation[:2] + ("-" if orientation.endswith("+") else "+")


def trailing_runs(
    eng: Engine,
    specs: Mapping[str, Spec],
    runs: list[NDArray[np.int64]],
    labels: list[str],
    alpha: float,
    outlier_z: float,
) -> tuple[list[Term], list[str]]:
    """Return the runs whose logged temperature is out of step with the part's, and notes.

    A probe that lagged in one run (left on a shelf, out of its clip) logs
    ``T - tau dT/dt``: the part's temperature terms then read that run off by about its
    tempco times ``tau dT/dt``, an offset in the run's rate of change
    (:class:`~accelcore.model.RunRate`). Each run's rate is fitted beside the models on
    every sample, its size pooled over the axes against its widened standard error
    (chi-square, 3 dof), Bonferroni-corrected over the runs. Being one run's, its size
    must also stand out of the other runs' on some axis: beyond ``outlier_z`` robust
    standard deviations of theirs (their median and MAD; at least its own standard
    error), as a run's level must. What the model leaves in every run's rate (a lag it
    lacks, or holds only in part) is the part's. As for steps, a rate off in half the
    runs or more is the part's, not an event, and so are rates off in both runs of a ±
    pair (a lag that differs with the orientation: blind round 4's ``orient_lag`` kept
    its z runs' steps, 3.36 mg on the validation session, where their rates as events
    left 3.69). Only where the temperature moves (:data:`MIN_TEMPERATURE_SPAN_C`).
    """
    if len(runs) < 3:
        return [], []
    lo, hi = np.quantile(eng.temperature, [0.05, 0.95])
    if not hi - lo >= MIN_TEMPERATURE_SPAN_C:  # NaN: no temperature logged
        return [], []
    raw: dict[str, tuple[FloatArray, FloatArray, Term]] = {}
    for label in dict.fromkeys(labels):
        term = Term(
            "offset", RunRate(label), effect=f"{EVENT_PREFIX}temperature out of step in {label}"
        )
        if np.any(eng.basis(term.basis)):
            raw[label] = (*_window_fit(eng, specs, term), term)

    def passes(chi2: FloatArray) -> bool:
        return bool(corrected_p(chi2_sf(float(np.nansum(chi2)), 3), len(runs)) < alpha)

    if not any(passes(c) for c, _, _ in raw.values()):
        return [], []  # not even as if the residual were white
    inflation = np.array([variance_inflation(eng, a, specs[a]) for a in AXES])
    fits: dict[str, tuple[float, FloatArray, FloatArray, Term]] = {}
    for label, (chi2, size, term) in raw.items():
        chi2 = chi2 / inflation
        fits[label] = (float(np.nansum(chi2)), size, np.abs(size) / np.sqrt(chi2), term)
    found: list[tuple[float, Term]] = []
    for label, (stat, size, error, term) in fits.items():
        if corrected_p(chi2_sf(stat, 3), len(runs)) >= alpha:
            continue
        others = np.array([f[1] for k, f in fits.items() if k != label])
        if others.shape[0] < 2:
            continue
        mid = np.nanmedian(others, axis=0)
        spread = np.maximum(1.4826 * np.nanmedian(np.abs(others - mid), axis=0), error)
        dev = np.abs(size - mid)
        # An axis the term is not fitted on (NaN), or no spread at all, tells nothing.
        z = np.divide(dev, spread, out=np.zeros_like(dev), where=spread > 0)
        if np.nanmax(z) > outlier_z:
            found.append((stat, term))
    if 2 * len(found) >= len(runs):
        return [], [
            f"temperatures out of step in {len(found)} of {len(runs)} runs: not treated as "
            "session events (what repeats in most runs is the part's: a lag)"
        ]
    # Both runs of a ± pair out of step alike is the axis' (a lag that differs with the
    # orientation), not what happened to one run: a probe lags in the run it was left in.
    seen = {_orientation(t) for _, t in found}
    paired = {o for o in seen if _opposite(o) in seen}
    notes: list[str] = []
    if paired:
        notes.append(
            f"temperatures out of step in both runs of a pair ({', '.join(sorted(paired))}): "
            "not treated as session events (what an orientation repeats is the part's)"
        )
        found = [f for f in found if _orientation(f[1]) not in paired]
    found.sort(key=lambda f: -f[0])
    return [t for _, t in found], notes
