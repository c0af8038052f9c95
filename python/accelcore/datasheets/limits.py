"""Limits of a datasheet parameter, per axis, and the datasheet error."""

from __future__ import annotations

import math
from dataclasses import dataclass

from accelcore.constants import AXES
from accelcore.errors import AccelcoreError

__all__ = ["AxisLimits", "AxisValues", "DatasheetError", "Limits", "number"]


class DatasheetError(AccelcoreError, ValueError):
    """A datasheet file or mapping breaks the schema, or a part is unknown."""


def number(value: object, where: str) -> float:
    """Return ``value`` as a finite float.

    Parameters
    ----------
    value : object
        The value read from a datasheet.
    where : str
        Where it was read, for the error message.

    Returns
    -------
    float
        The value.

    Raises
    ------
    DatasheetError
        If ``value`` is not a finite number (booleans are not numbers).
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise DatasheetError(f"{where}: expected a number, got {value!r}")
    result = float(value)
    if not math.isfinite(result):
        raise DatasheetError(f"{where}: expected a finite number, got {value!r}")
    return result


@dataclass(frozen=True)
class Limits:
    """Minimum, typical and maximum of one datasheet parameter.

    Any of the three may be ``None`` (not given). A symmetric "±b" limit is
    ``Limits(min=-b, typ=None, max=b)`` (see :meth:`symmetric`).

    Parameters
    ----------
    min, typ, max : float or None
        The limits, in the parameter's unit; ``min <= typ <= max`` where given.
    """

    min: float | None = None
    typ: float | None = None
    max: float | None = None

    def __post_init__(self) -> None:
        for name in ("min", "typ", "max"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, number(value, f"Limits.{name}"))
        given = [v for v in (self.min, self.typ, self.max) if v is not None]
        if given != sorted(given):
            raise DatasheetError(f"limits must satisfy min <= typ <= max, got {self}")

    @classmethod
    def symmetric(cls, bound: float) -> Limits:
        """Return the limits "±bound": ``|value| <= bound``.

        Parameters
        ----------
        bound : float
            Non-negative half-width.

        Returns
        -------
        Limits
            ``Limits(-bound, None, bound)``.
        """
        half = number(bound, "plus_minus")
        if half < 0.0:
            raise DatasheetError(f"plus_minus must be >= 0, got {bound!r}")
        return cls(min=-half, typ=None, max=half)

    @property
    def has_bounds(self) -> bool:
        """Whether a minimum or a maximum is given (so a value can be checked)."""
        return self.min is not None or self.max is not None

    def contains(self, value: float) -> bool | None:
        """Check ``value`` against the minimum and maximum.

        Parameters
        ----------
        value : float
            The value to check, in the parameter's unit.

        Returns
        -------
        bool or None
            ``None`` when neither bound is given, else whether
            ``min <= value <= max`` (a missing bound does not constrain).
        """
        if not self.has_bounds:
            return None
        v = float(value)
        if math.isnan(v):
            return False
        return (self.min is None or v >= self.min) and (self.max is None or v <= self.max)


@dataclass(frozen=True)
class AxisLimits:
    """Per-axis :class:`Limits` of one parameter (``None`` where not given).

    Parameters
    ----------
    x, y, z : Limits or None
        Limits for each axis.
    """

    x: Limits | None = None
    y: Limits | None = None
    z: Limits | None = None

    def __getitem__(self, axis: str) -> Limits | None:
        """Return the limits of ``axis`` ("x", "y" or "z", any case)."""
        return getattr(self, _axis(axis))  # type: ignore[no-any-return]

    @property
    def is_empty(self) -> bool:
        """Whether no axis has limits."""
        return self.x is None and self.y is None and self.z is None


@dataclass(frozen=True)
class AxisValues:
    """One value per axis.

    Parameters
    ----------
    x, y, z : float
        The values.
    """

    x: float
    y: float
    z: float

    def __getitem__(self, axis: str) -> float:
        """Return the value of ``axis`` ("x", "y" or "z", any case)."""
        return float(getattr(self, _axis(axis)))

    def as_tuple(self) -> tuple[float, float, float]:
        """Return ``(x, y, z)``."""
        return (self.x, self.y, self.z)


def _axis(axis: str) -> str:
    name = str(axis).lower()
    if name not in AXES:
        raise ValueError(f"axis must be one of 'x', 'y', 'z', got {axis!r}")
    return name
