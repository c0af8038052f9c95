"""The lag's refinement: a die lag of one time constant while heating, another while cooling.

A die coupled to the chamber's air differently while it heats (a heater blowing on the
board) and while it cools (through the chamber's walls) trails the logged temperature
by a time constant of each (:class:`~accelcore.model.LaggedTemperaturePower` with
``cool_tau_s``). The family ``two_way_lag`` (:data:`.space.TWO_WAY_LAG`) offers it on an
axis whose model already holds a lag of one time constant: :func:`two_way_variants`,
through :func:`search_two_way`.
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import partial

import numpy as np
from numpy.typing import NDArray

from .engine import CV, Engine
from .search import TAU_TOL, search_1d
from .space import TWO_WAY_LAG, Spec, with_lag_pair, with_tau
from .verdicts import Tried

__all__ = ["TWO_WAY_PROBE", "TWO_WAY_TRIALS", "search_two_way", "two_way_variants"]


def two_way_variants(
    eng: Engine, axis: str, spec: Spec, range_s: tuple[float, float]
) -> list[Tried]:
    """Return the axis' die lag with a time constant of its own each way, if any.

    Only on an axis whose model holds a lag of one time constant (a die lag, or a
    rate term, which it replaces: a rate term is the share of a two-way lag that a
    one-way die lag misses, and took its place), where the session both heats and cools
    (each way has a leg: the other way's time constant is otherwise not seen), and
    where the search parts the two (:func:`search_two_way`, from the one-way die lag's
    time constant, in ``range_s``).
    """
    if spec.tau_cool is not None or (spec.tau is None) == (spec.rate_tau is None):
        return []
    if not {"heating", "cooling"} <= set(eng.leg_kinds.values()):
        return []
    bare = replace(spec, rate_tau=None)
    start = spec.tau
    if start is None:
        start, _ = search_1d(eng, axis, partial(with_tau, bare, "die"), range_s)
    heat, cool, cv = search_two_way(eng, axis, bare, range_s, start)
    two = with_lag_pair(bare, heat, cool)
    if two.tau_cool is None:
        return []
    label = f"heating {heat:.3g} s, cooling {cool:.3g} s"
    if spec.rate_tau is not None:
        label += " (in place of the rate term)"
    return [(TWO_WAY_LAG, label, cv, two)]


#: Most trials of the two-way lag's search (each scored on a stride of the rows).
TWO_WAY_TRIALS = 80

#: Factor by which the two-way lag's first trials part the heating and cooling time
#: constants from the one-way lag's (each way).
TWO_WAY_PROBE = 1.25


def search_two_way(
    eng: Engine, axis: str, spec: Spec, range_s: tuple[float, float], tau_s: float
) -> tuple[float, float, CV]:
    """Search a die lag of one time constant while heating and another while cooling.

    A simplex search (Nelder-Mead) of the two in log time constant, from the one-way
    lag's ``tau_s`` (``spec`` has no lag), each trial scored as :func:`search_1d`'s
    are (held-out error on a stride of the rows, :meth:`Engine.cv_coarse`), inside
    ``range_s``, until the simplex is smaller than :data:`TAU_TOL` or
    :data:`TWO_WAY_TRIALS` are spent. (The two trade off along a ridge: searching
    them in turn one at a time crept along it, (73, 213) s after two turns each for a
    die of (50, 250) s.) Returns both and the cross-validation of the lag they make,
    on every row.
    """
    lo, hi = math.log(range_s[0]), math.log(range_s[1])
    cache: dict[tuple[float, float], float] = {}

    def score(p: NDArray[np.float64]) -> float:
        heat, cool = (float(f"{math.exp(v):.3g}") for v in np.clip(p, lo, hi))
        if (heat, cool) not in cache:
            terms = with_lag_pair(spec, heat, cool).terms(axis)
            cache[(heat, cool)] = eng.cv_coarse(axis, terms)
        return cache[(heat, cool)]

    start = math.log(tau_s)
    # Only where the one-way lag is not already the best of its two neighbours that
    # part the ways (a factor TWO_WAY_PROBE each way): a lag the same both ways is
    # left as it is, at two trials' cost.
    here = score(np.array((start, start)))
    apart = math.log(TWO_WAY_PROBE)
    if all(score(np.array((start + d, start - d))) >= here for d in (apart, -apart)):
        return tau_s, tau_s, eng.cv(axis, with_lag_pair(spec, tau_s, tau_s).terms(axis))
    # From the one-way lag, and the two ways apart by a factor e each way.
    corners = ((start, start), (start + 0.5, start - 0.5), (start - 0.5, start - 0.5))
    simplex = [np.array(p, dtype=np.float64) for p in corners]
    values = [score(p) for p in simplex]
    while len(cache) < TWO_WAY_TRIALS:
        order = np.argsort(values, kind="stable")
        simplex = [simplex[k] for k in order]
        values = [values[k] for k in order]
        size = max(float(np.max(np.abs(p - simplex[0]))) for p in simplex[1:])
        if size < TAU_TOL:
            break
        centre = (simplex[0] + simplex[1]) / 2.0
        worst = simplex[2]
        reflected = centre + (centre - worst)
        f_r = score(reflected)
        if f_r < values[0]:
            expanded = centre + 2.0 * (centre - worst)
            f_e = score(expanded)
            simplex[2], values[2] = (expanded, f_e) if f_e < f_r else (reflected, f_r)
        elif f_r < values[1]:
            simplex[2], values[2] = reflected, f_r
        else:
            inside = centre + 0.5 * (worst - centre)
            f_c = score(inside)
            if f_c < values[2]:
                simplex[2], values[2] = inside, f_c
            else:
                simplex = [simplex[0], *((simplex[0] + p) / 2.0 for p in simplex[1:])]
                values = [values[0], *(score(p) for p in simplex[1:])]
    best = min(cache, key=lambda k: cache[k])
    heat, cool = best
    return heat, cool, eng.cv(axis, with_lag_pair(spec, heat, cool).terms(axis))
