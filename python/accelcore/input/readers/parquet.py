"""Parquet files of samples (``pip install accelcore[parquet]``).

pyarrow is optional: it is imported when :func:`read_parquet` is called, so that
``import accelcore`` works without it.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np

from accelcore.errors import ParameterError, SessionFormatError
from accelcore.input.format import check_units, gravity_of
from accelcore.input.headers import check_unique_names
from accelcore.input.readers import common
from accelcore.input.readers.common import (
    _ROLES,
    _check_file,
    _check_rate,
    _check_settle,
    _column_names,
    _FloatArray,
    _missing_columns,
    _parse_error,
    _time_scale,
    _timestamp_seconds,
)
from accelcore.input.readers.segment import _Chunk, _drop_unlabelled, _label_ids, _Layout, _segment
from accelcore.input.session import Session, default_decimation_factor

__all__ = ["read_parquet"]


def _one_orientation(orientation: str | None, column: str | None, who: str) -> str | None:
    if (orientation is None) == (column is None):
        raise ParameterError(f"{who}: give exactly one of orientation= and orientation_column=")
    if orientation is None:
        return None
    try:
        gravity_of(orientation)
    except SessionFormatError as exc:
        raise ParameterError(f"{who}: {exc}") from None
    return orientation.strip().upper()


def read_parquet(
    path: str | os.PathLike[str],
    *,
    units: str,
    rate_hz: float,
    orientation: str | None = None,
    orientation_column: str | None = None,
    columns: Mapping[str, str] | None = None,
    time_unit: str = "s",
    sensor: str | None = None,
    serial: str | None = None,
    decimation_factor: int | None = None,
    min_count: int = 1,
    settle_s: float = 0.0,
) -> Session:
    """Read a Parquet file of samples (needs ``pip install accelcore[parquet]``).

    The file is read in record batches of at most :data:`CHUNK_ROWS` rows
    (``pyarrow.parquet.ParquetFile.iter_batches``) into the decimator.

    Parameters
    ----------
    path : str or path-like
        The Parquet file.
    units : str
        ``V``, ``LSB``, ``g``, ``mg`` or ``m/s2``.
    rate_hz : float
        Nominal sample rate.
    orientation : str, optional
        The orientation of the whole file (one run).
    orientation_column : str, optional
        Or a string column of labels, split into runs as by
        :func:`read_orientation_log`. Give exactly one of the two.
    columns : mapping, optional
        Names of the time, temperature, x, y, z columns, as in
        :func:`read_orientation_log` (``temperature=""``: none logged). Every
        other integer or floating-point column is kept as an extra observable;
        other types are ignored.
    time_unit : str, default "s"
        Unit of a numeric time column (``s``, ``ms``, ``us``, ``ns`` or
        ``sample``); a timestamp column counts seconds from the file's first
        timestamp, whatever ``time_unit`` says.
    sensor, serial, decimation_factor, min_count, settle_s
        As in :func:`read_orientation_log` (``settle_s`` applies to every run).

    Returns
    -------
    Session
        ``path`` is None; each run's ``source`` is ``"FILE#rows=<first>-<last>"``
        (1-based data rows).

    Raises
    ------
    ImportError
        pyarrow is not installed.
    accelcore.ParseError
        Missing columns (the message names the file) or time not increasing.
    accelcore.SessionFormatError
        An unknown or missing orientation label (``file:row N``).
    """
    try:
        import pyarrow as pa
        import pyarrow.compute as pc
        import pyarrow.parquet as pq
    except ImportError as exc:
        raise ImportError("read_parquet needs pyarrow: pip install accelcore[parquet]") from exc
    file = _check_file(path)
    units = check_units(units, "units")
    rate = _check_rate(rate_hz)
    factor = default_decimation_factor(rate) if decimation_factor is None else decimation_factor
    settle = _check_settle(settle_s)
    scale = _time_scale(time_unit, rate)
    label = _one_orientation(orientation, orientation_column, "read_parquet")
    names = _column_names(columns)
    try:
        pf = pq.ParquetFile(file)
    except (pa.ArrowInvalid, OSError) as exc:
        raise _parse_error(file, 1, 1, f"not a Parquet file: {exc}", where=None) from None
    schema = pf.schema_arrow
    header = list(schema.names)
    check_unique_names(file, header, header_line=False)
    wanted = [names[r] for r in _ROLES if names[r]]
    wanted += [orientation_column] if orientation_column else []
    if any(w not in header for w in wanted):
        raise _missing_columns(file, header, wanted, header_line=False)

    def numeric_type(t: Any) -> bool:
        return bool(pa.types.is_integer(t) or pa.types.is_floating(t))

    extras = [f.name for f in schema if f.name not in wanted and numeric_type(f.type)]
    index = {h: i + 1 for i, h in enumerate(header)}
    required = [names[r] for r in ("x", "y", "z")]
    time_type = schema.field(names["time"]).type
    logged = [names["temperature"]] if names["temperature"] else []
    for name in [*logged, *required]:
        if not numeric_type(schema.field(name).type):
            raise _parse_error(
                file,
                1,
                index[name],
                f"column '{name}' is {schema.field(name).type}, not numeric",
                where=None,
            )
    if not (numeric_type(time_type) or pa.types.is_timestamp(time_type)):
        raise _parse_error(
            file,
            1,
            index[names["time"]],
            f"column '{names['time']}' is {time_type}, not numeric",
            where=None,
        )
    layout = _Layout(
        path=file,
        time_column=index[names["time"]],
        extra_names=extras,
        n_channels=3 + len(extras),
        row_word="row",
        fragment="rows=",
        temperature=bool(logged),
        temperature_column=index.get(names["temperature"], 0),
    )

    def as_float(array: Any) -> _FloatArray:
        out: _FloatArray = (
            pc.cast(array, pa.float64()).to_numpy(zero_copy_only=False).astype(np.float64)
        )
        return out

    origin: list[Any] = []

    def time_of(array: Any) -> _FloatArray:
        if pa.types.is_timestamp(array.type):
            stamps = pc.cast(array, pa.timestamp("ns")).to_numpy(zero_copy_only=False)
            return _timestamp_seconds(np.asarray(stamps, dtype="datetime64[ns]"), origin)
        return as_float(array) * scale

    def chunks() -> Iterator[_Chunk]:
        first = 1
        batches = pf.iter_batches(batch_size=common.CHUNK_ROWS, columns=wanted + extras)
        for batch in batches:
            n = batch.num_rows
            pos = np.arange(first, first + n, dtype=np.int64)
            first += n
            labels = None
            if orientation_column is not None:
                raw = batch.column(orientation_column).to_numpy(zero_copy_only=False)
                labels = _label_ids(
                    np.asarray(raw, dtype=object),
                    pos,
                    path=file,
                    column_index=index[orientation_column],
                    column_name=orientation_column,
                    row_word="row",
                )
            time_s = time_of(batch.column(names["time"]))
            chunk = _Chunk(
                time_s=time_s,
                temperature_c=as_float(batch.column(logged[0])) if logged else time_s,
                channels=np.column_stack([as_float(batch.column(c)) for c in required + extras]),
                positions=pos,
                labels=labels,
            )
            if labels is not None:
                chunk = _drop_unlabelled(
                    chunk, path=file, column_index=index[orientation_column], row_word="row"
                )
            yield chunk

    runs = _segment(
        chunks(),
        layout,
        orientation=label,
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
