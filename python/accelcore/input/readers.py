"""Readers for logs that are not session folders, mapped onto the same :class:`Session`.

- :func:`read_orientation_log`: one delimited log with an orientation column, the
  positioner rotating during the run; every contiguous stretch of one label is a run.
- :func:`read_parquet`: a Parquet file (``pip install accelcore[parquet]``), one
  orientation for the whole file or an orientation column.
- :func:`read_tdms`: an NI TDMS file as LabVIEW writes it (``pip install
  accelcore[tdms]``), one run per group.

Every reader streams the file in chunks of at most ``CHUNK_ROWS`` rows into the
Rust :class:`accelcore.core.Decimator` (block means, ``decimation_factor`` raw
samples per block, the block grid starting at each run's first kept sample),
exactly as :func:`accelcore.load_session` does; only the decimated blocks are
kept. See ``docs/readers.md`` for the layouts each reader expects.
"""

from __future__ import annotations

import itertools
import math
import os
import re
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from accelcore import core
from accelcore._accelcore import RunTally
from accelcore.constants import DEFAULT_COLUMNS, DELIMITERS, ORIENTATIONS, TIME_UNITS
from accelcore.errors import (
    AccelcoreIOError,
    DataQualityWarning,
    InsufficientDataError,
    ParameterError,
    ParseError,
    SessionFormatError,
    TimeOrderError,
)
from accelcore.input.format import check_units, gravity_of
from accelcore.input.session import Run, RunStats, Session, _make_run

__all__ = ["CHUNK_ROWS", "read_orientation_log", "read_parquet", "read_tdms"]

#: Rows read per chunk: bounds the memory of every reader, whatever the file size.
CHUNK_ROWS = 65_536

_ROLES = ("time", "temperature", "x", "y", "z")
_LABELS = tuple(ORIENTATIONS)  # index -> label; -1 means "no label"
_FloatArray = NDArray[np.float64]


def _parse_error(
    path: str, line: int, column: int, reason: str, where: str | None = ""
) -> ParseError:
    """Build a ParseError laid out as the Rust reader's (``path:line:column: reason``).

    ``where`` replaces ``line:column`` in the message; None leaves it out.
    """
    location = "" if where is None else f":{where or f'{line}:{column}'}"
    err = ParseError(f"{path}{location}: {reason}")
    err.path, err.line, err.column = path, line, column
    return err


def _io_error(path: str, reason: str) -> AccelcoreIOError:
    err = AccelcoreIOError(f"{path}: {reason}")
    err.path = path
    return err


def _check_file(path: str | os.PathLike[str]) -> str:
    p = Path(path)
    if not p.exists():
        raise _io_error(str(p), "no such file")
    if not p.is_file():
        raise _io_error(str(p), "not a file")
    return str(p)


def _column_names(columns: Mapping[str, str] | None) -> dict[str, str]:
    names = {**DEFAULT_COLUMNS, **(columns or {})}
    unknown = set(names) - set(DEFAULT_COLUMNS)
    if unknown:
        raise ParameterError(
            f"columns: unknown role(s) {', '.join(sorted(unknown))}; "
            f"expected some of {', '.join(_ROLES)}"
        )
    return names


def _check_rate(rate_hz: float, where: str = "rate_hz") -> float:
    if not isinstance(rate_hz, (int, float)) or not math.isfinite(rate_hz) or rate_hz <= 0:
        raise ParameterError(f"{where} must be a positive number, got {rate_hz!r}")
    return float(rate_hz)


def _check_settle(settle_s: float) -> float:
    if not isinstance(settle_s, (int, float)) or not math.isfinite(settle_s) or settle_s < 0:
        raise ParameterError(f"settle_s must be a finite number >= 0, got {settle_s!r}")
    return float(settle_s)


def _time_scale(time_unit: str) -> float:
    if time_unit not in TIME_UNITS:
        raise ParameterError(f"time_unit must be one of {', '.join(TIME_UNITS)}, got {time_unit!r}")
    return TIME_UNITS[time_unit]


