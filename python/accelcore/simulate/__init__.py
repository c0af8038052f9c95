"""Simulated thermal-chamber sessions with a known truth.

:func:`session` writes a session folder in the accelcore session format
(``session.toml`` and one CSV log per run, see ``session-format.md``);
:func:`arrays` returns the same data in memory. Both are deterministic for a
given ``seed``.

The truth model
---------------
A run holds the sensor still in one orientation (``"OZ+"``: +1 g on Z) while the
chamber follows :func:`temperature_profile`: a soak at ``t_start_c``, then a
linear ramp to ``t_end_c`` (or half the remaining time heating and half cooling
back, with ``cool_back=True``). Per axis, at die temperature ``T``::

    offset(T)      = offset_25 + offset_tc_mg_per_c / 1000 * S_25 * (T - 25)
    sensitivity(T) = S_25 * (1 + sensitivity_tc_pct_per_c / 100 * (T - 25))
    output         = offset(T) + sensitivity(T) * g_axis + noise

then the output is quantised by the acquisition: an ADC of ``adc_bits`` over
±``adc_full_scale_v`` for analog parts (the paper's NI 9220 is 16-bit, ±10 V,
so one LSB is 20/65536 V), integer counts clipped to the two's complement word
for digital parts. The default truth (:meth:`SensorTruth.from_paper`) is the
paper's measured Tables 3-6.

The model is a sequence of named :class:`Effect` objects, each with a ``stage``
(``"temperature"``, ``"stimulus"``, ``"response"``, ``"output"``) and an
``apply(state, rng)`` hook that edits the :class:`RunState` of a run in place.
The default chain is ``ProbeNoise`` (temperature), ``LinearTempco`` (response)
and ``WhiteNoise`` (output); effects passed in ``effects=`` run after the
defaults of their stage. Thermal lag (a temperature effect on ``die_temp_c``),
misalignment (a stimulus effect), curvature or drift (response/output effects)
plug in there without changing this package.

Modules, in the order a run is built:

- :mod:`~accelcore.simulate.truth`: :class:`SensorTruth`, the true linear model;
- :mod:`~accelcore.simulate.chain`: :class:`RunState`, the :class:`Effect`
  protocol, :data:`STAGES` and the default effects;
- :mod:`~accelcore.simulate.profile`: :func:`temperature_profile`;
- :mod:`~accelcore.simulate.config`: the arguments checked and their defaults
  resolved (:func:`default_noise_g`, :data:`DEFAULT_ORIENTATIONS`, :data:`EXTRA_COLUMNS`);
- :mod:`~accelcore.simulate.runs`: the runs in memory (:func:`arrays`);
- :mod:`~accelcore.simulate.writer`: the session folder on disk (:func:`session`);
- :mod:`~accelcore.simulate.effects`: further effects that exercise the diagnosis;
- :mod:`~accelcore.simulate.events`: session events (a tilted run, an output
  step, a warm-up), which belong to one session, not to the part.

The simulators use NumPy freely and import only the foundation
(:mod:`accelcore.constants`, :mod:`accelcore.errors`, :mod:`accelcore.datasheets`,
:mod:`accelcore.paper` and the Rust core's kernels); never input, fitting,
result, diagnosis, outputs or apps, so that what they produce is independent
of the code under test.
"""

from __future__ import annotations

from accelcore.constants import ORIENTATIONS
from accelcore.simulate.chain import (
    STAGES,
    Effect,
    LinearTempco,
    ProbeNoise,
    RunState,
    Stage,
    WhiteNoise,
)
from accelcore.simulate.config import DEFAULT_ORIENTATIONS, EXTRA_COLUMNS, default_noise_g
from accelcore.simulate.profile import temperature_profile
from accelcore.simulate.runs import SimulatedArrays, SimulatedRun, arrays
from accelcore.simulate.truth import SensorTruth
from accelcore.simulate.writer import RunFile, SimulatedSession, session

__all__ = [
    "DEFAULT_ORIENTATIONS",
    "EXTRA_COLUMNS",
    "ORIENTATIONS",
    "STAGES",
    "Effect",
    "LinearTempco",
    "ProbeNoise",
    "RunFile",
    "RunState",
    "SensorTruth",
    "SimulatedArrays",
    "SimulatedRun",
    "SimulatedSession",
    "Stage",
    "WhiteNoise",
    "arrays",
    "default_noise_g",
    "session",
    "temperature_profile",
]
