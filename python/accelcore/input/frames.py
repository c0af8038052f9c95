"""In-memory runs checked cell by cell: what :meth:`accelcore.Session.from_arrays` accepts.

A run's data is a mapping of column name to 1-D array, or a pandas DataFrame.
Every problem is an :class:`accelcore.AccelcoreError` naming the run, the
column and, for a bad cell, the row: a text cell, a column of another length,
a 2-D column, a repeated column name, two roles mapped onto one column.
A ``datetime64`` time column is read as seconds from its first valid stamp
(a ``timedelta64`` one as seconds), never as raw nanoseconds.

May import: the foundation and :mod:`accelcore.input.format`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from accelcore.constants import DEFAULT_COLUMNS
from accelcore.errors import ParameterError, ParseError, SessionFormatError, ShapeError
from accelcore.input.format import check_distinct_columns

__all__ = ["run_table"]

_ROLES = ("time", "temperature", "x", "y", "z")
_FloatArray = NDArray[np.float64]


def column_roles(columns: Mapping[str, str] | None) -> dict[str, str]:
    """Return the log column of each role, defaults filled in; refuse unknown or shared ones.

    Parameters
    ----------
    columns : mapping of str to str, optional
        Column names by role (``time``, ``temperature``, ``x``, ``y``, ``z``).

    Returns
    -------
    dict of str to str

    Raises
    ------
    accelcore.ParameterError
        An unknown role.
    accelcore.SessionFormatError
        Two roles name one column.
    """
    names = {**DEFAULT_COLUMNS, **(columns or {})}
    unknown = set(names) - set(DEFAULT_COLUMNS)
    if unknown:
        err = ParameterError(
            f"columns: unknown role(s) {', '.join(sorted(unknown))}; "
            f"expected some of {', '.join(_ROLES)}"
        )
        err.parameter = "columns"
        raise err
    check_distinct_columns(names, "columns")
    return names


def run_table(
    data: Mapping[str, Any] | Any, label: str, columns: Mapping[str, str] | None
) -> tuple[list[_FloatArray], list[str]]:
    """Check one run's data and return its columns as float64 arrays.

    Parameters
    ----------
    data : mapping or pandas.DataFrame
        Column name to 1-D array.
    label : str
        How messages name the run (``"run 2 (OX-)"``).
    columns : mapping of str to str, optional
        Column names by role.

    Returns
    -------
    arrays : list of ndarray
        Time (s), temperature, x, y, z, then every extra column.
    extra_names : list of str
        Names of the extra columns, in the data's order.

    Raises
    ------
    accelcore.SessionFormatError
        A role's column is missing, a column name repeats, or two roles share a column.
    accelcore.ShapeError
        A column is not 1-D or its length differs from the time column's.
    accelcore.ParseError
        A cell is not a number (``.path`` is the run, ``.line`` the 1-based row,
        ``.column`` the 1-based column).
    """
    names = column_roles(columns)
    keys = list(data.columns) if hasattr(data, "columns") else list(data)
    shown = [str(k) for k in keys]
    seen: set[str] = set()
    for name in shown:
        if name in seen:
            raise SessionFormatError(
                f"{label}: column name {name!r} appears twice; every column needs a distinct name"
            )
        seen.add(name)
    wanted = [names[r] for r in _ROLES]
    missing = [w for w in wanted if w not in seen]
    if missing:
        raise SessionFormatError(
            f"{label}: missing column(s) {', '.join(missing)}; found {', '.join(shown)}"
        )
    by_name = dict(zip(shown, keys, strict=True))
    extra_names = [n for n in shown if n not in wanted]
    order = wanted + extra_names
    arrays = [
        _column(data[by_name[n]], label, n, shown.index(n) + 1, is_time=(n == names["time"]))
        for n in order
    ]
    n = arrays[0].shape[0]
    for name, arr in zip(order, arrays, strict=True):
        if arr.shape[0] != n:
            raise ShapeError(
                f"{label}: column {name!r} has {arr.shape[0]} rows but the time column "
                f"{names['time']!r} has {n}; every column of a run needs one value per row"
            )
    return arrays, extra_names


def _column(raw: Any, label: str, name: str, index: int, *, is_time: bool) -> _FloatArray:
    arr = np.asarray(raw)
    if arr.ndim != 1:
        raise ShapeError(
            f"{label}: column {name!r} must be 1-D (one value per row), got shape {arr.shape}"
        )
    kind = arr.dtype.kind
    if kind in "fiu":
        return arr.astype(np.float64, copy=False)
    if kind == "M" and is_time:
        stamps = arr.astype("datetime64[ns]")
        valid = ~np.isnat(stamps)
        out = np.full(stamps.shape, np.nan)
        if valid.any():
            origin = stamps[int(np.argmax(valid))]
            out[valid] = (stamps[valid] - origin).astype(np.int64).astype(np.float64) * 1e-9
        return out
    if kind == "m" and is_time:
        deltas = arr.astype("timedelta64[ns]")
        out = np.full(deltas.shape, np.nan)
        ok = ~np.isnat(deltas)
        out[ok] = deltas[ok].astype(np.int64).astype(np.float64) * 1e-9
        return out
    if kind in "OUS":
        return _text_column(arr, label, name, index)
    row = 0
    raise _cell_error(label, name, index, row, arr[row] if arr.size else None, arr.dtype)


def _text_column(arr: NDArray[Any], label: str, name: str, index: int) -> _FloatArray:
    """Numbers stored as objects or text; the first cell that is not one is an error."""
    out = np.empty(arr.shape[0])
    for row, cell in enumerate(arr.tolist()):
        if cell is None or (isinstance(cell, float) and math.isnan(cell)):
            out[row] = math.nan
            continue
        if isinstance(cell, (bool, complex)) or not isinstance(cell, (int, float, str, bytes)):
            if not _is_missing(cell):
                raise _cell_error(label, name, index, row, cell, arr.dtype)
            out[row] = math.nan
            continue
        try:
            out[row] = float(cell)
        except ValueError:
            raise _cell_error(label, name, index, row, cell, arr.dtype) from None
    return out


def _is_missing(cell: object) -> bool:
    """Tell pandas' NA and NaT (without importing pandas)."""
    return type(cell).__name__ in ("NAType", "NaTType")


def _cell_error(
    label: str, name: str, index: int, row: int, cell: object, dtype: np.dtype[Any]
) -> ParseError:
    what = "a date/time" if dtype.kind in "Mm" else f"{cell!r}"
    err = ParseError(
        f"{label}, column {name!r} (column {index}), row {row}: {what} is not a number"
        + ("; only the time column may hold date/times" if dtype.kind in "Mm" else "")
    )
    err.path, err.line, err.column = label, row + 1, index
    return err