def _missing_columns(
    path: str, found: Sequence[str], wanted: Sequence[str], *, header_line: bool
) -> ParseError:
    """Missing columns, located on the header line of a text log (else just the file)."""
    missing = [w for w in wanted if w not in found]
    return _parse_error(
        path,
        1,
        1,
        f"missing column(s) {', '.join(repr(m) for m in missing)}; "
        f"found {', '.join(repr(str(f)) for f in found)}",
        where="" if header_line else None,
    )


# --------------------------------------------------------------------------- one run


class _RunBuilder:
    """Decimates one run pushed in chunks, with the statistics the Rust reader keeps.

    ``where`` turns a row's position into the text of an error location.
    """

    def __init__(
        self,
        label: str,
        *,
        source: str,
        path: str,
        time_column: int,
        n_channels: int,
        extra_names: Sequence[str],
        factor: int,
        rate_hz: float,
        min_count: int,
        settle_s: float,
        row_word: str,
    ) -> None:
        self.label = label
        self.source = source
        self.path = path
        self.time_column = time_column
        self.extra_names = list(extra_names)
        self.settle_s = settle_s
        self.row_word = row_word
        self.decimator = core.Decimator(
            factor=factor, rate_hz=rate_hz, n_channels=n_channels, min_count=min_count
        )
        self.tally = RunTally(n_channels=n_channels, rate_hz=rate_hz)
        self.start_s: float | None = None  # first finite time of the run (settling origin)
        self.settled = False
        self.first_pos: int | None = None
        self.last_pos: int | None = None
        self.n_settling = 0
        self.n_truncated = 0

    def push(
        self,
        time_s: _FloatArray,
        temperature_c: _FloatArray,
        channels: _FloatArray,
        positions: NDArray[np.int64],
    ) -> None:
        if time_s.size == 0:
            return
        if self.first_pos is None:
            self.first_pos = int(positions[0])
        self.last_pos = int(positions[-1])
        if self.settle_s > 0 and not self.settled:
            finite = np.isfinite(time_s)
            if self.start_s is None and finite.any():
                self.start_s = float(time_s[int(np.argmax(finite))])
            settled = (
                time_s >= self.start_s + self.settle_s
                if self.start_s is not None
                else np.zeros(time_s.shape, dtype=bool)
            )
            if not settled.any():
                self.n_settling += time_s.size
                return
            i = int(np.argmax(settled))
            self.settled = True
            self.n_settling += i
            time_s, temperature_c = time_s[i:], temperature_c[i:]
            channels, positions = channels[i:], positions[i:]
        try:
            self.decimator.push(time_s, temperature_c, channels)
        except TimeOrderError as exc:
            pos = int(positions[exc.index])
            raise _parse_error(
                self.path,
                pos,
                self.time_column,
                f"time is not strictly increasing: {exc.previous_s!r} s then {exc.time_s!r} s",
                where=self._where(pos),
            ) from None
        self.tally.push(time_s, temperature_c, channels)

    def _where(self, pos: int) -> str:
        return f"{self.row_word} {pos}" if self.row_word != "line" else f"{pos}:{self.time_column}"

    def span(self) -> str:
        """Describe the run's rows, e.g. ``lines 2-7201``."""
        return f"{self.row_word}s {self.first_pos}-{self.last_pos}"

    def finish(self) -> Run | None:
        """Return the decimated run, or None (with a warning) when no block has valid data."""
        try:
            blocks = self.decimator.finish()
        except InsufficientDataError:
            why = (
                f"all within settle_s={self.settle_s:g} s of its start"
                if self.tally.n_rows == 0 and self.n_settling
                else "no row with finite values in every column"
            )
            warnings.warn(
                f"{self.path}: run {self.label} ({self.span()}) dropped: {why}",
                DataQualityWarning,
                stacklevel=4,
            )
            return None
        stats = RunStats.from_raw(self.tally.finish(), n_truncated_rows=self.n_truncated)
        return _make_run(
            self.label, gravity_of(self.label), blocks, self.extra_names, self.source, stats
        )


