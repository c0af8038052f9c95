"""What this session cannot tell apart: pairs of effects, and effects the base model spans.

:func:`confounding` names pairs of effects whose signature columns correlate beyond a
threshold, and says which of the two the model holds (:class:`Confounded`). An effect's
column can also be a *combination* of the base model's columns without matching any one
of them: a chamber that runs on from one run to the next while the part is turned after
each leg (OX+ heats, OX- cools, OY+ heats, ...) makes every run's rate of change follow
its orientation's sign, so a lag's shift ``tau·dT/dt`` is the sum of the gravity columns
times a constant, a share of the sensitivity and cross-axis gains (a pair test saw
|r| = 0.58 against each gravity alone). A held-out test cannot find such an effect: its
share is in the base model's coefficients, on this data and on no other.
:func:`base_spanned` measures each effect's column against the span of the base model's
terms of each axis and says which ones that session cannot show. Both read the same
signatures (:func:`signatures`).

Imports: NumPy, the model's bases and the engine.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from accelcore.model import AXES, Elapsed, Extra, LaggedTemperaturePower, TemperaturePower

from .engine import Engine
from .space import Spec
from .structure import MIN_TEMPERATURE_SPAN_C, temperature_span_c

__all__ = ["Confounded", "SpannedByBase", "base_spanned", "confounding", "signatures"]

FloatArray = NDArray[np.float64]

#: Time constant of the lag whose signature (lagged temperature less the temperature)
#: stands for every lag, s.
_CONFOUND_TAU_S = 120.0

#: How plausible each signature is as the cause of a thermal calibration's residual,
#: most plausible first: the base model's temperature line, then the temperature
#: effects of the part, then geometry, then the history of the run, then anything logged.
_PLAUSIBILITY = (
    "temperature (linear tempco)",
    "offset_curvature",
    "sensitivity_curvature",
    "misalignment",
    "thermal_lag",
    "drift",
    "extra",
)


def _family(signature: str) -> str:
    """Return the selection's family name for a confounding signature."""
    if signature.startswith("misalignment"):
        return "misalignment"
    return signature


def _rank(signature: str) -> int:
    if signature in _PLAUSIBILITY:
        return _PLAUSIBILITY.index(signature)
    head = signature.split(" (")[0].split(":")[0]
    return _PLAUSIBILITY.index(head) if head in _PLAUSIBILITY else len(_PLAUSIBILITY)


@dataclass(frozen=True)
class Confounded:
    """Two effects whose model columns the data cannot tell apart.

    Attributes
    ----------
    first, second : str
        The two signatures, the physically more plausible one first.
    r : float
        Largest |correlation| of their model columns over the axes.
    axes : tuple of str
        Axes where it exceeds the threshold.
    """

    first: str
    second: str
    r: float
    axes: tuple[str, ...]

    def text(self, added: Sequence[str]) -> str:
        """Say, in one line, which of the two the diagnosed model holds (``added``: effects)."""
        held = [
            s for s in (self.first, self.second) if s == _PLAUSIBILITY[0] or _family(s) in added
        ]
        pair = (
            f"{self.first} and {self.second} cannot be told apart on this data "
            f"(|r| = {self.r:.3f} between their model columns, axes {','.join(self.axes)})"
        )
        advice = (
            "log a profile that separates them "
            "(e.g. heat and cool back, or soak at several temperatures)"
        )
        if len(held) == 2:
            return f"{pair}: the model holds both, their coefficients trade off; {advice}"
        if len(held) == 1:
            other = self.second if held[0] == self.first else self.first
            why = "the base model" if held[0] == _PLAUSIBILITY[0] else "it cut the held-out error"
            return f"{pair}: the model attributes it to {held[0]} ({why}), not to {other}; {advice}"
        return (
            f"{pair}: neither was added; were one needed, {self.first} is the physically "
            f"plausible one; {advice}"
        )


