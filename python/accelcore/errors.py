"""The accelcore exception hierarchy.

Every error accelcore raises on purpose is a subclass of :class:`AccelcoreError`.
Errors about data or arguments are also :class:`ValueError`; errors about files
that cannot be opened are also :class:`OSError`. The Rust core's typed errors are
mapped onto these classes in one place (``rust/accelcore-py/src/errors.rs``) and
carry the values that explain them as attributes, so code never parses messages.
"""

from __future__ import annotations

__all__ = [
    "AccelcoreError",
    "AccelcoreIOError",
    "AccelcoreWarning",
    "CalibrationFileError",
    "DataQualityWarning",
    "IncompatibleError",
    "InsufficientDataError",
    "NonFiniteError",
    "OutputConflictError",
    "ParameterError",
    "ParseError",
    "SessionFormatError",
    "ShapeError",
    "SingularSystemError",
    "TemperatureRangeWarning",
    "TimeOrderError",
]


class AccelcoreError(Exception):
    """Base class of every error raised by accelcore."""


class ParameterError(AccelcoreError, ValueError):
    """A configuration value is out of its valid range (attribute ``parameter``)."""

    parameter: str


class ShapeError(AccelcoreError, ValueError):
    """Input arrays do not have the expected lengths or number of columns."""


class TimeOrderError(AccelcoreError, ValueError):
    """Time stamps go backwards or repeat (attributes ``index``, ``previous_s``, ``time_s``)."""

    index: int
    previous_s: float
    time_s: float


class NonFiniteError(AccelcoreError, ValueError):
    """A value that must be finite is NaN or infinite (attributes ``row``, ``column``)."""

    row: int
    column: int


class InsufficientDataError(AccelcoreError, ValueError):
    """Not enough data for the requested result (including empty input)."""


class IncompatibleError(AccelcoreError, ValueError):
    """Two accumulators or objects of different configuration were combined."""


class SingularSystemError(AccelcoreError, ValueError):
    """A least-squares design cannot identify some terms (attribute ``columns``)."""

    columns: list[str]


class ParseError(AccelcoreError, ValueError):
    """A file could not be parsed (attributes ``path``, ``line``, ``column``, 1-based)."""

    path: str
    line: int
    column: int


class SessionFormatError(AccelcoreError, ValueError):
    """A session folder or its ``session.toml`` does not follow the session format."""


class CalibrationFileError(AccelcoreError, ValueError):
    """A calibration file is corrupted, truncated, of another version or another sensor."""


class OutputConflictError(AccelcoreError, ValueError):
    """An output would overwrite one of the inputs (attributes ``output``, ``input``)."""

    output: str
    input: str


class AccelcoreIOError(AccelcoreError, OSError):
    """A file could not be opened or read (attribute ``path``)."""

    path: str


class AccelcoreWarning(UserWarning):
    """Base class of accelcore's warnings."""


class TemperatureRangeWarning(AccelcoreWarning):
    """A calibration is used outside the temperature range it was fitted on."""


class DataQualityWarning(AccelcoreWarning):
    """Something in the data deserves a look (gaps, rate, clipping, outliers)."""
