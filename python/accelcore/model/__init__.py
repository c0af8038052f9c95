"""The calibration model: per axis, a list of named terms, linear in their coefficients.

The output of axis ``a`` (in session units) is modelled as::

    v_a = Σ offset terms  c · B(features)  +  Σ gain terms  c · B(features) · g_b

where ``g_b`` is the gravity (in g) on axis ``b`` that the run's orientation
implies and ``B`` a *basis*: a named function of the sample's observables. The
basis names are a small grammar, so a model can be saved, loaded and extended
by later effects without new code paths. Each name is parsed once, where it
enters (a :class:`Term`, a calibration file), into a typed :class:`Basis` value;
code then asks the value what it is instead of splitting strings:

``1`` (:class:`Constant`)
    constant;
``dT^k`` (:class:`TemperaturePower`)
    ``(T - t_ref_c)^k``, °C^k (curvature for k >= 2);
``lag(tau):dT^k`` (:class:`LaggedTemperaturePower`)
    the same with the temperature passed through a first-order lag of
    ``tau`` seconds (the die trailing the logged probe); ``lag(h,c):dT^k``,
    ``h`` seconds while the logged temperature is above the lagged one
    (heating), ``c`` while it is below (cooling);
``dTdt`` (:class:`TemperatureRate`)
    rate of change of temperature, °C/min (causal, smoothed over 60 s);
``elapsed_h`` (:class:`Elapsed`)
    time since the start of the run, hours (drift);
``extra:NAME`` (:class:`Extra`)
    an extra logged column, minus its reference value stored in the model;
``decay(tau)`` (:class:`Decay`)
    ``exp(-t / tau)`` of the time since the start of the run, s (a warm-up after
    power-on; a session event, never carried into a calibration);
``step(RUN@t0)`` (:class:`RunStep`)
    1 in run ``RUN`` from ``t0`` seconds into it on, else 0 (the part knocked
    mid-run; a session event); ``until(RUN@t0)``, 1 before ``t0`` instead (an
    offset that went away mid-run);
``rate(RUN)`` (:class:`RunRate`)
    ``dTdt`` in run ``RUN``, else 0 (that run's logged temperature trailing the part's,
    a probe that lagged in one run; a session event);
``g_b^2`` (:class:`SquaredGravity`)
    the square of the specific force on axis ``b``, g² (an offset in ``g_b^2`` is the
    second-order nonlinearity of the output in the force, IEEE Std 1293's ``K2``
    when ``b`` is the axis itself); read from the run's orientation when fitting, and
    solved for with the force when compensating;
``hinge(k):B`` (:class:`Hinge`)
    ``max(B - k, 0)`` of one of the observables above (``dT^1``, ``dTdt``,
    ``elapsed_h``, ``extra:NAME``) at a knot ``k`` in that basis' units: with the
    observable's own line, a piecewise-linear (linear spline) function of it, the
    diagnosis' generic term over anything logged.

The base model of the seed paper is, on each axis, offset ``1``, ``dT^1`` and
gain (own axis) ``1``, ``dT^1``: zero-g offset and sensitivity, each a line in
temperature.
"""

from accelcore.constants import AXES, DTDT_SMOOTHING_S

from .bases import (
    Basis,
    Constant,
    Decay,
    Elapsed,
    Extra,
    Features,
    Hinge,
    LaggedTemperaturePower,
    RunRate,
    RunStep,
    SquaredGravity,
    TemperaturePower,
    TemperatureRate,
)
from .terms import Term, base_terms, design_columns, evaluate_basis, full_gain_terms

__all__ = [
    "AXES",
    "DTDT_SMOOTHING_S",
    "Basis",
    "Constant",
    "Decay",
    "Elapsed",
    "Extra",
    "Features",
    "Hinge",
    "LaggedTemperaturePower",
    "RunRate",
    "RunStep",
    "SquaredGravity",
    "TemperaturePower",
    "TemperatureRate",
    "Term",
    "base_terms",
    "design_columns",
    "evaluate_basis",
    "full_gain_terms",
]
