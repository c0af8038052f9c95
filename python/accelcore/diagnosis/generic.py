"""The generic family: any observable, as a smooth function, in the offset or in a gain.

The named families are special cases of one mechanism: a function of something
logged, entering the model where it acts. This module offers that mechanism
whole. Each *observable* — temperature (``dT^1``), its rate of change (``dTdt``)
and every extra logged column (``extra:NAME``) — may enter as its line alone or as a
continuous piecewise-linear function (its line and :class:`~accelcore.model.Hinge`
pieces at three evenly spaced knots where its data dwells) in one *slot*: the offset, the
sensitivity (the gain on the axis' own gravity) or the gain on another axis' gravity
(cross-axis coupling). Each (slot, observable) pair is a family of its own, named by what it
depends on and where it acts, e.g. ``offset vs dtemp_dt_c_per_min``, ``sensitivity
vs supply_v`` (one family over the axes, as ``sensitivity_curvature`` is: a
sensitivity that follows the supply on x and y is the same effect on z, where the
data may not tell it from a curvature) or ``gain on g_y vs supply_v``; the selection
tries every one of them on every axis by the same held-out test as the named
families. Time since the run's start is left to
the named drift and warm-up (see :func:`observables`). Should a term of time
ever enter here, it is a session event (:func:`accelcore.diagnosis.space.is_event`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Container, Sequence
from dataclasses import replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from accelcore._accelcore import sorted_values
from accelcore.model import (
    AXES,
    Basis,
    Elapsed,
    Extra,
    Hinge,
    TemperaturePower,
    TemperatureRate,
    Term,
)

from .engine import Engine
from .space import EVENT_PREFIX, Spec

__all__ = [
    "KNOT_FRACTIONS",
    "LINE",
    "TEMPERATURE_OBSERVABLES",
    "generic_variants",
    "knots",
    "observable_unit",
    "observables",
    "slot_name",
]

#: Label of the generic family's simplest variant: the observable's line alone.
LINE = "line"

#: Where an observable's hinges sit, as fractions of the span of its values (5th to
#: 95th percentile): four linear pieces of equal width, a knot kept only where the data
#: dwells (see :data:`_MIN_NEAR`). Evenly spaced rather than at quantiles, so that a
#: temperature that soaks at its ends still gets knots across its range.
KNOT_FRACTIONS = (0.25, 0.5, 0.75)

#: The finer variant: eight pieces (its knots hold the coarse ones), for a sharper
#: feature (a step at one temperature). It is tried where the coarse one cuts the
#: held-out error by half the least improvement or more, and taken over it only
#: when better by more than 1 %.
FINE_KNOT_FRACTIONS = tuple(k / 8 for k in range(1, 8))

#: The finest variant: sixteen pieces (a feature a few degrees wide over a wide
#: window), tried where the eight-piece one cuts.
FINEST_KNOT_FRACTIONS = tuple(k / 16 for k in range(1, 16))

_RANGE = (0.05, 0.95)

#: Observables driven by temperature (not tried when the temperature does not move).
TEMPERATURE_OBSERVABLES = ("temperature_c", "dtemp_dt_c_per_min")

#: Least fraction of the weighted samples on each side of a knot.
_MIN_SIDE = 0.05

#: A knot is kept where at least this share of what an even spread would put within
#: half a knot spacing of it is there. A knot between two values the data dwells at
#: (a rate of change that is mostly 0 and ±ramp: a chamber profile) would bend the
#: function where only the few samples of a ramp's start and end are, and another
#: session that dwells there (a slower ramp) would get what those transients fitted:
#: an offset tempco that differs between heating and cooling, fitted so by hinges of
#: the rate at ±1.34 °C/min, took an independent session ramping at 1.5 °C/min from
#: 1.24 to 17.6 mg. Without them, the function between two dwelling values is the
#: straight line between them.
_MIN_NEAR = 0.5


def observables(eng: Engine) -> list[tuple[str, Basis]]:
    """Name and basis (the observable's line) of every observable of the data.

    Time since the run's start is not one: every run of a chamber session follows
    the same profile in time, so a free function of time is confounded with the
    temperature history and would not repeat on a session with another profile.
    Time enters through the named families instead: a linear drift (a property of
    the part) and a warm-up after power-on (a session event).
    """
    out: list[tuple[str, Basis]] = [
        ("temperature_c", TemperaturePower(1)),
        ("dtemp_dt_c_per_min", TemperatureRate()),
    ]
    out += [(name, Extra(name)) for name in eng.varying_extras]
    return out


def observable_unit(inner: Basis) -> str:
    """Return the unit of an observable's line basis."""
    if isinstance(inner, TemperaturePower):
        return "°C"
    if isinstance(inner, TemperatureRate):
        return "°C/min"
    if isinstance(inner, Elapsed):
        return "h"
    return "unit"


def knot_label(eng: Engine, inner: Basis, knot_values: Sequence[float]) -> str:
    """Return a variant's knots as the observable's own values (``knots 6.2/16.9 °C``).

    A temperature's knots are held in ``T - t_ref`` (the basis ``dT``); they are shown as
    the temperature itself.
    """
    shift = eng.t_ref_c if isinstance(inner, TemperaturePower) else 0.0
    values = "/".join(f"{float(f'{k + shift:.6g}'):g}" for k in knot_values)
    return f"knots {values} {observable_unit(inner)}"


def knots(
    eng: Engine, inner: Basis, fractions: Sequence[float] = KNOT_FRACTIONS
) -> tuple[float, ...]:
    """Knots of an observable at ``fractions`` of its 5–95 % span where its data dwells."""
    key = (inner, tuple(fractions))
    if key not in eng.knot_cache:
        v, span = _span(eng, inner)
        eng.knot_cache[key] = () if span is None else _knots(v, span, fractions)
    return eng.knot_cache[key]


def _span(eng: Engine, inner: Basis) -> tuple[NDArray[np.float64], tuple[float, float] | None]:
    """Return an observable's weighted samples, sorted, and their 5–95 % span (None: no spread).

    Read once per engine: every set of knots of the observable uses them.
    """
    if inner not in eng.span_cache:
        v = eng.basis(inner)[eng.w > 0]
        span = None
        if v.size >= 8 and np.all(np.isfinite(v)) and v.max() > v.min():
            lo, hi = (float(x) for x in np.quantile(v, list(_RANGE)))
            span = (lo, hi) if hi > lo else None
        # Sorted once (the core's radix sort; -0.0 before 0.0, which compare equal):
        # every count of a set of knots is then a bisection (:func:`_knots`).
        eng.span_cache[inner] = (sorted_values(v), span)
    return eng.span_cache[inner]


def _count_near(v: NDArray[np.float64], raw: float, reach: float) -> int:
    """Return ``count_nonzero(abs(v - raw) <= reach)`` of the sorted ``v``, by bisection.

    Values farther than a margin (1e-9 of the scale, far above rounding) inside or
    outside the band are counted by their place; those within it by the test itself,
    so the count is exactly the test's.
    """
    m = 1e-9 * (abs(raw) + reach)
    a0, a1, b0 = (
        int(i) for i in np.searchsorted(v, [raw - reach - m, raw - reach + m, raw + reach - m])
    )
    b1 = int(np.searchsorted(v, raw + reach + m, "right"))
    if a1 >= b0:
        return int(np.count_nonzero(np.abs(v[a0:b1] - raw) <= reach))
    edges = np.concatenate([v[a0:a1], v[b0:b1]])
    return (b0 - a1) + int(np.count_nonzero(np.abs(edges - raw) <= reach))


def _knots(
    v: NDArray[np.float64], span: tuple[float, float], fractions: Sequence[float]
) -> tuple[float, ...]:
    """Knots of the sorted samples ``v`` of an observable (see :func:`knots`)."""
    lo, hi = span
    # Rounded to a hundredth of the span's decade: readable, and the same on reruns.
    step = 10.0 ** (math.floor(math.log10(hi - lo)) - 2)
    out: list[float] = []
    # Half the distance between neighbouring knots: the stretch a knot bends.
    reach = 0.5 * (hi - lo) / (len(fractions) + 1)
    for q in fractions:
        raw = lo + q * (hi - lo)
        near = _count_near(v, raw, reach) / v.size
        if near < _MIN_NEAR / (len(fractions) + 1):
            continue
        k = round(raw / step) * step
        k = float(f"{k:.6g}")
        below = int(np.searchsorted(v, k, "right")) / v.size
        if not _MIN_SIDE <= below <= 1 - _MIN_SIDE:
            continue
        if out and k <= out[-1]:
            continue
        out.append(k)
    return tuple(out)


def slot_name(source: str | None, axis: str | None = None) -> str:
    """Return the readable name of a slot of ``axis``' model.

    ``offset``, ``sensitivity`` (the gain on its own gravity) or ``gain on g_<source>``
    (cross-axis coupling).
    """
    if source is None:
        return "offset"
    return "sensitivity" if source == axis else f"gain on g_{source}"


@functools.lru_cache(maxsize=4096)
def _slot_terms(
    inner: Basis, source: str | None, family: str, knot_values: tuple[float, ...]
) -> tuple[Term, ...]:
    # Terms are immutable values: each step and axis asks for the same ones again.
    kind: Literal["offset", "gain"] = "offset" if source is None else "gain"
    line = (Term(kind, inner, source=source, effect=family),)
    return line + tuple(
        Term(kind, Hinge(k, inner), source=source, effect=family) for k in knot_values
    )


def _key(t: Term) -> tuple[str, Basis, str | None]:
    return t.kind, t.basis, t.source


def generic_variants(
    axis: str, spec: Spec, eng: Engine, skip: Container[str]
) -> list[tuple[str, str, Spec, list[tuple[str, Spec]]]]:
    """Every (slot, observable) not in the model yet: its coarse variant, and finer ones.

    Returns (family, label, spec, finer) with ``finer`` the (label, spec) of the
    eight- and sixteen-piece variants, coarse to fine (only those with more knots
    than the one before). The coarse variants' columns are pushed once per
    observable (a catalogue); a finer variant is cross-validated only when asked for.
    ``skip`` holds observables not to try (e.g. temperature when it does not move).
    """
    have = {_key(t) for t in spec.terms(axis)}
    held = {
        (t.source, t.basis.inner)
        for t in (*spec.generic, *spec.events)
        if isinstance(t.basis, Hinge)
    }
    sources: list[str | None] = [None]
    # The axis' own gain wherever it sees two gravity values (as the base's sensitivity
    # is told); another axis' only on a gravity two records see (Parts.gain_sources).
    sources += [
        b
        for i, b in enumerate(AXES)
        if eng.gravity_values[i] >= 2 and (b == axis or b in eng.gain_sources)
    ]
    out: list[tuple[str, str, Spec, list[tuple[str, Spec]]]] = []
    # Each observable's knot sets, coarse to fine; their catalogues pushed together.
    found: list[tuple[str, Basis, list[tuple[float, ...]]]] = []
    for name, inner in observables(eng):
        if name in skip:
            continue
        if _span(eng, inner)[1] is None:
            continue  # it does not vary
        # The line alone, then the hinges: four pieces, eight, sixteen.
        sets: list[tuple[float, ...]] = [()]
        for fractions in (KNOT_FRACTIONS, FINE_KNOT_FRACTIONS, FINEST_KNOT_FRACTIONS):
            ks = knots(eng, inner, fractions)
            if len(ks) > len(sets[-1]):
                sets.append(ks)
        found.append((name, inner, sets))
    eng.ensure_catalogues(
        [
            (
                name,
                [
                    (t.basis, None if t.kind == "offset" else t.source)
                    for source in sources
                    for t in _slot_terms(inner, source, "", sets[min(1, len(sets) - 1)])
                ],
            )
            for name, inner, sets in found
        ]
    )
    for name, inner, sets in found:
        for source in sources:
            if (source, inner) in held:
                continue
            family = f"{slot_name(source, axis)} vs {name}"
            event = isinstance(inner, Elapsed)
            if event:
                family = EVENT_PREFIX + family
            variants: list[tuple[str, Spec]] = []
            for ks in sets:
                terms = [t for t in _slot_terms(inner, source, family, ks) if _key(t) not in have]
                if not terms:
                    continue  # the line alone, already in the model
                label = LINE if not ks else knot_label(eng, inner, ks)
                if event:
                    variants.append((label, replace(spec, events=(*spec.events, *terms))))
                else:
                    variants.append((label, replace(spec, generic=(*spec.generic, *terms))))
            if variants:
                first = variants[0]
                out.append((family, first[0], first[1], variants[1:]))
    return out