@dataclass
class _Chunk:
    """Rows of a log, ready for the segmenter.

    ``labels`` holds an index into ``_LABELS`` per row (-1: no label), or None when
    one orientation covers the whole file; ``positions`` the 1-based line or row
    number of each row, for error messages and run spans; ``truncated`` says that
    a last line cut off mid-write was dropped after these rows.
    """

    time_s: _FloatArray
    temperature_c: _FloatArray
    channels: _FloatArray
    positions: NDArray[np.int64]
    labels: NDArray[np.int64] | None
    truncated: bool = False


@dataclass
class _Layout:
    path: str
    time_column: int
    extra_names: list[str]
    n_channels: int
    row_word: str
    fragment: str  # how a run's span is written into Run.source ("L" or "rows=")


def _label_ids(
    raw: NDArray[Any],
    positions: NDArray[np.int64],
    *,
    path: str,
    column_index: int,
    column_name: str,
    row_word: str,
) -> NDArray[np.int64]:
    """Orientation index of each raw label (``-1`` for a missing one); unknown labels raise."""
    codes, uniques = pd.factorize(pd.Series(raw, dtype=object), use_na_sentinel=True)
    table = np.full(len(uniques) + 1, -1, dtype=np.int64)  # last slot: the NA sentinel
    for k, value in enumerate(uniques):
        key = str(value).strip().upper()
        if key in ORIENTATIONS:
            table[k] = _LABELS.index(key)
        elif key:
            pos = int(positions[int(np.argmax(codes == k))])
            where = f"{pos}:{column_index}" if row_word == "line" else f"{row_word} {pos}"
            raise SessionFormatError(
                f"{path}:{where}: unknown orientation {str(value)!r} in column "
                f"{column_name!r} (column {column_index}); expected one of "
                f"{', '.join(ORIENTATIONS)}"
            )
    return table[np.asarray(codes, dtype=np.int64)]


def _drop_unlabelled(chunk: _Chunk, *, path: str, column_index: int, row_word: str) -> _Chunk:
    """Drop blank rows (no label, no value); a row with values but no label raises."""
    assert chunk.labels is not None
    missing = chunk.labels < 0
    if not missing.any():
        return chunk
    values = np.column_stack([chunk.time_s, chunk.temperature_c, chunk.channels])
    has_data = missing & np.isfinite(values).any(axis=1)
    if has_data.any():
        pos = int(chunk.positions[int(np.argmax(has_data))])
        where = f"{pos}:{column_index}" if row_word == "line" else f"{row_word} {pos}"
        raise SessionFormatError(
            f"{path}:{where}: no orientation label (column {column_index}) on a row with data"
        )
    keep = ~missing
    return _Chunk(
        chunk.time_s[keep],
        chunk.temperature_c[keep],
        chunk.channels[keep],
        chunk.positions[keep],
        chunk.labels[keep],
    )


def _segment(
    chunks: Iterator[_Chunk],
    layout: _Layout,
    *,
    orientation: str | None,
    factor: int,
    rate_hz: float,
    min_count: int,
    settle_s: float,
) -> list[Run]:
    """Split a stream of chunks into runs at every change of label and decimate each."""
    runs: list[Run] = []
    current: _RunBuilder | None = None

    def start(label: str) -> _RunBuilder:
        return _RunBuilder(
            label,
            source=layout.path,
            path=layout.path,
            time_column=layout.time_column,
            n_channels=layout.n_channels,
            extra_names=layout.extra_names,
            factor=factor,
            rate_hz=rate_hz,
            min_count=min_count,
            settle_s=settle_s,
            row_word=layout.row_word,
        )

    def close(builder: _RunBuilder | None) -> None:
        if builder is None or builder.first_pos is None:
            return
        builder.source = f"{layout.path}#{layout.fragment}{builder.first_pos}-{builder.last_pos}"
        run = builder.finish()
        if run is not None:
            runs.append(run)

    for chunk in chunks:
        n = chunk.time_s.shape[0]
        if chunk.truncated and current is not None and n == 0:
            current.n_truncated = 1
        if n == 0:
            continue
        if chunk.labels is None:
            assert orientation is not None
            if current is None:
                current = start(orientation)
            current.push(chunk.time_s, chunk.temperature_c, chunk.channels, chunk.positions)
            continue
        ids = chunk.labels
        cuts = np.flatnonzero(ids[1:] != ids[:-1]) + 1
        bounds = [0, *cuts.tolist(), n]
        for a, b in itertools.pairwise(bounds):
            label = _LABELS[int(ids[a])]
            if current is None or current.label != label or a > 0:
                close(current)
                current = start(label)
            current.push(
                chunk.time_s[a:b],
                chunk.temperature_c[a:b],
                chunk.channels[a:b],
                chunk.positions[a:b],
            )
        if chunk.truncated and current is not None:
            current.n_truncated = 1
    close(current)
    if not runs:
        raise SessionFormatError(f"{layout.path}: no run with valid data")
    return runs


