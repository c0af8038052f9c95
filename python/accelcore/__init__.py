"""accelcore: thermal calibration of MEMS accelerometers, with a Rust streaming core.

The method follows Sawicki & Walendziuk (six static orientations, chamber sweeps,
20 Hz to 2 Hz decimation, temperature binning and line fits of zero-g offset and
sensitivity against temperature), and goes further: one joint least-squares fit
over every sample, and a diagnosis of what the model still gets wrong.
"""

from __future__ import annotations

from accelcore import core, datasheets
from accelcore._accelcore import __version__
from accelcore.diagnosis import Diagnosis, diagnose, residuals
from accelcore.errors import (
    AccelcoreError,
    AccelcoreIOError,
    CalibrationFileError,
    IncompatibleError,
    InsufficientDataError,
    NonFiniteError,
    ParameterError,
    ParseError,
    SessionFormatError,
    ShapeError,
    SingularSystemError,
    TimeOrderError,
)
from accelcore.fitting.calibrate import calibrate
from accelcore.input.session import Run, Session
from accelcore.input.single_log import load_session
from accelcore.result.calibration import Calibration

__all__ = [
    "AccelcoreError",
    "AccelcoreIOError",
    "Calibration",
    "CalibrationFileError",
    "Diagnosis",
    "IncompatibleError",
    "InsufficientDataError",
    "NonFiniteError",
    "ParameterError",
    "ParseError",
    "Run",
    "Session",
    "SessionFormatError",
    "ShapeError",
    "SingularSystemError",
    "TimeOrderError",
    "__version__",
    "calibrate",
    "core",
    "datasheets",
    "diagnose",
    "load_session",
    "residuals",
]
