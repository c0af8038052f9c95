"""The model space of the diagnosis: the catalogue's families and the point an axis model is at.

A :class:`Spec` names one axis model of the space (temperature orders of offset and
gain, the lag, cross-axis gains, drift, extra columns); :meth:`Spec.terms` spells it
in model terms (:mod:`accelcore.model`), and :func:`spec_from_terms` reads a base
calibration's terms back into the space.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass, replace

from accelcore.model import (
    Basis,
    Constant,
    Elapsed,
    Extra,
    Hinge,
    LaggedTemperaturePower,
    SquaredGravity,
    TemperaturePower,
    TemperatureRate,
    Term,
)

__all__ = [
    "BETWEEN_RUNS",
    "EVENT_PREFIX",
    "FAMILIES",
    "TWO_WAY_LAG",
    "Spec",
    "is_event",
    "spec_from_terms",
    "with_cross",
    "with_lag_pair",
    "with_tau",
    "without",
]

#: Candidate effect families of the catalogue, in the order they are tried.
FAMILIES = (
    "offset_curvature",
    "sensitivity_curvature",
    "thermal_lag",
    "two_way_lag",
    "misalignment",
    "nonlinearity",
    "drift",
    "extra",
    "smooth",
    "warm_up",
    "run_events",
)

#: Families whose terms are constant in every run (a gain on gravity, which a run holds
#: still): only the contrasts between runs tell them.
BETWEEN_RUNS = ("misalignment", "nonlinearity")

#: Family of a die lag with a time constant of its own while heating and while cooling:
#: tried on an axis whose model holds a one-way die lag (``thermal_lag``), so that it is
#: judged beside the effects chosen with it. (Offered as a variant of ``thermal_lag``,
#: it was chosen at the first step and its two time constants took the place of a drift
#: in elapsed time, 378 s heating / 998 s cooling, where heating came early in each run
#: and cooling late, and of a curvature: 0.61 -> 3.00 mg on a validation session.)
TWO_WAY_LAG = "two_way_lag"

#: Effects whose name starts so are session events: they correct this session's fit
#: and are reported, never carried into a calibration (see :func:`is_event`).
EVENT_PREFIX = "event: "


def is_event(effect: str) -> bool:
    """Tell whether an effect (a term's or a family's) is a session event."""
    return effect.startswith(EVENT_PREFIX)


@dataclass(frozen=True)
class Spec:
    """A point of the model space of one axis.

    Attributes
    ----------
    tau : float or None
        Time constant of the die lag (s): every ``dT^k`` basis becomes ``lag(tau):dT^k``.
    tau_cool : float or None
        With ``tau``, the die lag's time constant while cooling, when it differs from
        the heating one (``tau``): every ``dT^k`` becomes ``lag(tau,tau_cool):dT^k``.
    rate_tau : float or None
        Time constant of the rate term, an offset ``lag(rate_tau):dT^1`` beside ``dT^1``.
    offset_order, gain_order : int
        Highest temperature power of the offset and of the own-axis gain.
    cross : tuple of str
        Axes whose gravity enters as cross-axis gain (misalignment).
    squares : tuple of str
        Axes whose squared gravity enters the offset (``g_b^2``: the output's
        second-order nonlinearity in the force, family ``nonlinearity``).
    drift : bool
        Offset linear in elapsed time.
    gain_drift : bool
        Own-axis sensitivity linear in elapsed time (family ``drift``, variant
        ``sensitivity``).
    extras : tuple of str
        Extra columns entering as linear offsets.
    generic : tuple of Term
        Terms of the generic family (``smooth``, :mod:`accelcore.diagnosis.generic`):
        the line and hinges of an observable in the offset or in a gain, each term
        tagged with its effect (e.g. ``offset vs temperature_c``).
    events : tuple of Term
        Session-event terms (effect ``event: ...``: a warm-up, a step in one run,
        anything in elapsed time): fitted with the rest, never carried into a
        calibration.
    """

    tau: float | None = None
    tau_cool: float | None = None
    rate_tau: float | None = None
    offset_order: int = 1
    gain_order: int = 1
    cross: tuple[str, ...] = ()
    squares: tuple[str, ...] = ()
    drift: bool = False
    gain_drift: bool = False
    extras: tuple[str, ...] = ()
    generic: tuple[Term, ...] = ()
    events: tuple[Term, ...] = ()

    def temp_basis(self, k: int) -> Basis:
        """Return the ``k``-th temperature basis (lagged with ``tau``)."""
        if self.tau is None:
            return TemperaturePower(k)
        return LaggedTemperaturePower(self.tau, k, self.tau_cool)

    def terms(self, axis: str) -> tuple[Term, ...]:
        """Return the model terms of ``axis`` at this point, each tagged with its effect."""
        # Specs and terms are immutable values: the selection asks for the same ones
        # again and again (every candidate, step and figure).
        return _terms(self, axis)


@functools.lru_cache(maxsize=4096)
def _terms(spec: Spec, axis: str) -> tuple[Term, ...]:
    """Return the terms of :meth:`Spec.terms` (kept: a spec is a value)."""
    out = [Term("offset", "1")]
    for k in range(1, spec.offset_order + 1):
        eff = "base" if k == 1 else "offset_curvature"
        out.append(Term("offset", spec.temp_basis(k), effect=eff))
    if spec.rate_tau is not None:
        rate = LaggedTemperaturePower(spec.rate_tau, 1)
        out.append(Term("offset", rate, effect="thermal_lag"))
    out.append(Term("gain", "1", source=axis))
    for k in range(1, spec.gain_order + 1):
        eff = "base" if k == 1 else "sensitivity_curvature"
        out.append(Term("gain", spec.temp_basis(k), source=axis, effect=eff))
    out += [Term("gain", "1", source=b, effect="misalignment") for b in spec.cross]
    out += [Term("offset", SquaredGravity(b), effect="nonlinearity") for b in spec.squares]
    if spec.drift:
        out.append(Term("offset", Elapsed(), effect="drift"))
    if spec.gain_drift:
        out.append(Term("gain", Elapsed(), source=axis, effect="drift"))
    out += [Term("offset", Extra(e), effect="extra") for e in spec.extras]
    out += spec.generic
    out += spec.events
    if spec.tau is not None:
        out = [
            replace(t, effect="thermal_lag")
            if t.basis.lag_s is not None and t.effect == "base"
            else t
            for t in out
        ]
    # One column once: a generic line may be a named family's term (drift, extra).
    seen: set[tuple[str, Basis, str | None]] = set()
    unique = []
    for t in out:
        if (t.kind, t.basis, t.source) not in seen:
            seen.add((t.kind, t.basis, t.source))
            unique.append(t)
    return tuple(unique)


def spec_from_terms(axis: str, terms: Sequence[Term]) -> Spec | None:
    """Return the spec a base calibration's terms correspond to (None: outside the space)."""
    spec = Spec(offset_order=0, gain_order=0)
    has = set()
    plain = {t.basis for t in terms if t.kind == "offset"}
    for t in terms:
        basis = t.basis
        if is_event(t.effect):
            spec = replace(spec, events=(*spec.events, t))
            continue
        if _generic(t, axis):
            spec = replace(spec, generic=(*spec.generic, t))
            continue
        tau = basis.lag_s
        if tau is not None and t.kind == "offset" and TemperaturePower(1) in plain:
            if basis.temperature_order == 1 and spec.rate_tau is None:
                spec = replace(spec, rate_tau=tau)
                continue
            return None
        if tau is not None:
            cool = basis.cool_tau_s if isinstance(basis, LaggedTemperaturePower) else None
            if spec.tau is not None and (spec.tau, spec.tau_cool) != (tau, cool):
                return None
            spec = replace(spec, tau=tau, tau_cool=cool)
            basis = basis.without_lag()
        if isinstance(basis, Constant):
            has.add((t.kind, t.source))
            if t.kind == "gain" and t.source != axis:
                spec = replace(spec, cross=(*spec.cross, str(t.source)))
            continue
        if isinstance(basis, TemperaturePower):
            k = basis.order
            if t.kind == "offset":
                spec = replace(spec, offset_order=max(spec.offset_order, k))
            elif t.source == axis:
                spec = replace(spec, gain_order=max(spec.gain_order, k))
            else:
                return None
        elif isinstance(basis, Elapsed) and t.kind == "offset":
            spec = replace(spec, drift=True)
        elif isinstance(basis, Elapsed) and t.source == axis:
            spec = replace(spec, gain_drift=True)
        elif isinstance(basis, SquaredGravity) and t.kind == "offset":
            spec = replace(spec, squares=(*spec.squares, basis.axis))
        elif isinstance(basis, Extra) and t.kind == "offset":
            spec = replace(spec, extras=(*spec.extras, basis.column))
        else:
            return None
    if ("offset", None) not in has or ("gain", axis) not in has:
        return None
    # Orders 0: a calibration at one temperature (no temperature logged).
    return spec


