"""Defaults that fit the logs: the decimation a rate calls for, what was not logged, gravity.

:func:`default_decimation_factor` gives blocks of about 0.5 s at any rate (the
seed paper's 2 Hz from 20 Hz); :func:`fill_unlogged` stands in for a time or
temperature column that in-memory data does not have; :func:`check_gravity`
takes the local gravity of a session in ``m/s2``.

May import: the foundation only.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from accelcore.constants import DEFAULT_COLUMNS
from accelcore.errors import ParameterError

__all__ = ["BLOCK_S", "MAX_FACTOR", "check_gravity", "default_decimation_factor", "fill_unlogged"]

#: Largest default decimation factor (a rate beyond any logger is an error, not a block).
MAX_FACTOR = 2**31 - 1
#: Length of a decimated block by default, s: the seed paper's 2 Hz from its 20 Hz logs.
BLOCK_S = 0.5


def default_decimation_factor(rate_hz: float) -> int:
    """Return the default decimation factor of a log: blocks of about :data:`BLOCK_S`.

    ``max(1, round(rate_hz * BLOCK_S))``: 10 at 20 Hz (the seed paper's 2 Hz), 50
    at 100 Hz, 1 for a log already at 2 Hz or slower (kept as it is).

    Parameters
    ----------
    rate_hz : float
        Nominal sample rate of the log, Hz.

    Returns
    -------
    int
    """
    if not isinstance(rate_hz, (int, float)) or not math.isfinite(rate_hz) or rate_hz <= 0:
        raise _parameter("rate_hz", f"must be a positive number, got {rate_hz!r}")
    factor = max(1, round(rate_hz * BLOCK_S))
    if factor > MAX_FACTOR:
        raise _parameter(
            "rate_hz",
            f"{rate_hz:g} Hz would average {factor} samples per block (at most {MAX_FACTOR}); "
            "check rate_hz, or pass decimation_factor",
        )
    return factor


def check_gravity(gravity_m_s2: object) -> float:
    """Return the local gravity as a float; refuse (as the caller's error) all but 9.7–9.9 m/s²."""
    if (
        isinstance(gravity_m_s2, bool)
        or not isinstance(gravity_m_s2, (int, float))
        or not 9.7 <= gravity_m_s2 <= 9.9
    ):
        raise _parameter(
            "gravity_m_s2",
            f"must be the local gravity in m/s² (9.7 to 9.9), got {gravity_m_s2!r}",
        )
    return float(gravity_m_s2)


#: Column names that stand in for a time or temperature that was not logged.
_UNLOGGED = {"time": "\x00sample time", "temperature": "\x00no temperature"}


def fill_unlogged(
    data: Mapping[str, ArrayLike] | Any, columns: Mapping[str, str] | None, rate_hz: float
) -> tuple[Mapping[str, Any] | Any, dict[str, str], bool]:
    """Stand in for a time or temperature column the data does not have.

    A role named ``""``, or not named and whose default column is absent, was not
    logged: time becomes ``index / rate_hz``; temperature a constant the
    decimator can average (it skips rows with a NaN), set to NaN in the run.
    Returns the data (a new mapping when something was filled in), the column
    names by role and whether temperature was logged.
    """
    names = dict(columns or {})
    keys = list(data.columns) if hasattr(data, "columns") else list(data)
    shown = {str(k) for k in keys}
    missing = [
        role
        for role in ("time", "temperature")
        if names.get(role) == "" or (role not in names and DEFAULT_COLUMNS[role] not in shown)
    ]
    if not missing:
        return data, names, True
    filled: dict[Any, Any] = {k: data[k] for k in keys}
    first = np.asarray(filled[keys[0]]) if keys else np.zeros(0)
    n = first.shape[0] if first.ndim else 0
    for role in missing:
        names[role] = _UNLOGGED[role]
        filled[_UNLOGGED[role]] = (
            np.arange(n, dtype=np.float64) / rate_hz if role == "time" else np.zeros(n)
        )
    return filled, names, "temperature" not in missing


def _parameter(name: str, text: str) -> ParameterError:
    err = ParameterError(f"{name} {text}")
    err.parameter = name
    return err