# --------------------------------------------------------------------------- orientation log


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
    decimation_factor: int = 10,
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
        ``V``, ``LSB``, ``g`` or ``m/s2``.
    rate_hz : float
        Nominal sample rate of the log.
    orientation_column : str, default "orientation"
        Name of the label column.
    columns : mapping, optional
        Names of the time, temperature, x, y, z columns (keys ``time``,
        ``temperature``, ``x``, ``y``, ``z``); defaults ``time_s, temp_c, x, y, z``.
        Every other column must be numeric and is kept as an extra observable.
    delimiter : str, default ","
        A comma (default), a tab or a semicolon.
    time_unit : str, default "s"
        ``s``, ``ms``, ``us`` or ``ns``.
    sensor, serial : str, optional
        Datasheet name and serial, carried into the session.
    decimation_factor : int, default 10
        Raw samples per block.
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
    settle = _check_settle(settle_s)
    scale = _time_scale(time_unit)
    if delimiter not in DELIMITERS:
        raise ParameterError(f"delimiter must be ',', '\\t' or ';', got {delimiter!r}")
    names = _column_names(columns)
    options: dict[str, Any] = {
        "sep": DELIMITERS[delimiter],
        "skipinitialspace": True,
        "encoding": "utf-8-sig",
        "engine": "c",
    }
    try:
        header = [str(c).strip() for c in pd.read_csv(file, nrows=0, **options).columns]
        reader = pd.read_csv(
            file,
            chunksize=CHUNK_ROWS,
            dtype={orientation_column: object},
            skip_blank_lines=False,
            **options,
        )
    except pd.errors.EmptyDataError:
        raise _parse_error(file, 1, 1, "empty file: no header") from None
    except UnicodeDecodeError as exc:
        raise _parse_error(file, 1, 1, f"not UTF-8 text: {exc}") from None
    with reader:
        wanted = [names[r] for r in _ROLES] + [orientation_column]
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
        )

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
                        for c in [names["time"], names["temperature"], *required, *extras]
                    }
                    chunk = _Chunk(
                        time_s=values[names["time"]] * scale,
                        temperature_c=values[names["temperature"]],
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
            factor=decimation_factor,
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
        decimation_factor=decimation_factor,
    )


