"""In-memory runs checked cell by cell: what :meth:`accelcore.Session.from_arrays` accepts.

A run's data is a mapping of column name to 1-D array, a pandas DataFrame, or
any other eager DataFrame narwhals knows (polars, pyarrow, Modin, cuDF...; ``pip
install accelcore[frames]``): :func:`frame_columns` is the one adapter, and
pandas, a base dependency, needs no extra. Every problem is an
:class:`accelcore.AccelcoreError` naming the run, the column and, for a bad
cell, the row: a text cell, a column of another length, a 2-D column, a
repeated column name, two roles mapped onto one column.
A ``datetime64`` time column is read as seconds from its first valid stamp
(a ``timedelta64`` one as seconds), never as raw nanoseconds.

May import: the foundation and :mod:`accelcore.input.format`; narwhals (optional)
inside :func:`frame_columns`.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from accelcore.constants import DEFAULT_COLUMNS
from accelcore.errors import (
    DataQualityWarning,
    InsufficientDataError,
    ParameterError,
    ParseError,
    SessionFormatError,
    ShapeError,
)
from accelcore.input.format import check_distinct_columns

__all__ = ["check_complete_rows", "frame_columns", "run_table"]

#: What installs the DataFrame adapter (narwhals) for frames other than pandas.
FRAMES_EXTRA = "pip install accelcore[frames]"

_ROLES = ("time", "temperature", "x", "y", "z")

#: Share of a run's rows skipped (a value not finite in some column) from which
#: :func:`check_complete_rows` warns: dropouts here and there are counted by the quality
#: checks (:func:`accelcore.input.quality.check_session`); one row in twenty or more is a
#: column missing from the log's rhythm (read at half the rate: one row in two).
SKIPPED_WARN_SHARE = 0.05
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


def frame_columns(data: Mapping[str, Any] | Any, label: str) -> tuple[list[str], list[Any]]:
    """Return the column names of one table and its columns, as the table holds them.

    Parameters
    ----------
    data : mapping, pandas.DataFrame or another eager DataFrame
        A mapping of column name to 1-D array; a pandas DataFrame; or any eager
        DataFrame narwhals supports (polars, pyarrow.Table, ...), read through
        narwhals (``pip install accelcore[frames]``).
    label : str
        How messages name the table (``"run 2 (OX-)"``).

    Returns
    -------
    names : list of str
        The column names, in the table's order (as text).
    columns : list
        Each column, ready for :func:`numpy.asarray` (a NumPy array for a frame
        read through narwhals).

    Raises
    ------
    accelcore.SessionFormatError
        A column name repeats, or the data is a lazy frame or not a table.
    ImportError
        A DataFrame other than pandas without narwhals installed; the message
        names the extra.
    """
    if isinstance(data, Mapping):
        keys = list(data)
        return _distinct([str(k) for k in keys], label), [data[k] for k in keys]
    if isinstance(data, pd.DataFrame):
        keys = list(data.columns)
        names = _distinct([str(k) for k in keys], label)
        return names, [data.iloc[:, i] for i in range(len(keys))]
    try:
        import narwhals.stable.v2 as nw
        from narwhals.exceptions import DuplicateError
    except ImportError:
        raise ImportError(
            f"{label}: a {type(data).__module__.split('.')[0]} {type(data).__name__} is read "
            f"through narwhals: {FRAMES_EXTRA} (or pass a dict of arrays or a pandas DataFrame)"
        ) from None
    try:
        frame = nw.from_native(data, pass_through=True)
    except DuplicateError:
        names = getattr(data, "column_names", None) or getattr(data, "columns", [])
        _distinct([str(c) for c in names], label)
        raise
    if isinstance(frame, nw.LazyFrame):
        raise SessionFormatError(
            f"{label}: a lazy frame holds no data yet; collect it first (.collect())"
        )
    if not isinstance(frame, nw.DataFrame):
        raise SessionFormatError(
            f"{label}: expected a mapping of column name to array or a DataFrame, "
            f"got {type(data).__name__}"
        )
    names = _distinct([str(c) for c in frame.columns], label)
    return names, [frame.get_column(c).to_numpy() for c in frame.columns]


def _distinct(names: list[str], label: str) -> list[str]:
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise SessionFormatError(
                f"{label}: column name {name!r} appears twice; every column needs a distinct name"
            )
        seen.add(name)
    return names


def run_table(
    data: Mapping[str, Any] | Any,
    label: str,
    columns: Mapping[str, str] | None,
    *,
    extras: Sequence[str] | None = None,
) -> tuple[list[_FloatArray], list[str]]:
    """Check one run's data and return its columns as float64 arrays.

    Parameters
    ----------
    data : mapping or DataFrame
        Column name to 1-D array, or a DataFrame (:func:`frame_columns`).
    label : str
        How messages name the run (``"run 2 (OX-)"``).
    columns : mapping of str to str, optional
        Column names by role.
    extras : sequence of str, optional
        The extra columns to read (each must be present); default: every
        column that is not a role's.

    Returns
    -------
    arrays : list of ndarray
        Time (s), temperature, x, y, z, then the extra columns.
    extra_names : list of str
        Names of the extra columns, in the data's order (or in ``extras``' order).

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
    shown, raw = frame_columns(data, label)
    wanted = [names[r] for r in _ROLES]
    if extras is None:
        extra_names = [n for n in shown if n not in wanted]
    else:
        extra_names = [n for n in extras if n not in wanted]
    missing = [w for w in wanted + extra_names if w not in shown]
    if missing:
        raise SessionFormatError(
            f"{label}: missing column(s) {', '.join(missing)}; found {', '.join(shown)}"
        )
    order = wanted + extra_names
    arrays = [
        _column(raw[shown.index(n)], label, n, shown.index(n) + 1, is_time=(n == names["time"]))
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


def check_complete_rows(
    arrays: Sequence[NDArray[np.float64]],
    names: Mapping[str, str],
    extra_names: Sequence[str],
    label: str,
) -> None:
    """Say which columns make rows incomplete; refuse data with no complete row.

    A row with a NaN, infinite or empty value in any column is skipped whole, and the
    accelerometer's readings in it with it: a column logged more slowly than the others
    (NaN between its readings) silently took most of the rows away.

    Parameters
    ----------
    arrays : sequence of ndarray
        Time, temperature, x, y, z, then the extra columns (:func:`run_table`).
    names : mapping of str to str
        Column names by role.
    extra_names : sequence of str
        Names of the extra columns.
    label : str
        How messages name the run.

    Raises
    ------
    accelcore.InsufficientDataError
        No row has every column finite.

    Warns
    -----
    accelcore.DataQualityWarning
        :data:`SKIPPED_WARN_SHARE` of the rows or more are skipped: how many, and the
        columns that are not finite there (fewer are counted by the quality checks,
        :func:`accelcore.input.quality.check_session`).
    """
    columns = [names.get(r) or DEFAULT_COLUMNS[r] for r in _ROLES] + list(extra_names)
    finite = [np.isfinite(a) for a in arrays]
    bad = [int(f.size - np.count_nonzero(f)) for f in finite]
    if not any(bad):
        return
    n = int(arrays[0].size)
    complete = np.logical_and.reduce(finite)
    skipped = n - int(np.count_nonzero(complete))
    which = ", ".join(f"'{c}' ({k})" for c, k in zip(columns, bad, strict=True) if k)
    if skipped == n:
        raise InsufficientDataError(
            f"{label}: no row has every column finite (not finite in {which} of {n} rows); "
            "a column never logged is left out, or given with the columns= of its role"
        )
    if skipped >= SKIPPED_WARN_SHARE * n:
        warnings.warn(
            f"{label}: {skipped} of {n} rows ({100 * skipped / n:.3g} %) skipped whole, "
            f"with their x, y, z: not finite in {which}; a column logged more slowly than "
            "the others leaves NaN between its readings (fill or drop it before)",
            DataQualityWarning,
            stacklevel=4,
        )
