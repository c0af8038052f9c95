"""How much temperature a fit's samples span: the whole session's, and each term's carriers.

A temperature term fitted over too little temperature extrapolates a slope from a
few degrees over the whole range, or takes a difference between runs for temperature;
:mod:`accelcore.fitting.calibrate` holds such terms at 0 (see its notes).

May import: the foundation, :mod:`accelcore.model`, :mod:`accelcore.input.session`
and :mod:`accelcore.fitting.stacking`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from accelcore.constants import AXES
from accelcore.fitting.stacking import Stacked
from accelcore.input.session import Session
from accelcore.model import Term

__all__ = ["MIN_SPAN_FRACTION", "session_temperature_span_c", "thin_temperature_terms"]


#: A temperature term is identified only by samples spread over at least this
#: fraction of the fitted temperature span; fitted on less, it extrapolates a
#: slope from a few degrees over the whole range.
MIN_SPAN_FRACTION = 0.25


def thin_temperature_terms(
    axis: str,
    terms: Sequence[Term],
    data: Stacked,
    parts: Sequence[int] | range,
) -> list[tuple[int, float, float]]:
    """Temperature terms whose carrying samples span too little temperature: (index, spans).

    A gain term is carried by the stretches whose gravity on its source axis is not 0
    (a stretch holds one orientation); the span of a union of stretches is read from
    each stretch's lowest and highest weighted temperature.
    """
    lows: dict[int, float] = {}
    highs: dict[int, float] = {}
    for i in parts:
        temps = data.features[i].temperature_c[data.weight[i] > 0]
        if temps.size:
            lows[i], highs[i] = float(temps.min()), float(temps.max())
    if not lows:
        return []

    def span(stretches: list[int]) -> float:
        return max(highs[i] for i in stretches) - min(lows[i] for i in stretches)

    span_all = span(list(lows))
    thin = []
    for j, t in enumerate(terms):
        if not t.basis.temperature_order:
            continue
        carrying = list(lows)
        if t.kind == "gain":
            source = AXES.index(t.source or axis)
            carrying = [i for i in carrying if data.gravity[i][source] != 0]
        if not carrying:
            continue  # the term's column is zero: dropped as such by the fit
        s = span(carrying)
        if s < MIN_SPAN_FRACTION * span_all:
            thin.append((j, s, span_all))
    return thin


def session_temperature_span_c(session: Session) -> float:
    """Return the span of the runs' temperatures (block means), 5th to 95th percentile, °C.

    0 when no finite temperature was logged.
    """
    temps = np.concatenate([np.asarray(r.temperature_c, dtype=np.float64) for r in session.runs])
    temps = temps[np.isfinite(temps)]
    if temps.size == 0:
        return 0.0
    lo, hi = np.quantile(temps, [0.05, 0.95])
    return float(hi - lo)