# --------------------------------------------------------------------------- Parquet


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
    decimation_factor: int = 10,
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
        ``V``, ``LSB``, ``g`` or ``m/s2``.
    rate_hz : float
        Nominal sample rate.
    orientation : str, optional
        The orientation of the whole file (one run).
    orientation_column : str, optional
        Or a string column of labels, split into runs as by
        :func:`read_orientation_log`. Give exactly one of the two.
    columns : mapping, optional
        Names of the time, temperature, x, y, z columns, as in
        :func:`read_orientation_log`. Every other integer or floating-point
        column is kept as an extra observable; other types are ignored.
    time_unit : str, default "s"
        Unit of a numeric time column; a timestamp column counts seconds from
        the file's first timestamp, whatever ``time_unit`` says.
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
    settle = _check_settle(settle_s)
    scale = _time_scale(time_unit)
    label = _one_orientation(orientation, orientation_column, "read_parquet")
    names = _column_names(columns)
    try:
        pf = pq.ParquetFile(file)
    except (pa.ArrowInvalid, OSError) as exc:
        raise _parse_error(file, 1, 1, f"not a Parquet file: {exc}", where=None) from None
    schema = pf.schema_arrow
    header = list(schema.names)
    wanted = [names[r] for r in _ROLES] + ([orientation_column] if orientation_column else [])
    if any(w not in header for w in wanted):
        raise _missing_columns(file, header, wanted, header_line=False)

    def numeric_type(t: Any) -> bool:
        return bool(pa.types.is_integer(t) or pa.types.is_floating(t))

    extras = [f.name for f in schema if f.name not in wanted and numeric_type(f.type)]
    index = {h: i + 1 for i, h in enumerate(header)}
    required = [names[r] for r in ("x", "y", "z")]
    time_type = schema.field(names["time"]).type
    for name in [names["temperature"], *required]:
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
        batches = pf.iter_batches(batch_size=CHUNK_ROWS, columns=wanted + extras)
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
            chunk = _Chunk(
                time_s=time_of(batch.column(names["time"])),
                temperature_c=as_float(batch.column(names["temperature"])),
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
        factor=decimation_factor,
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
        decimation_factor=decimation_factor,
    )


# --------------------------------------------------------------------------- TDMS


def _nominal_rate(rate_hz: float) -> float:
    """Round a rate computed from an interval to 10 significant digits (0.05 s gives 20 Hz).

    A rate a hair below the nominal one would shift every block boundary that
    falls exactly on a sample.
    """
    return float(f"{rate_hz:.10g}")


def _tdms_prop(obj: Any, name: str) -> Any:
    props = getattr(obj, "properties", {})
    return props.get(name)


def _timestamp_seconds(data: NDArray[Any], origin: list[Any]) -> _FloatArray:
    """Seconds of datetime64 values from the first one seen (kept in ``origin``); NaT: NaN."""
    stamps = data.astype("datetime64[ns]")
    valid = ~np.isnat(stamps)
    if not origin and valid.any():
        origin.append(stamps[int(np.argmax(valid))])
    seconds = np.full(stamps.shape, np.nan)
    if origin:
        seconds[valid] = (stamps[valid] - origin[0]).astype(np.int64).astype(np.float64) * 1e-9
    return seconds


def _tdms_time(data: NDArray[Any], origin: list[Any], scale: float) -> _FloatArray:
    """Seconds of a time channel chunk; timestamps count from the group's first one."""
    if np.issubdtype(data.dtype, np.datetime64):
        return _timestamp_seconds(data, origin)
    return np.asarray(data, dtype=np.float64) * scale


