"""The search of the diagnosis: variants of each family, the lag time-constant.

:func:`variants` lists the variants of one family on one axis (orders, sources,
extra columns), :func:`search_tau` finds a lag's time constant by held-out error (grid,
then parabolic steps; :func:`tau_trials` runs the trials in the core when the model's
columns that follow tau are lags or decays, :func:`search_many` several such searches
at once on :data:`search_threads` threads) and :func:`tau_se` its standard error. What
the data cannot tell apart is :mod:`.confounds`'.
"""

from __future__ import annotations

import math
import os
import weakref
from collections.abc import Callable, Container, Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from accelcore.core import TimeConstantSearch
from accelcore.model import (
    AXES,
    Basis,
    Decay,
    Elapsed,
    LaggedTemperaturePower,
    Term,
)

from .engine import CV, Engine
from .generic import generic_variants
from .observables import MIN_LEG_S
from .space import Spec, with_cross, with_lag_pair, with_tau

__all__ = [
    "at_upper_end",
    "cross_sources",
    "lag_range_s",
    "profile_se",
    "search_1d",
    "search_many",
    "search_tau",
    "tau_columns",
    "tau_se",
    "tau_trials",
    "variants",
    "warm_up_range_s",
    "with_gravity_drift",
    "with_warm_up",
]

#: Points of the log grid of a time-constant search, then at most SEARCH_STEPS steps
#: of parabolic interpolation around the best, until one moves less than TAU_TOL in
#: log tau (0.5 %, finer than a time constant's standard error).
GRID_POINTS = 10
SEARCH_STEPS = 8
TAU_TOL = 5e-3

#: Family name of the warm-up (a session event).
WARM_UP = "event: warm-up"

#: Family name of a gravity direction that turns with the time in every run (a session
#: event: a fixture or positioner creeping). An axis' sensing direction does not turn with
#: the time since a run started; a fixture settling under the part's weight does, the
#: same way in every run. Offered beside the drift family's variants, as the cross-axis
#: gains' line in elapsed time, so that the creep is not taken for a part's misalignment
#: (its mean over a run) and for a cross-axis gain following whatever else moves with the
#: time in the runs (the rate of temperature): both would be carried into the
#: calibration and raise the error on a session without the creep (round 4's
#: ``fixture_creep``: 0.61 -> 2.57 mg on the validation session).
GRAVITY_DRIFT = "event: gravity direction drifting"


#: Search range of a lag's time constant when none is given, s (the upper end then
#: capped by :func:`lag_range_s`).
TAU_RANGE_S = (5.0, 3600.0)

#: A lag's time constant is searched up to this share of the session's shortest
#: heating or cooling leg (three time constants: 95 % settled inside every leg).
LAG_LEG_SHARE = 1.0 / 3.0


def lag_range_s(eng: Engine, range_s: tuple[float, float] = TAU_RANGE_S) -> tuple[float, float]:
    """Return ``range_s`` ending at most at a third of the shortest heating or cooling leg.

    A time constant is told from a lag by the transient each leg starts with and the
    steady lag it settles to. Up to a third of a leg, the lagged temperature settles to
    ``1 - exp(-3)`` = 95 % of its steady lag inside every leg; a longer one settles less
    and less, and what its column fits is more and more each leg's memory of where it
    started, which another temperature profile does not repeat (an offset that shifts
    once the die passed 50 °C, a die that heats faster than it cools: a "lag" of
    1000-2000 s fitted those and raised the error on an independent session 1.9x and
    1.7x; up to half a leg, the second still 1.17x on one seed). Without a heating or
    cooling leg (a steady session), ``range_s`` as it is. Legs shorter than
    :data:`MIN_LEG_S` (only a record that short holds one: shorter legs join a
    neighbour) do not count while a longer one exists: a run cut short does not take
    the lag away from the others.
    """
    lo, hi = range_s
    if not eng.leg_s:
        return range_s
    legs = [s for s in eng.leg_s.values() if s >= MIN_LEG_S] or list(eng.leg_s.values())
    cap = LAG_LEG_SHARE * min(legs)
    return lo, max(lo, min(hi, cap))


def warm_up_range_s(eng: Engine) -> tuple[float, float]:
    """Search range of a warm-up's time constant: 5 s to a third of the longest run."""
    longest = float(eng.elapsed_s.max()) if eng.n else 0.0
    return 5.0, max(10.0, longest / 3.0)