def signatures(
    eng: Engine, extras: Sequence[str] = ()
) -> list[tuple[str, FloatArray, Sequence[str]]]:
    """Every effect's signature column and the axes it is a signature on, each column once.

    On the engine's window means (what its fits see): correlations to a few 1e-4, at a
    thirtieth of the rows. A temperature that does not move has no temperature effect.
    """
    win = eng._window_column
    sig: list[tuple[str, FloatArray, Sequence[str]]] = [("drift", win((Elapsed(), None)), AXES)]
    moves = temperature_span_c(eng) >= MIN_TEMPERATURE_SPAN_C
    if moves:
        t1, t2 = win((TemperaturePower(1), None)), win((TemperaturePower(2), None))
        lag = win((LaggedTemperaturePower(_CONFOUND_TAU_S, 1), None)) - t1
        sig += [
            ("temperature (linear tempco)", t1, AXES),
            ("offset_curvature", t2, AXES),
            ("thermal_lag", lag, AXES),
        ]
    for b_i, b in enumerate(AXES):
        if eng.gravity_values[b_i] < 2:
            continue
        g = eng.window_gravity[:, b_i]
        if moves:
            sig.append(("sensitivity_curvature", win((TemperaturePower(2), b)), (b,)))
        sig.append((f"misalignment (gravity on {b})", g, [a for a in AXES if a != b]))
    return sig + [(f"extra:{e}", win((Extra(e), None)), AXES) for e in extras]


def confounding(
    eng: Engine, specs: Mapping[str, Spec], extras: Sequence[str], threshold: float
) -> list[Confounded]:
    """Pairs of effects whose signature columns correlate beyond ``threshold``."""
    found: dict[tuple[str, str], tuple[float, list[str]]] = {}
    w = eng.window_weight
    sig = signatures(eng, extras)
    # Weighted correlations of all of them from one product of the centred columns.
    cols = np.column_stack([col for _, col, _ in sig])
    cols = cols - (w @ cols) / w.sum()
    cols *= np.sqrt(w)[:, None]
    norms = np.sqrt(np.einsum("ij,ij->j", cols, cols))
    live = norms > 0
    scale = np.where(live, norms, 1.0)
    gram = (cols.T @ cols) / scale[:, None] / scale
    for a in AXES:
        own = sorted(
            ((name, j) for j, (name, _, axes) in enumerate(sig) if a in axes and live[j]),
            key=lambda item: _rank(item[0]),
        )
        for i, (first, fi) in enumerate(own):
            for second, sj in own[i + 1 :]:
                r = float(gram[fi, sj])
                if abs(r) > threshold:
                    pair = (first, second)
                    prev = found.get(pair, (0.0, []))
                    found[pair] = (max(prev[0], abs(r)), [*prev[1], a])
    return [Confounded(p1, p2, r, tuple(axes)) for (p1, p2), (r, axes) in found.items()]


@dataclass(frozen=True)
class SpannedByBase:
    """An effect whose model column the base model's terms span on some axes.

    Attributes
    ----------
    effect : str
    r : float
        Largest multiple correlation of its column with the base model's, over the axes.
    axes : tuple of str
        Axes where it exceeds the threshold.
    via_gains : bool
        Whether an offset's signature is spanned only with the gain terms' columns.
    """

    effect: str
    r: float
    axes: tuple[str, ...]
    via_gains: bool

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


#: Signatures of effects the base model's own terms may span, in the order they are said.
_SPANNED = ("thermal_lag", "drift", "offset_curvature", "sensitivity_curvature")


def base_spanned(
    eng: Engine, pairs: Sequence[Confounded], threshold: float, added: Sequence[str] = ()
) -> list[SpannedByBase]:
    """Return the effects whose columns the base model's terms span beyond ``threshold`` (R).

    ``pairs``: the pairs :func:`confounding` found; an effect already named beside one of
    the base model's own signatures on an axis is not named again there, nor one in
    ``added`` (effects the diagnosis added: the data told them apart).
    """
    if not (eng.session.has_temperature and temperature_span_c(eng) >= MIN_TEMPERATURE_SPAN_C):
        return []  # a temperature that does not move (or none) confounds nothing
    sig = sorted(
        (s for s in signatures(eng) if s[0] in _SPANNED), key=lambda s: _SPANNED.index(s[0])
    )
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
        if not keys:
            continue
        span = np.column_stack([eng._window_column(k) for k in keys])
        if not np.all(np.isfinite(span)):
            continue
        offsets = span[:, [k[1] is None for k in keys]]
        for effect, column, axes in sig:
            if axis not in axes or (effect, axis) in named:
                continue
            if not np.all(np.isfinite(column)) or np.ptp(column) == 0:
                continue
            r = _r_on_span(column, span, sw)
            if r > threshold:
                # An offset's signature the offset terms alone do not span: the gains do.
                gains = len(axes) == len(AXES) and _r_on_span(column, offsets, sw) <= threshold
                prev = found.get(effect, (0.0, [], False))
                found[effect] = (max(prev[0], r), [*prev[1], axis], prev[2] or gains)
    return [SpannedByBase(e, r, tuple(a), g) for e, (r, a, g) in found.items() if e not in added]