def read_tdms(
    path: str | os.PathLike[str],
    *,
    units: str,
    rate_hz: float | None = None,
    group: str | Sequence[str] | None = None,
    channel_map: Mapping[str, str] | None = None,
    orientation: str | Mapping[str, str] | None = None,
    time_unit: str = "s",
    sensor: str | None = None,
    serial: str | None = None,
    decimation_factor: int = 10,
    min_count: int = 1,
    settle_s: float = 0.0,
) -> Session:
    """Read an NI TDMS file as LabVIEW writes it (needs ``pip install accelcore[tdms]``).

    Expected layout: one group per run, holding a channel per quantity (names
    from ``channel_map``, defaults ``time_s, temp_c, x, y, z``). The time channel
    is optional: without it, time is computed from the x channel's waveform
    properties, ``wf_start_offset + i / rate`` s with ``rate = 1 / wf_increment``
    rounded to 10 significant digits (``wf_start_time``,
    the absolute start, is not needed). Every other numeric channel of the group
    with the same length is kept as an extra observable. The group's
    ``orientation`` property names its orientation unless ``orientation`` is given.
    Channels are read in slices of :data:`CHUNK_ROWS` samples.

    Parameters
    ----------
    path : str or path-like
        The ``.tdms`` file (its ``.tdms_index``, if any, is used by npTDMS).
    units : str
        ``V``, ``LSB``, ``g`` or ``m/s2``.
    rate_hz : float, optional
        Nominal sample rate; default ``1 / wf_increment`` of the x channel, else
        1 / the median interval of the time channel's first 1000 intervals, both
        rounded to 10 significant digits.
    group : str or sequence of str, optional
        The group(s) to read, in this order; default every group holding the
        x, y, z and temperature channels, in file order.
    channel_map : mapping, optional
        Channel names of ``time``, ``temperature``, ``x``, ``y``, ``z``.
    orientation : str or mapping of group name to str, optional
        Orientation of every group (a one-run file), or of each group; default
        each group's ``orientation`` property.
    time_unit : str, default "s"
        Unit of a numeric time channel (a timestamp channel counts seconds from
        the group's first sample).
    sensor, serial : str, optional
        Default: the file's (root) ``sensor`` and ``serial`` properties, if any.
    decimation_factor, min_count, settle_s
        As in :func:`read_orientation_log`.

    Returns
    -------
    Session
        ``path`` is None; each run's ``source`` is ``"FILE#GROUP"``.

    Raises
    ------
    ImportError
        npTDMS is not installed.
    accelcore.SessionFormatError
        No usable group, a group without orientation, or no way to get the rate.
    accelcore.ParseError
        Missing channels (the message names the file and group) or time not increasing.
    """
    try:
        from nptdms import TdmsFile
    except ImportError as exc:
        raise ImportError("read_tdms needs npTDMS: pip install accelcore[tdms]") from exc
    file = _check_file(path)
    units = check_units(units, "units")
    rate_arg = None if rate_hz is None else _check_rate(rate_hz)
    settle = _check_settle(settle_s)
    scale = _time_scale(time_unit)
    names = _column_names(channel_map)
    needed = [names[r] for r in ("temperature", "x", "y", "z")]
    runs: list[Run] = []
    try:
        tdms = TdmsFile.open(file)
    except Exception as exc:  # npTDMS raises plain ValueError/KeyError on bad files
        raise _parse_error(file, 1, 1, f"not a TDMS file: {exc}", where=None) from None
    with tdms:
        all_groups = tdms.groups()
        by_name = {g.name: g for g in all_groups}
        if group is None:
            chosen = [
                g for g in all_groups if all(c in [ch.name for ch in g.channels()] for c in needed)
            ]
            if not chosen:
                listing = "; ".join(
                    f"{g.name!r}: {', '.join(repr(c.name) for c in g.channels())}"
                    for g in all_groups
                )
                raise SessionFormatError(
                    f"{file}: no group holds the channels {', '.join(map(repr, needed))} "
                    f"(groups: {listing or 'none'}); pass channel_map= or group="
                )
        else:
            wanted_groups = [group] if isinstance(group, str) else list(group)
            unknown = [g for g in wanted_groups if g not in by_name]
            if unknown:
                raise SessionFormatError(
                    f"{file}: no group {', '.join(map(repr, unknown))}; "
                    f"found {', '.join(repr(g) for g in by_name)}"
                )
            chosen = [by_name[g] for g in wanted_groups]
        if isinstance(orientation, str) and len(chosen) > 1:
            raise ParameterError(
                f"{file}: orientation={orientation!r} given for {len(chosen)} groups; "
                "pass a mapping of group name to orientation"
            )
        root = tdms.properties
        sensor = (
            sensor if sensor is not None else (str(root["sensor"]) if "sensor" in root else None)
        )
        serial = (
            serial if serial is not None else (str(root["serial"]) if "serial" in root else None)
        )
        rate_used: float | None = rate_arg
        for g in chosen:
            run, rate_g = _tdms_group(
                file,
                g,
                names=names,
                orientation=orientation,
                rate_hz=rate_arg,
                scale=scale,
                factor=decimation_factor,
                min_count=min_count,
                settle_s=settle,
            )
            if rate_used is None:
                rate_used = rate_g
            if run is not None:
                runs.append(run)
    if not runs or rate_used is None:
        raise SessionFormatError(f"{file}: no run with valid data")
    return Session(
        runs=tuple(runs),
        units=units,
        rate_hz=rate_used,
        sensor=sensor,
        serial=serial,
        path=None,
        decimation_factor=decimation_factor,
    )