def at_upper_end(tau: float, range_s: tuple[float, float]) -> bool:
    """Whether a searched time constant ended at the top of its range (the search's tolerance).

    A warm-up there would decay slower than any warm-up the runs can show: its time
    constant is not identified, and the shape is a drift's (a line in time is the
    limit of ``exp(-t / tau)``), which the drift family tries as a property of the
    part. Taken as a warm-up, a drift of 7-10 mg/h in three 1 h runs was fitted as
    this session's event (tau 1200 s, a third of the runs) and left out of the
    calibration: 2.04 mg on a cooling session of the same part, against 1.52 as a drift.
    """
    return tau >= range_s[1] / (1.0 + 2.0 * TAU_TOL)


def with_warm_up(spec: Spec, tau: float) -> Spec:
    """Return ``spec`` with an offset decaying as ``exp(-t / tau)`` from each run's start."""
    term = Term("offset", Decay(tau), effect=WARM_UP)
    kept = tuple(t for t in spec.events if not isinstance(t.basis, Decay))
    return replace(spec, events=(*kept, term))


def with_gravity_drift(spec: Spec, sources: Sequence[str]) -> Spec:
    """Return ``spec`` with the gains on ``sources``' gravity linear in elapsed time (an event)."""
    terms = tuple(Term("gain", Elapsed(), source=b, effect=GRAVITY_DRIFT) for b in sources)
    return replace(spec, events=(*spec.events, *terms))


def has_gravity_drift(spec: Spec) -> bool:
    """Whether ``spec`` holds the gravity direction's drift (:data:`GRAVITY_DRIFT`)."""
    return any(t.effect == GRAVITY_DRIFT for t in spec.events)


FloatArray = NDArray[np.float64]


def cross_sources(eng: Engine, axis: str) -> tuple[str, ...]:
    """Return the other axes that can carry a cross-axis gain (``Engine.gain_sources``)."""
    return tuple(b for b in eng.gain_sources if b != axis)


def variants(
    family: str,
    axis: str,
    spec: Spec,
    eng: Engine,
    max_order: int,
    extras: Sequence[str],
    skip: Container[str] = (),
) -> list[tuple[str, str, Spec]]:
    """(family, variant label, spec) of one family on one axis, cheapest first.

    ``smooth`` (the generic family) lists one family per slot and observable not in
    ``skip`` (:func:`accelcore.diagnosis.generic.generic_variants`).
    """
    if family == "smooth":
        return [v[:3] for v in generic_variants(axis, spec, eng, skip)]
    a_i = AXES.index(axis)
    own_values = eng.gravity_values[a_i]
    out: list[tuple[str, str, Spec]] = []
    if family == "offset_curvature":
        out = [
            (family, f"order {k}", replace(spec, offset_order=k))
            for k in range(max(2, spec.offset_order + 1), max_order + 1)
        ]
    elif family == "sensitivity_curvature" and own_values >= 2:
        out = [
            (family, f"order {k}", replace(spec, gain_order=k))
            for k in range(max(2, spec.gain_order + 1), max_order + 1)
        ]
    elif family == "misalignment":
        missing = tuple(b for b in cross_sources(eng, axis) if b not in spec.cross)
        if missing:
            out = [(family, "from " + "+".join(missing), with_cross(spec, missing))]
    elif family == "nonlinearity" and axis not in spec.squares and own_values >= 3:
        # The axis' own K2: g_a^2 beside the offset and the sensitivity needs three
        # values of g_a (-1, 0, +1 g). Not g_b^2 of another axis: with one run per
        # orientation, a run tilted about an axis is exactly a cross-axis gain plus
        # a g_b^2 term of its pair, so a part property would take a session event.
        out = [(family, f"g_{axis}^2", replace(spec, squares=(*spec.squares, axis)))]
    elif family == "drift":
        # Linear in the time since the run's start: the offset, or the sensitivity.
        if not spec.drift:
            out.append((family, "linear", replace(spec, drift=True)))
        if not spec.gain_drift and own_values >= 2:
            out.append((family, "sensitivity, linear", replace(spec, gain_drift=True)))
        sources = cross_sources(eng, axis)
        if sources and not has_gravity_drift(spec):
            label = "from " + "+".join(sources)
            out.append((GRAVITY_DRIFT, label, with_gravity_drift(spec, sources)))
    elif family == "extra":
        out = [
            (f"extra:{e}", e, replace(spec, extras=(*spec.extras, e)))
            for e in extras
            if e not in spec.extras
        ]
    return out


