"""One delimited log whose orientation column says how the sensor was held."""

from __future__ import annotations

import contextlib
import os
import re
from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from accelcore.constants import DELIMITERS
from accelcore.errors import ParameterError
from accelcore.input.format import check_units
from accelcore.input.headers import check_unique_names, first_line_fields
from accelcore.input.readers import common
from accelcore.input.readers.common import (
    _ROLES,
    GuardedLog,
    _check_file,
    _check_rate,
    _check_settle,
    _column_names,
    _FloatArray,
    _missing_columns,
    _parse_error,
    _time_scale,
)
from accelcore.input.readers.segment import _Chunk, _drop_unlabelled, _label_ids, _Layout, _segment
from accelcore.input.session import Session, default_decimation_factor

__all__ = ["read_orientation_log"]


def _numeric(
    frame: pd.DataFrame, name: str, positions: NDArray[np.int64], path: str, column: int
) -> _FloatArray:
    col = frame[name]
    if pd.api.types.is_numeric_dtype(col.dtype) and not pd.api.types.is_bool_dtype(col.dtype):
        return col.to_numpy(dtype=np.float64, na_value=np.nan)
    text = col.astype(object)
    values = pd.to_numeric(text.where(text.notna(), np.nan), errors="coerce")
    stripped = text.map(lambda v: v.strip() if isinstance(v, str) else v)
    bad = values.isna() & stripped.notna() & (stripped != "")
    if bad.any():
        i = int(np.argmax(bad.to_numpy()))
        raise _parse_error(
            path,
            int(positions[i]),
            column,
            f"column '{name}': '{stripped.iloc[i]}' is not a number",
        )
    return values.to_numpy(dtype=np.float64, na_value=np.nan)


