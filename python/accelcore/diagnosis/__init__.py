"""Diagnosis room: find what the calibration model misses, add it, report before and after.

:func:`residuals` gives, per decimated sample, the error in mg against the gravity the
run's orientation implies, beside the observables (temperature, its rate, elapsed
time, branch, extra columns). :func:`diagnose` searches a catalogue of candidate
effects, each a named set of model terms (:mod:`accelcore.model`), and adds them
greedily by *held-out* error only:

``offset_curvature``
    offset terms ``dT^2 … dT^k`` (nested, ``k`` up to ``max_order``);
``sensitivity_curvature``
    own-axis gain terms ``dT^2 … dT^k`` (needs two gravity values on the axis);
``thermal_lag``
    every ``dT^k`` basis of the axis replaced by ``lag(tau):dT^k``, or an offset
    ``lag(tau):dT^1`` beside ``dT^1`` (a rate term); ``tau`` estimated by a grid and
    golden-section search on the held-out error;
``two_way_lag``
    on an axis that holds a lag of one time constant, where the session heats and
    cools: a die lag ``lag(h,c):dT^k`` of one time constant while heating and another
    while cooling (:mod:`~accelcore.diagnosis.lags`);
``misalignment``
    gain terms on the other axes' gravity (cross-axis sensitivity; with six
    orientations, the full 3x3 sensitivity matrix);
``nonlinearity``
    an offset ``g_a^2`` (the output's second-order nonlinearity in the force, K2;
    needs the axis at -1, 0 and +1 g);
``drift``
    offset, or own-axis sensitivity, linear in the time since the run's start
    (``elapsed_h``);
``extra:NAME``
    offset linear in an extra logged column.

Every fit, held-out or not, is the core's QR least squares
(:class:`accelcore.core.LeastSquares`); errors are per axis, linearised: the output
residual divided by the axis' sensitivity, in mg. After the last step a generic check
bins the residual by every observable and reports the structure no added term explains.

Modules, along the data flow:

- :mod:`~accelcore.diagnosis.observables`: :func:`rate_c_per_min`, :func:`leg_labels`,
  :func:`residuals`;
- :mod:`~accelcore.diagnosis.space`: the catalogue (:data:`FAMILIES`) and the model
  space of one axis;
- :mod:`~accelcore.diagnosis.stats`: chi-square and t tails, the paired test;
- :mod:`~accelcore.diagnosis.engine`: parts, blocks and folds; held-out fits;
- :mod:`~accelcore.diagnosis.search`: variants, the lag time-constant search;
- :mod:`~accelcore.diagnosis.lags`: the two-way lag's search and variant;
- :mod:`~accelcore.diagnosis.rates` and :mod:`~accelcore.diagnosis.events`: session
  events (a run's temperature out of step; steps, run levels);
- :mod:`~accelcore.diagnosis.confounds`: what the session cannot tell apart (pairs of
  effects, effects the base model's own terms span);
- :mod:`~accelcore.diagnosis.structure`: the binned check of the final residual;
- :mod:`~accelcore.diagnosis.parameters`: final fits and added parameters;
- :mod:`~accelcore.diagnosis.result`: :class:`Diagnosis`, :class:`Step`, :class:`Structure`;
- :mod:`~accelcore.diagnosis.tables`: the report's tables and text blocks (added effects,
  held-out error per axis, unexplained structure);
- :mod:`~accelcore.diagnosis.scope`: the options checked, the families a quality finding rules out;
- :mod:`~accelcore.diagnosis.selection`: the greedy selection and :func:`diagnose`.

May import: foundation, input, model, result, fitting. Never outputs or apps (plots of
a diagnosis live in :mod:`accelcore.outputs.diagnosis_plot`).
"""

from __future__ import annotations

from .observables import leg_labels, rate_c_per_min, residuals
from .result import Diagnosis, Step, Structure
from .selection import diagnose
from .space import FAMILIES

__all__ = [
    "FAMILIES",
    "Diagnosis",
    "Step",
    "Structure",
    "diagnose",
    "leg_labels",
    "rate_c_per_min",
    "residuals",
]