def _tdms_group(
    file: str,
    g: Any,
    *,
    names: Mapping[str, str],
    orientation: str | Mapping[str, str] | None,
    rate_hz: float | None,
    scale: float,
    factor: int,
    min_count: int,
    settle_s: float,
) -> tuple[Run | None, float]:
    """Decimate one TDMS group into a run; also return the rate used."""
    where = f"{file}#{g.name}"
    channels = {c.name: c for c in g.channels()}
    needed = [names[r] for r in ("temperature", "x", "y", "z")]
    if any(c not in channels for c in needed):
        raise _missing_columns(where, list(channels), needed, header_line=False)
    if orientation is None:
        label = _tdms_prop(g, "orientation")
        if label is None:
            raise SessionFormatError(
                f"{where}: the group has no 'orientation' property; pass orientation="
            )
    elif isinstance(orientation, str):
        label = orientation
    else:
        if g.name not in orientation:
            raise ParameterError(f"{where}: orientation= has no entry for group {g.name!r}")
        label = orientation[g.name]
    try:
        gravity_of(str(label))
        label = str(label).strip().upper()
    except SessionFormatError as exc:
        raise SessionFormatError(f"{where}: {exc}") from None
    x = channels[names["x"]]
    time_ch = channels.get(names["time"])
    increment = _tdms_prop(x, "wf_increment")
    if time_ch is None and not increment:
        raise SessionFormatError(
            f"{where}: no time channel {names['time']!r} and no wf_increment property "
            f"on channel {names['x']!r}: cannot tell when the samples were taken"
        )
    wf_rate = _nominal_rate(1.0 / float(increment)) if increment else None
    start = float(_tdms_prop(x, "wf_start_offset") or 0.0)
    lengths = {c: len(channels[c]) for c in needed}
    if time_ch is not None:
        lengths[time_ch.name] = len(time_ch)
    n = min(lengths.values())
    if len(set(lengths.values())) > 1:
        warnings.warn(
            f"{where}: channels of different lengths ({lengths}); reading the first {n} samples",
            DataQualityWarning,
            stacklevel=3,
        )
    extras = [
        c.name
        for c in g.channels()
        if c.name not in needed
        and c.name != names["time"]
        and len(c) == n
        and np.issubdtype(np.dtype(c.dtype), np.number)
    ]
    origin: list[Any] = []
    rate = rate_hz or wf_rate
    if rate is None:
        assert time_ch is not None
        head = _tdms_time(time_ch.read_data(0, min(n, 1001)), origin, scale)
        steps = np.diff(head[np.isfinite(head)])
        if steps.size == 0 or not np.median(steps) > 0:
            raise SessionFormatError(
                f"{where}: cannot infer the sample rate from the time channel; pass rate_hz="
            )
        rate = _nominal_rate(1.0 / float(np.median(steps)))
    builder = _RunBuilder(
        label,
        source=where,
        path=where,
        time_column=1,
        n_channels=3 + len(extras),
        extra_names=extras,
        factor=factor,
        rate_hz=rate,
        min_count=min_count,
        settle_s=settle_s,
        row_word="sample",
    )
    order = [names["x"], names["y"], names["z"], *extras]
    for a in range(0, n, CHUNK_ROWS):
        m = min(CHUNK_ROWS, n - a)
        if time_ch is not None:
            t = _tdms_time(time_ch.read_data(a, m), origin, scale)
        else:
            assert wf_rate is not None
            t = start + np.arange(a, a + m, dtype=np.float64) / wf_rate
        temp = np.asarray(channels[names["temperature"]].read_data(a, m), dtype=np.float64)
        data = np.column_stack(
            [np.asarray(channels[c].read_data(a, m), dtype=np.float64) for c in order]
        )
        builder.push(t, temp, data, np.arange(a + 1, a + m + 1, dtype=np.int64))
    if n == 0:
        warnings.warn(f"{where}: empty group, skipped", DataQualityWarning, stacklevel=3)
        return None, rate
    return builder.finish(), rate