def search_tau(
    eng: Engine, axis: str, spec: Spec, tau_range_s: tuple[float, float], variant: str
) -> tuple[float, CV]:
    """Grid then golden-section search of the lag time constant on held-out SSE.

    The trials are scored on a stride of the rows (:meth:`Engine.cv_coarse`); the
    time constant found is cross-validated on every row.
    """
    return search_1d(eng, axis, lambda tau: with_tau(spec, variant, tau), tau_range_s)


def search_1d(
    eng: Engine, axis: str, make: Callable[[float], Spec], range_s: tuple[float, float]
) -> tuple[float, CV]:
    """Search a positive time constant of a model (``make(tau)``) on held-out SSE.

    A log grid of :data:`GRID_POINTS` over ``range_s``, then at most
    :data:`SEARCH_STEPS` of parabolic interpolation (golden section where a parabola
    leaves the bracket) around the best; the trials are scored on a stride of the
    engine's rows (:meth:`Engine.cv_coarse`, or the core's search: :func:`tau_trials`)
    and the value found is cross-validated on every row.
    """
    best, _ = tau_trials(eng, axis, make, range_s)
    return best, eng.cv(axis, make(best).terms(axis))


#: Whether :func:`tau_trials` runs the search in the core when the model allows it
#: (the same trials to rounding; False forces the Python loop, for tests and benches).
CORE_SEARCH = True

#: Threads of the core's searches run together (:func:`search_many`) and of the
#: engine's catalogue pushes (:attr:`Engine.threads`); None: one per core. A bulk
#: worker process sets it to its share of the cores (:mod:`accelcore.apps.bulk`), so
#: that jobs times threads never exceeds the cores.
search_threads: int | None = None

#: Key of a core search: the axis, the range, the model's column keys at both ends of
#: the range (they make its design: :func:`tau_columns`) and the search's settings.
_SearchKey = tuple[object, ...]
_Trials = tuple[float, dict[float, float]]


def tau_trials(
    eng: Engine,
    axis: str,
    make: Callable[[float], Spec],
    range_s: tuple[float, float],
    *,
    core: bool | None = None,
) -> tuple[float, dict[float, float]]:
    """Return the best time constant and every trial's score (rounded tau -> score).

    The trials of :func:`search_1d`. ``core`` (default :data:`CORE_SEARCH`): run
    them in the core (:class:`accelcore.core.TimeConstantSearch`) when the model's
    columns that depend on tau are lagged temperature powers or decays (see
    :func:`tau_columns`), else in Python, each through :meth:`Engine.cv_coarse`.
    Both try the same values and score them alike to rounding (the core fits the
    blocks of one fold as one block: the same sum of held-out errors); the core's
    skips the Python of each trial and builds each tau's columns once for every axis.
    """
    if CORE_SEARCH if core is None else core:
        key = _search_key(eng, axis, make, range_s)
        found = _found(eng).get(key)
        if found is None:
            recipe = tau_columns(eng, axis, make, range_s)
            if recipe is not None:
                best, trials = _core(eng).search(
                    *recipe,
                    range_s=range_s,
                    grid_points=GRID_POINTS,
                    steps=SEARCH_STEPS,
                    tol=TAU_TOL,
                )
                found = _keep(eng, key, best, trials)
        if found is not None:
            return found[0], dict(found[1])
    return _python_trials(eng, axis, make, range_s)


def search_many(
    eng: Engine,
    searches: Sequence[tuple[str, Callable[[float], Spec]]],
    range_s: tuple[float, float],
) -> None:
    """Run in the core, at once, the searches :func:`tau_trials` will be asked for.

    ``searches``: ``(axis, make)`` of each. Those the core can run (:func:`tau_columns`)
    and has not run yet go to one
    :meth:`~accelcore.core.TimeConstantSearch.search_many` on :data:`search_threads`
    threads; :func:`tau_trials` then takes their results for the same model (the
    same column keys) and range. Each search gives the floats it gives alone, on any
    number of threads. Nothing when :data:`CORE_SEARCH` is False.
    """
    if not CORE_SEARCH:
        return
    found = _found(eng)
    wanted: dict[
        _SearchKey, tuple[FloatArray, FloatArray, list[tuple[str, int, FloatArray | None]]]
    ]
    wanted = {}
    for axis, make in searches:
        key = _search_key(eng, axis, make, range_s)
        if key in found or key in wanted:
            continue
        recipe = tau_columns(eng, axis, make, range_s)
        if recipe is not None:
            wanted[key] = recipe
    if not wanted:
        return
    results = _core(eng).search_many(
        list(wanted.values()),
        range_s=range_s,
        grid_points=GRID_POINTS,
        steps=SEARCH_STEPS,
        tol=TAU_TOL,
        threads=search_threads or os.cpu_count() or 1,
    )
    for key, (best, trials) in zip(wanted, results, strict=True):
        _keep(eng, key, best, trials)


