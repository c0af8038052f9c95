"""Effects the base model's own terms already span on a session: said, never chosen apart.

:func:`.search.confounding` names pairs of effects whose columns correlate. An effect's
column can also be a *combination* of the base model's columns without matching any
one of them: a chamber that runs on from one run to the next while the part is turned
after each leg (OX+ heats, OX- cools, OY+ heats, ...) makes every run's rate of change
follow its orientation's sign, so a lag's shift ``tau·dT/dt`` is the sum of the
gravity columns times a constant, a share of the sensitivity and cross-axis gains (a
pair test saw |r| = 0.58 against each gravity alone). A held-out test cannot find such
an effect: its share is in the base model's coefficients, on this data and on no other.
:func:`base_spanned` measures each effect's column against the span of the base
model's terms of each axis and says which ones that session cannot show.

Imports: NumPy, the model's bases and the engine.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from accelcore.model import AXES, Elapsed, LaggedTemperaturePower, TemperaturePower

from .engine import Engine
from .search import _CONFOUND_TAU_S, Confounded
from .structure import MIN_TEMPERATURE_SPAN_C, temperature_span_c

__all__ = ["SpannedByBase", "base_spanned"]

FloatArray = NDArray[np.float64]


class SpannedByBase:
    """An effect whose model column the base model's terms span on some axes."""

    def __init__(self, effect: str, r: float, axes: Sequence[str], via_gains: bool) -> None:
        self.effect, self.r, self.axes = effect, r, tuple(axes)
        #: Whether an offset's signature is spanned only with the gain terms' columns.
        self.via_gains = via_gains

    def text(self) -> str:
        """One line: what the session cannot show, and how a session would."""
        why = (
            ", through the gains: the runs' course follows their orientations"
            if self.via_gains
            else ""
        )
        return (
            f"{self.effect} cannot be told from the base model's own terms on this data "
            f"(axes {','.join(self.axes)}: its model column is a combination of theirs to "
            f"R = {self.r:.3f}{why}): their coefficients hold its share; log runs that "
            "each heat and cool back over the whole range, or soak at several temperatures"
        )


def _r_on_span(x: FloatArray, span: FloatArray, sw: FloatArray) -> float:
    """Multiple correlation of ``x`` with the columns ``span`` (weights ``sw``²)."""
    xs, a = x * sw, span * sw[:, None]
    coef, *_ = np.linalg.lstsq(a, xs, rcond=None)
    rss = float(np.sum((xs - a @ coef) ** 2))
    mean = float(np.sum(xs * sw) / np.sum(sw * sw))
    tss = float(np.sum((xs - mean * sw) ** 2))
    return math.sqrt(max(0.0, 1.0 - rss / tss)) if tss > 0 else 0.0


def base_spanned(
    eng: Engine, pairs: Sequence[Confounded], threshold: float, added: Sequence[str] = ()
) -> list[SpannedByBase]:
    """Return the effects whose columns the base model's terms span beyond ``threshold`` (R).

    ``pairs``: the pairs :func:`.search.confounding` found; an effect already named
    beside one of the base model's own signatures on an axis is not named again there,
    nor one in ``added`` (effects the diagnosis added: the data told them apart).
    """
    if not (eng.session.has_temperature and temperature_span_c(eng) >= MIN_TEMPERATURE_SPAN_C):
        return []  # a temperature that does not move (or none) confounds nothing
    win = eng._window_column
    t1 = win((TemperaturePower(1), None))
    signatures: list[tuple[str, FloatArray, str | None]] = [
        ("thermal_lag", win((LaggedTemperaturePower(_CONFOUND_TAU_S, 1), None)) - t1, None),
        ("drift", win((Elapsed(), None)), None),
        ("offset_curvature", win((TemperaturePower(2), None)), None),
    ]
    signatures += [
        ("sensitivity_curvature", win((TemperaturePower(2), a)), a)
        for i, a in enumerate(AXES)
        if eng.gravity_values[i] >= 2
    ]
    base_names = ("temperature (linear tempco)", "misalignment")
    named = {
        (effect, axis)
        for p in pairs
        for effect, other in ((p.first, p.second), (p.second, p.first))
        if other.startswith(base_names)
        for axis in p.axes
    }
    sw = np.sqrt(eng.window_weight)
    found: dict[str, tuple[float, list[str], bool]] = {}
    for axis in AXES:
        keys = [
            (t.basis, (t.source or "x") if t.kind == "gain" else None)
            for t in eng.base.axes[axis].terms
        ]
        span = np.column_stack([win(k) for k in keys]) if keys else np.zeros((t1.size, 0))
        if span.shape[1] == 0 or not np.all(np.isfinite(span)):
            continue
        offsets = span[:, [k[1] is None for k in keys]]
        for effect, column, own in signatures:
            if (own is not None and own != axis) or (effect, axis) in named:
                continue
            if not np.all(np.isfinite(column)) or np.ptp(column) == 0:
                continue
            r = _r_on_span(column, span, sw)
            if r > threshold:
                # An offset's signature the offset terms alone do not span: the gains do.
                gains = own is None and _r_on_span(column, offsets, sw) <= threshold
                prev = found.get(effect, (0.0, [], False))
                found[effect] = (max(prev[0], r), [*prev[1], axis], prev[2] or gains)
    return [SpannedByBase(e, *v) for e, v in found.items() if e not in added]
