"""Parts of the engine: each record's samples inside the window, cut by leg.

A *part* is the samples of one record (contiguous pieces of one log: folds never
follow file cuts) inside the calibration's temperature window that lie on one leg of
its temperature cycle (:func:`.observables.leg_labels`). The lag of a part's features
runs over its record unbroken, so each record's features are also kept whole, with
where every sample of the parts sits in them.

Imports: NumPy, the model's features and the calibration's cut features and weights.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from accelcore.errors import InsufficientDataError
from accelcore.fitting.calibrate import CutFeatures, block_weights
from accelcore.input.run import Run
from accelcore.input.session import Session
from accelcore.model import AXES, Constant, Features, Term
from accelcore.result.calibration import Calibration, nominal_sensitivity

from .observables import leg_labels, rate_c_per_min

__all__ = ["Parts", "cut_parts", "one_way"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Parts:
    """The parts of a session, in the order cut (record by record, leg by leg).

    Attributes
    ----------
    features, gravity, output, weight : lists, one entry per part
        Its features, orientation's gravity (g), output (less the corrections)
        and sample weights (those of the calibration).
    run, leg : list of int
        Record and leg of each part.
    leg_kinds : dict
        ``"heating"``, ``"cooling"`` or ``"steady"`` of each (record, leg).
    rate_c_per_min : list of ndarray
        Rate of temperature of each part's samples, °C/min.
    wholes : list of (ndarray, ndarray)
        Each record's time since its start (s) and temperature (°C), whole.
    gather : list of ndarray of int64
        Where each part's samples sit in the records' samples end to end.
    leg_s : dict
        Duration of each heating or cooling leg of a record, whole (not cut to the
        window), ``(record, leg)`` -> s.
    """

    features: list[Features]
    gravity: list[FloatArray]
    output: list[FloatArray]
    weight: list[FloatArray]
    run: list[int]
    leg: list[int]
    leg_kinds: dict[tuple[int, int], str]
    rate_c_per_min: list[FloatArray]
    wholes: list[tuple[FloatArray, FloatArray]]
    gather: list[NDArray[np.int64]]
    leg_s: dict[tuple[int, int], float] = field(default_factory=dict)

    def gain_sources(self) -> tuple[str, ...]:
        """Return the axes whose gravity another axis' gain (cross-axis) can be told on.

        Two gravity values (a gain apart from the offset), and not 0 in two records at
        least: a cross-axis gain on a gravity that only one record sees acts in that
        record alone, and is that record's own level and course as much as the part's
        (three orientations, each axis down once: a cross-axis gain that follows
        temperature took one run's day of wander, ``tests/test_gain_sources.py``). An
        axis' own gain is told wherever it sees two gravity values, as the base model's
        sensitivity is. A session of one record has none.
        """
        found = []
        for i, axis in enumerate(AXES):
            values = {float(g[i]) for g in self.gravity}
            records = {r for r, g in zip(self.run, self.gravity, strict=True) if g[i] != 0}
            if len(values) >= 2 and len(records) >= 2:
                found.append(axis)
        return tuple(found)


def cut_parts(
    records: Sequence[Run],
    names: Sequence[str],
    base: Calibration,
    *,
    steady_c_per_min: float,
    corrections: Sequence[FloatArray] | None = None,
) -> Parts:
    """Cut the records into parts (see the module docs).

    ``corrections``: per part (in the order parts are cut), what to take off the
    output first (session events fitted on an earlier pass), session units.
    """
    window = None if not np.all(np.isfinite(base.window_c)) else base.window_c
    out = Parts([], [], [], [], [], [], {}, [], [], [])
    offset = 0
    for i, run in enumerate(records):
        if len(run) == 0:
            continue
        time_s = run.time_s - run.time_s[0]
        whole = Features(run.temperature_c, time_s, run.extras, base.t_ref_c, run=names[i])
        rate = rate_c_per_min(run.time_s, run.temperature_c)
        legs, kinds = leg_labels(
            run.time_s, run.temperature_c, steady_c_per_min=steady_c_per_min, rate=rate
        )
        if window is None:
            inside = np.ones(len(run), dtype=bool)
        else:
            inside = (run.temperature_c >= window[0]) & (run.temperature_c <= window[1])
        # Same weights as the calibration: spikes and clipped blocks left out.
        weight, _ = block_weights(run, robust=bool(base.options.get("robust", True)))
        for leg in range(len(kinds)):
            if kinds[leg] != "steady":
                on_leg = run.time_s[legs == leg]
                out.leg_s[(i, leg)] = float(on_leg[-1] - on_leg[0])
            keep = inside & (legs == leg)
            if np.count_nonzero(keep) < 2:
                continue
            out.features.append(CutFeatures.cut(whole, keep))
            out.gather.append(offset + np.flatnonzero(keep))
            out.gravity.append(run.gravity_g)
            cut = run.output[keep]
            k = len(out.output)
            out.output.append(cut if corrections is None else cut - corrections[k])
            out.weight.append(weight[keep])
            out.run.append(i)
            out.leg.append(leg)
            out.leg_kinds[(i, leg)] = kinds[leg]
            out.rate_c_per_min.append(rate[keep])
        out.wholes.append((time_s, np.asarray(run.temperature_c, dtype=np.float64)))
        offset += len(run)
    if not out.features:
        raise InsufficientDataError("no decimated sample lies in the calibration's window")
    return out


#: Share of the session's travel in temperature that the other way must run to count.
OTHER_WAY_SHARE = 0.25


def one_way(
    leg_kinds: Mapping[tuple[int, int], str],
    rate_c_per_min: FloatArray | None = None,
    elapsed_s: FloatArray | None = None,
) -> str | None:
    """Return the caveat of a session whose temperature runs one way only, else None.

    ``rate_c_per_min``: the samples' rates; ``elapsed_s``: their times in their records.
    Legs shorter than :data:`.observables.MIN_LEG_S` join a neighbour: six 10 min runs
    that heat for 4 min and cool back for 4 had one leg each, "heating", and were said
    to only heat. The way back counts when the samples that run it travel at least
    :data:`OTHER_WAY_SHARE` of the way the others run, whatever the legs' kinds: a
    4 h heating ramp that ends cooling 2 °C in 7 min (a leg of its own) runs one way.

    On a ramp, a die that lags the logged temperature by ``tau`` reads the temperature
    ``tau·dT/dt`` behind: at one rate that is a shift, which the offset and its tempco
    absorb; only where a ramp starts or stops does it show, and no held-out fold of the
    session runs the other way. A session that does sees it whole (heating-only
    calibrations of a part with a 90 s lag and a curvature: 0.6 mg held out, 6-11 mg
    on a cooling session).
    """
    kinds = set(leg_kinds.values()) - {"steady"}
    if not kinds:
        return None
    steps = np.diff(elapsed_s) if elapsed_s is not None else np.zeros(0)
    interval_s = float(np.median(steps[steps > 0])) if np.any(steps > 0) else 0.0
    if rate_c_per_min is not None and interval_s > 0:
        # The way the samples travel most; the other counts from a quarter of it (a
        # 7 min tail that cools 2 °C after a 4 h heating ramp is a leg, not a cycle).
        moved = np.asarray(rate_c_per_min) * (interval_s / 60.0)
        up, down = float(moved[moved > 0].sum()), float(-moved[moved < 0].sum())
        there, back = max(up, down), min(up, down)
        if there <= 0 or back >= OTHER_WAY_SHARE * there:
            return None
        kinds = {"heating" if up >= down else "cooling"}
    elif len(kinds) != 1:
        return None
    way, other = ("rises", "cools") if kinds == {"heating"} else ("falls", "heats")
    return (
        f"the temperature only {way} in this session: a lag of the die behind the logged "
        "temperature shows only where a ramp starts or stops (along a ramp at one rate it "
        "is a shift of the temperature, which the offset's tempco absorbs), and no held-out "
        f"fold here runs the other way (a term in dT/dt is fitted on one sign of it and "
        f"carried to the other unchecked); a session that {other} sees it whole: log a "
        "cycle that heats and cools back"
    )


def axis_responses(
    base: Calibration,
    session: Session,
    output: FloatArray,
    gravity: FloatArray,
    column: Callable[[Term], FloatArray],
) -> tuple[dict[str, float], dict[str, list[tuple[Term, float]]], dict[str, FloatArray]]:
    """Return each axis' scale (units per g), the base's fixed terms, and its response, mg.

    The response is the output less the fixed terms (``column`` gives a term's column
    over the samples) and less the base model's constant and own gain (in every
    model's span), in mg of the scale: the base's sensitivity, else the nominal one.
    """
    scale: dict[str, float] = {}
    fixed: dict[str, list[tuple[Term, float]]] = {}
    y: dict[str, FloatArray] = {}
    for a_i, a in enumerate(AXES):
        m = base.axes[a]
        s0, _ = m.value("gain", "1", a)
        if not s0:
            nominal = nominal_sensitivity(session.units, session.sensor, session.gravity_m_s2)
            s0 = nominal[a_i] if nominal else 1.0
        scale[a] = float(s0)
        held = [
            (term, float(c))
            for term, c, e in zip(m.terms, m.coefficients, m.estimated, strict=True)
            if not e
        ]
        fixed[a] = held
        r = output[:, a_i].copy()
        for term, c in held:
            if c != 0.0:  # a term held at 0 adds nothing (its column may be NaN: no T)
                r -= c * column(term)
        # Centre with the base model's constant and own-gain terms (in every model's span).
        c_off, _ = m.value("offset", "1")
        r -= c_off
        if not any(
            term.kind == "gain" and term.basis == Constant() and term.source == a
            for term, _ in held
        ):
            r -= s0 * gravity[:, a_i]
        y[a] = r * (1000.0 / scale[a])
    return scale, fixed, y
