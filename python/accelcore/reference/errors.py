"""Exceptions of the reference kernels.

They carry the same names as the classes in :mod:`accelcore.errors`
(``ParameterError``, ``ShapeError``, ...) and likewise subclass
:class:`ValueError`, so that tests can compare errors by class name; they are
defined here so that the reference depends on nothing of accelcore.
"""

from __future__ import annotations

__all__ = [
    "IncompatibleError",
    "InsufficientDataError",
    "NonFiniteError",
    "ParameterError",
    "ReferenceKernelError",
    "ShapeError",
    "SingularSystemError",
    "TimeOrderError",
]


class ReferenceKernelError(ValueError):
    """Base class of the errors raised by the reference kernels."""


class ParameterError(ReferenceKernelError):
    """A configuration value or a weight is out of its valid range."""


class ShapeError(ReferenceKernelError):
    """Input arrays do not have the shape the kernel was configured for."""


class TimeOrderError(ReferenceKernelError):
    """Finite time stamps are not strictly increasing.

    Parameters
    ----------
    index : int
        Zero-based index of the offending row in the whole stream.
    previous_s : float
        Previous finite time stamp, s.
    time_s : float
        Offending time stamp, s.
    """

    def __init__(self, index: int, previous_s: float, time_s: float) -> None:
        super().__init__(
            f"time is not strictly increasing at sample {index}: {previous_s} s then {time_s} s"
        )
        self.index = index
        self.previous_s = previous_s
        self.time_s = time_s


class NonFiniteError(ReferenceKernelError):
    """A value that must be finite is NaN or infinite."""


class InsufficientDataError(ReferenceKernelError):
    """There is not enough usable data for the requested result."""


class IncompatibleError(ReferenceKernelError):
    """Two accumulators cannot be merged."""


class SingularSystemError(ReferenceKernelError):
    """The weighted design cannot identify some columns.

    Parameters
    ----------
    columns : list of str
        Names of the columns that are numerically linear combinations of
        earlier columns (or all zero).
    """

    def __init__(self, columns: list[str]) -> None:
        super().__init__(f"rank-deficient design: cannot identify {', '.join(columns)}")
        self.columns = columns