#: Searches the core ran for each engine, by :func:`_search_key` (at most
#: :data:`_KEPT_SEARCHES`; all are dropped when one more is needed).
_FOUND: weakref.WeakKeyDictionary[Engine, dict[_SearchKey, _Trials]] = weakref.WeakKeyDictionary()
_KEPT_SEARCHES = 256


def _found(eng: Engine) -> dict[_SearchKey, _Trials]:
    found = _FOUND.get(eng)
    if found is None:
        found = _FOUND[eng] = {}
    return found


def _search_key(
    eng: Engine, axis: str, make: Callable[[float], Spec], range_s: tuple[float, float]
) -> _SearchKey:
    """Return what determines a core search's result (see :data:`_SearchKey`)."""
    lo, hi = range_s
    ends = tuple(eng._keys(axis, make(t).terms(axis)) for t in (lo, hi))
    return (axis, (float(lo), float(hi)), ends, GRID_POINTS, SEARCH_STEPS, TAU_TOL)


def _keep(eng: Engine, key: _SearchKey, best: float, trials: FloatArray) -> _Trials:
    """Keep a core search's result under its key; return it."""
    found = _found(eng)
    if len(found) >= _KEPT_SEARCHES:
        found.clear()
    kept = (float(best), {float(t): float(v) for t, v in trials})
    found[key] = kept
    return kept


#: The core's search of each engine (it keeps the window means of the columns each
#: time constant builds: every axis' model tries the same grid).
_SEARCHES: weakref.WeakKeyDictionary[Engine, TimeConstantSearch] = weakref.WeakKeyDictionary()


def _core(eng: Engine) -> TimeConstantSearch:
    """Return the core's search over the engine's samples and windows (made once)."""
    found = _SEARCHES.get(eng)
    if found is None:
        found = TimeConstantSearch(
            eng._wholes,
            eng._gather,
            eng.elapsed_s,
            eng.windows.w,
            eng.windows.start,
            eng.window_weight,
            eng.window_block,
            eng.block_fold,
            t_ref_c=eng.t_ref_c,
            stride=eng.coarse_stride,
        )
        _SEARCHES[eng] = found
    return found


def tau_columns(
    eng: Engine, axis: str, make: Callable[[float], Spec], range_s: tuple[float, float]
) -> tuple[FloatArray, FloatArray, list[tuple[str, int, FloatArray | None]]] | None:
    """Return a model as the core's search takes it (fixed design, response, columns), or None.

    The model's column keys at the two ends of ``range_s`` are compared: a key that
    stays is a fixed column (its window means), one that follows tau must be a
    lagged temperature power (``("lag", order, multiplier)``) or a decay
    (``("decay", 0, multiplier)``), a gain's multiplier the window gravity of its
    source. None when the model is anything else, when a fixed column could take the
    place of one that follows tau at some trial value (two of one basis: the model
    would hold it once), or when the range is not ``0 < lo < hi``.
    """
    lo, hi = range_s
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        return None
    first = eng._keys(axis, make(lo).terms(axis))
    second = eng._keys(axis, make(hi).terms(axis))
    if len(first) != len(second):
        return None
    fixed: list[FloatArray] = []
    fixed_keys: list[tuple[Basis, str | None]] = []
    columns: list[tuple[str, int, FloatArray | None]] = []
    moving: list[tuple[type, int, str | None]] = []
    for (b1, s1), (b2, s2) in zip(first, second, strict=True):
        if (b1, s1) == (b2, s2):
            columns.append(("fixed", len(fixed), None))
            fixed.append(eng._window_column((b1, s1)))
            fixed_keys.append((b1, s1))
            continue
        if s1 != s2:
            return None
        multiplier = None if s1 is None else eng.window_gravity[:, AXES.index(s1)]
        if isinstance(b1, LaggedTemperaturePower) and (b1, b2) == (
            LaggedTemperaturePower(lo, b1.order),
            LaggedTemperaturePower(hi, b1.order),
        ):
            columns.append(("lag", b1.order, multiplier))
            moving.append((LaggedTemperaturePower, b1.order, s1))
        elif isinstance(b1, Decay) and (b1, b2) == (Decay(lo), Decay(hi)):
            columns.append(("decay", 0, multiplier))
            moving.append((Decay, 0, s1))
        else:
            return None
    if not moving:
        return None
    for basis, source in fixed_keys:
        order = basis.order if isinstance(basis, LaggedTemperaturePower) else 0
        if (type(basis), order, source) in moving:
            return None
    design = np.column_stack(fixed) if fixed else np.zeros((eng.n_windows, 0))
    return design, eng._yc[axis], columns