def _generic(term: Term, axis: str) -> bool:
    """Tell whether only the generic family makes a term.

    A hinge, or an observable's line in a place the named families do not put it.
    """
    b = term.basis
    if isinstance(b, Hinge):
        return True
    if isinstance(b, TemperatureRate):
        return True
    if term.kind == "gain" and isinstance(b, Elapsed) and term.source == axis:
        return term.effect != "drift"  # the drift family's sensitivity variant
    if term.kind == "gain" and isinstance(b, (Elapsed, Extra)):
        return True
    return term.kind == "gain" and term.source != axis and b == TemperaturePower(1)


def with_cross(spec: Spec, sources: Sequence[str]) -> Spec:
    """Return ``spec`` with cross-axis gains from ``sources`` too (the missing ones, last)."""
    return replace(spec, cross=tuple(dict.fromkeys((*spec.cross, *sources))))


def with_tau(spec: Spec, variant: str, tau: float) -> Spec:
    """Return ``spec`` with a die lag (``variant="die"``) or a rate term (else), time ``tau``.

    A die lag's cooling time constant (:attr:`Spec.tau_cool`) is kept.
    """
    return replace(spec, tau=tau) if variant == "die" else replace(spec, rate_tau=tau)


def with_lag_pair(spec: Spec, tau_heat: float, tau_cool: float) -> Spec:
    """Return ``spec`` with a die lag of ``tau_heat`` s while heating, ``tau_cool`` s while cooling.

    Equal to the 6 digits a basis keeps, the plain lag (:attr:`Spec.tau_cool` None).
    """
    same = f"{tau_cool:.6g}" == f"{tau_heat:.6g}"
    return replace(spec, tau=tau_heat, tau_cool=None if same else tau_cool)


def without(spec: Spec, family: str) -> Spec:
    """Return ``spec`` without what ``family`` added (as the selection names families).

    A temperature curvature goes back to the line, a lag to none; misalignment, the
    nonlinearity, the drift, an extra column (``extra:NAME``) and a generic or event
    family (its terms carry its name) are taken out whole.
    """
    if family == "offset_curvature":
        return replace(spec, offset_order=min(spec.offset_order, 1))
    if family == "sensitivity_curvature":
        return replace(spec, gain_order=min(spec.gain_order, 1))
    if family == "thermal_lag":
        return replace(spec, tau=None, tau_cool=None, rate_tau=None)
    if family == TWO_WAY_LAG:
        return replace(spec, tau_cool=None)
    if family == "misalignment":
        return replace(spec, cross=())
    if family == "nonlinearity":
        return replace(spec, squares=())
    if family == "drift":
        return replace(spec, drift=False, gain_drift=False)
    if family.startswith("extra:"):
        name = family.split(":", 1)[1]
        return replace(spec, extras=tuple(e for e in spec.extras if e != name))
    return replace(
        spec,
        generic=tuple(t for t in spec.generic if t.effect != family),
        events=tuple(t for t in spec.events if t.effect != family),
    )