def read_orientation_log(
    path: str | os.PathLike[str],
    *,
    units: str,
    rate_hz: float,
    orientation_column: str = "orientation",
    columns: Mapping[str, str] | None = None,
    delimiter: str = ",",
    time_unit: str = "s",
    sensor: str | None = None,
    serial: str | None = None,
    decimation_factor: int | None = None,
    min_count: int = 1,
    settle_s: float = 0.0,
) -> Session:
    """Read one delimited log whose orientation column says how the sensor was held.

    The positioner rotates the sensor during the log: every contiguous stretch of
    rows with one label (``OX+`` ... ``OZ-``, case-insensitive) becomes a run; a
    label that comes back later starts another run (a repeat sweep). The file is
    streamed in chunks of :data:`CHUNK_ROWS` rows into the decimator.

    Parameters
    ----------
    path : str or path-like
        The log: one header row, then one row per sample.
    units : str
        ``V``, ``LSB``, ``g``, ``mg`` or ``m/s2``.
    rate_hz : float
        Nominal sample rate of the log.
    orientation_column : str, default "orientation"
        Name of the label column.
    columns : mapping, optional
        Names of the time, temperature, x, y, z columns (keys ``time``,
        ``temperature``, ``x``, ``y``, ``z``); defaults ``time_s, temp_c, x, y, z``.
        Every other column must be numeric and is kept as an extra observable.
        ``temperature=""``: no temperature was logged (the runs' temperatures are
        NaN and the session calibrates at one temperature).
    delimiter : str, default ","
        A comma (default), a tab or a semicolon.
    time_unit : str, default "s"
        ``s``, ``ms``, ``us``, ``ns``, or ``sample`` (a sample index: seconds
        are ``index / rate_hz``).
    sensor, serial : str, optional
        Datasheet name and serial, carried into the session.
    decimation_factor : int, optional
        Raw samples per block; default
        :func:`~accelcore.input.session.default_decimation_factor` of ``rate_hz``
        (blocks of about 0.5 s).
    min_count : int, default 1
        Blocks with fewer valid raw samples are dropped.
    settle_s : float, default 0
        Rows within this many seconds of the start of every run (the positioner
        still moving or ringing) are dropped; the block grid starts at the first
        row kept. A run with nothing left is dropped with a
        :class:`~accelcore.errors.DataQualityWarning`.

    Returns
    -------
    Session
        ``path`` is None; each run's ``source`` is ``"FILE#L<first>-<last>"`` (its
        1-based lines) and its times are those of the log.

    Raises
    ------
    accelcore.SessionFormatError
        An unknown or missing orientation label (the message gives
        ``file:line:column``), or no run with valid data.
    accelcore.ParseError
        Missing columns, a non-numeric cell, a wrong field count or time not
        increasing within a run; ``.path``, ``.line``, ``.column`` say where.
    accelcore.AccelcoreIOError
        The file does not exist.
    """
    file = _check_file(path)
    units = check_units(units, "units")
    rate = _check_rate(rate_hz)
    factor = default_decimation_factor(rate) if decimation_factor is None else decimation_factor
    settle = _check_settle(settle_s)
    scale = _time_scale(time_unit, rate)
    if delimiter not in DELIMITERS:
        raise ParameterError(f"delimiter must be ',', '\\t' or ';', got {delimiter!r}")
    names = _column_names(columns)
    options: dict[str, Any] = {
        "sep": DELIMITERS[delimiter],
        "skipinitialspace": True,
        "encoding": "utf-8-sig",
        "engine": "c",
    }
    # Read through GuardedLog: a line over the limit (a sparse file, no line
    # ends) is refused after a megabyte rather than buffered whole.
    stack = contextlib.ExitStack()
    try:
        with GuardedLog(file) as head:
            header = [str(c).strip() for c in pd.read_csv(head, nrows=0, **options).columns]
        reader = pd.read_csv(
            stack.enter_context(GuardedLog(file)),
            chunksize=common.CHUNK_ROWS,
            dtype={orientation_column: object},
            skip_blank_lines=False,
            **options,
        )
    except pd.errors.EmptyDataError:
        stack.close()
        raise _parse_error(file, 1, 1, "empty file: no header") from None
    except UnicodeDecodeError as exc:
        stack.close()
        raise _parse_error(file, 1, 1, f"not UTF-8 text: {exc}") from None
    except BaseException:
        stack.close()
        raise
    with stack, reader:
        check_unique_names(file, first_line_fields(file, DELIMITERS[delimiter]), header_line=True)
        wanted = [names[r] for r in _ROLES if names[r]] + [orientation_column]
        if any(w not in header for w in wanted):
            raise _missing_columns(file, header, wanted, header_line=True)
        required = [names[r] for r in ("x", "y", "z")]
        extras = [h for h in header if h not in wanted]
        index = {h: i + 1 for i, h in enumerate(header)}
        layout = _Layout(
            path=file,
            time_column=index[names["time"]],
            extra_names=extras,
            n_channels=3 + len(extras),
            row_word="line",
            fragment="L",
            temperature=bool(names["temperature"]),
            temperature_column=index.get(names["temperature"], 0),
        )
        logged = [names["temperature"]] if layout.temperature else []

        with open(file, "rb") as fh:
            size = fh.seek(0, os.SEEK_END)
            if size:
                fh.seek(-1, os.SEEK_END)
            unterminated = bool(size) and fh.read(1) != b"\n"

        def chunks() -> Iterator[_Chunk]:
            first_line = 2  # header is line 1
            frames: Iterator[pd.DataFrame] = iter(reader)
            try:
                ahead = next(frames, None)
                while ahead is not None:
                    frame, ahead = ahead, next(frames, None)
                    frame.columns = header
                    # Like the Rust reader: a last line without newline that lacks
                    # cells was cut off mid-write; drop it and count it.
                    truncated = bool(
                        ahead is None
                        and unterminated
                        and len(frame)
                        and frame.iloc[-1].isna().any()
                    )
                    if truncated:
                        frame = frame.iloc[:-1]
                    n = len(frame)
                    pos = np.arange(first_line, first_line + n, dtype=np.int64)
                    first_line += n

                    values = {
                        c: _numeric(frame, c, pos, file, index[c])
                        for c in [names["time"], *logged, *required, *extras]
                    }
                    time_s = values[names["time"]] * scale
                    chunk = _Chunk(
                        time_s=time_s,
                        temperature_c=values[logged[0]] if logged else time_s,
                        channels=np.column_stack([values[c] for c in required + extras]),
                        positions=pos,
                        labels=_label_ids(
                            frame[orientation_column].to_numpy(dtype=object),
                            pos,
                            path=file,
                            column_index=index[orientation_column],
                            column_name=orientation_column,
                            row_word="line",
                        ),
                    )
                    chunk = _drop_unlabelled(
                        chunk, path=file, column_index=index[orientation_column], row_word="line"
                    )
                    chunk.truncated = truncated
                    yield chunk
            except pd.errors.ParserError as exc:
                found = re.search(r"line (\d+)", str(exc))
                line = int(found.group(1)) if found else 0
                raise _parse_error(file, line, 1, f"malformed row: {exc}") from None
            except UnicodeDecodeError as exc:
                raise _parse_error(file, 0, 1, f"not UTF-8 text: {exc}") from None

        runs = _segment(
            chunks(),
            layout,
            orientation=None,
            factor=factor,
            rate_hz=rate,
            min_count=min_count,
            settle_s=settle,
        )
    return Session(
        runs=tuple(runs),
        units=units,
        rate_hz=rate,
        sensor=sensor,
        serial=serial,
        path=None,
        decimation_factor=factor,
    )