def _python_trials(
    eng: Engine, axis: str, make: Callable[[float], Spec], range_s: tuple[float, float]
) -> tuple[float, dict[float, float]]:
    """Return the trials of :func:`search_1d`, each through :meth:`Engine.cv_coarse`."""
    cache: dict[float, float] = {}
    tau_range_s = range_s

    def score(tau: float) -> float:
        tau = float(f"{tau:.3g}")
        if tau not in cache:
            cache[tau] = eng.cv_coarse(axis, make(tau).terms(axis))
        return cache[tau]

    lo, hi = math.log(tau_range_s[0]), math.log(tau_range_s[1])
    grid = np.linspace(lo, hi, GRID_POINTS)
    vals = [score(math.exp(g)) for g in grid]
    i = int(np.argmin(vals))
    # Bracket (a, x, b) around the grid's best, then parabolas through the three in
    # log tau (a golden-section step where a parabola leaves the bracket), until a
    # step moves less than TAU_TOL (log) or SEARCH_STEPS are spent.
    a, fa = grid[max(i - 1, 0)], vals[max(i - 1, 0)]
    b, fb = grid[min(i + 1, grid.size - 1)], vals[min(i + 1, grid.size - 1)]
    x, fx = grid[i], vals[i]
    golden = (3 - math.sqrt(5)) / 2
    for _ in range(SEARCH_STEPS):
        num = (x - a) ** 2 * (fx - fb) - (x - b) ** 2 * (fx - fa)
        den = (x - a) * (fx - fb) - (x - b) * (fx - fa)
        u = x - 0.5 * num / den if den != 0 else math.nan
        if not (a < u < b) or abs(u - x) < 0.5 * TAU_TOL:
            # Golden section of the larger side.
            u = x + golden * (b - x) if (b - x) > (x - a) else x - golden * (x - a)
        fu = score(math.exp(u))
        moved = abs(u - x)
        if fu < fx:
            if u < x:
                b, fb = x, fx
            else:
                a, fa = x, fx
            x, fx = u, fu
        elif u < x:
            a, fa = u, fu
        else:
            b, fb = u, fu
        if moved < TAU_TOL or b - a < 2 * TAU_TOL:
            break
    best = min(cache, key=lambda t: cache[t])
    return best, cache


def tau_se(eng: Engine, axis: str, spec: Spec, cooling: bool = False) -> float:
    """Return the standard error of tau from the curvature of the in-sample SSE profile.

    ``cooling``: of a two-way die lag's cooling time constant (:attr:`Spec.tau_cool`).
    """
    if cooling:
        heat, cool = spec.tau, spec.tau_cool
        if heat is None or cool is None:
            return math.nan
        return profile_se(eng, axis, lambda c: with_lag_pair(spec, heat, c), cool)
    variant = "die" if spec.tau is not None else "rate"
    tau = spec.tau if spec.tau is not None else spec.rate_tau
    if tau is None:
        return math.nan
    return profile_se(eng, axis, lambda t: with_tau(spec, variant, t), tau)


def profile_se(eng: Engine, axis: str, make: Callable[[float], Spec], tau: float) -> float:
    """Return the standard error of a time constant from the in-sample SSE curvature."""
    h = 0.05 * tau
    s0 = eng.cv(axis, make(tau).terms(axis))
    sp = eng.cv(axis, make(tau + h).terms(axis)).sse_in
    sm = eng.cv(axis, make(max(tau - h, 1e-3)).terms(axis)).sse_in
    curv = (sp - 2 * s0.sse_in + sm) / (h * h)
    p = len(s0.terms)
    sigma2 = s0.sse_in / max(eng.n - p - 1, 1)
    return math.sqrt(2.0 * sigma2 / curv) if curv > 0 else math.nan
