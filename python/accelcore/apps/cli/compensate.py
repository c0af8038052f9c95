"""``accelcore compensate``: a raw log of any size into acceleration in g, chunk by chunk.

The raw log is a delimited text file (read in chunks), a Parquet file (``pip
install accelcore[parquet]``, read in record batches) or a flight log (PX4
``.ulg``, ArduPilot ``.bin``: one IMU instance, every sample). The output holds
the time and temperature columns, then ``x_g``, ``y_g``, ``z_g``: a CSV file, or
a Parquet file when its name ends in ``.parquet`` (``pip install
accelcore[parquet]``); it is written as it goes and replaced atomically at the end.

Part of the applications room.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import sys
import warnings
from collections.abc import Generator, Iterator, Mapping, Sequence
from pathlib import Path
from typing import IO, Any, TextIO

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from accelcore.apps.cli.documents import require_folder
from accelcore.apps.cli.inputs import CliDataError, UsageError, guard, need, open_session
from accelcore.apps.progress import Progress
from accelcore.constants import DEFAULT_COLUMNS as _DEFAULT_COLUMNS
from accelcore.constants import DELIMITERS as _DELIMITERS
from accelcore.constants import TIME_UNITS as _TIME_UNITS
from accelcore.errors import (
    AccelcoreError,
    NonFiniteError,
    ParseError,
    TemperatureRangeWarning,
    TimeOrderError,
)
from accelcore.files import atomic_open, check_input_file
from accelcore.input.consistency import RATE_SLACK
from accelcore.input.format import SessionFormat
from accelcore.input.headers import check_unique_names, first_line_fields
from accelcore.input.readers.common import GuardedLog
from accelcore.input.readers.opener import is_flight_log
from accelcore.result.calibration import Calibration

__all__ = ["COLUMN_KEYS", "cmd_compensate"]

#: The roles of a raw log's columns, as ``--column KEY=NAME`` names them.
COLUMN_KEYS = ("time", "temperature", "x", "y", "z")

#: Column names of a flight log's samples, as the output names them.
_FLIGHT_COLUMNS = {
    "time": "time_s",
    "temperature": "temperature_c",
    "x": "x",
    "y": "y",
    "z": "z",
}


def _session_format(folder: str) -> dict[str, Any]:
    fmt = SessionFormat.read(folder, check_files=False)
    return {
        "delimiter": fmt.delimiter,
        "time_unit": fmt.time_unit,
        "columns": dict(fmt.columns),
        "time_scale": fmt.time_scale_to_s,
    }


def _parse_column_options(items: Sequence[str]) -> dict[str, str]:
    columns: dict[str, str] = {}
    for item in items:
        key, sep, name = item.partition("=")
        if not sep or key not in COLUMN_KEYS or not name:
            raise UsageError(
                f"--column expects KEY=NAME with KEY one of {', '.join(COLUMN_KEYS)}, got {item!r}"
            )
        columns[key] = name
    return columns


def _layout(args: argparse.Namespace) -> tuple[dict[str, str], str, float]:
    """Column names by role, delimiter and seconds per time unit, from --session and options.

    A session's ``time_unit = "sample"`` (a sample index) gives ``1 / rate_hz``; its
    ``temperature = ""`` (not logged) leaves the temperature role out.
    """
    fmt: dict[str, Any] = {"delimiter": ",", "time_unit": "s", "columns": {}}
    if args.session:
        fmt = _session_format(args.session)
    if args.delimiter is not None:
        fmt["delimiter"] = args.delimiter
    if args.time_unit is not None:
        fmt["time_unit"] = args.time_unit
        fmt.pop("time_scale", None)
    fmt["columns"].update(_parse_column_options(args.column))
    if fmt["delimiter"] not in _DELIMITERS:
        raise UsageError(f"delimiter must be ',', '\\t' or ';', got {fmt['delimiter']!r}")
    if "time_scale" not in fmt and fmt["time_unit"] not in _TIME_UNITS:
        raise UsageError(f"time unit must be one of {', '.join(_TIME_UNITS)}")
    scale = float(fmt.get("time_scale", _TIME_UNITS.get(fmt["time_unit"], 1.0)))
    names = {**_DEFAULT_COLUMNS, **fmt["columns"]}
    used = [v for v in names.values() if v]
    if len(set(used)) < len(used):
        raise UsageError(f"two columns share one name: {names}; each role needs its own column")
    return names, fmt["delimiter"], scale


def _compensate_chunks(
    cal: Calibration,
    chunks: Iterator[pd.DataFrame],
    names: Mapping[str, str],
    time_scale: float,
    extra_names: Sequence[str],
) -> Iterator[tuple[pd.DataFrame, NDArray[np.float64], int]]:
    """Yield per chunk: the input frame, acceleration in g, and samples outside the range."""
    comp = cal.compensator()
    for frame in chunks:
        before = comp.n_out_of_range
        with warnings.catch_warnings():
            # The command reports the total once at the end instead.
            warnings.simplefilter("ignore", TemperatureRangeWarning)
            temp = (
                frame[names["temperature"]].to_numpy(dtype=np.float64)
                if names["temperature"]
                else None
            )
            g = comp.push(
                frame[[names["x"], names["y"], names["z"]]].to_numpy(dtype=np.float64),
                temp,
                frame[names["time"]].to_numpy(dtype=np.float64) * time_scale,
                {k: frame[k].to_numpy(dtype=np.float64) for k in extra_names},
            )
        yield frame, g, comp.n_out_of_range - before


def _check_columns(source: Path, needed: Sequence[str], found: Sequence[str]) -> None:
    missing = [c for c in needed if c not in found]
    if missing:
        raise CliDataError(
            f"{source}: missing column(s) {', '.join(missing)}; found {', '.join(found)} "
            "(name them with --column KEY=NAME or --session)"
        )


def _text_chunks(
    source: Path, delimiter: str, needed: Sequence[str], chunk_rows: int
) -> Generator[pd.DataFrame]:
    try:
        with GuardedLog(str(source)) as head:  # a line over 1 MiB is refused, not buffered
            header = pd.read_csv(head, sep=_DELIMITERS[delimiter], nrows=0, skipinitialspace=True)
    except pd.errors.EmptyDataError as exc:
        raise CliDataError(f"{source}: empty file, no header row") from exc
    except UnicodeDecodeError as exc:
        raise CliDataError(
            f"{source}: not a text log ({exc.reason}); compensate reads delimited text, "
            "Parquet (.parquet) and flight logs (.ulg, .bin)"
        ) from None
    # pandas renames a repeated name ("x", "x.1"): the line as written says it.
    check_unique_names(
        str(source), first_line_fields(source, _DELIMITERS[delimiter]), header_line=True
    )
    _check_columns(source, needed, [str(c) for c in header.columns])
    body = GuardedLog(str(source))
    reader = pd.read_csv(
        body,
        sep=_DELIMITERS[delimiter],
        skipinitialspace=True,  # "time_s, temp_c": the names the session reader reads
        usecols=list(needed),
        dtype=dict.fromkeys(needed, np.float64),
        chunksize=chunk_rows,
    )

    def frames() -> Generator[pd.DataFrame]:
        with body, reader:
            yield from reader

    return frames()


def _parquet_chunks(
    source: Path, needed: Sequence[str], chunk_rows: int
) -> Generator[pd.DataFrame]:
    pq = need("pyarrow.parquet", "parquet", f"compensating {source} (Parquet)")
    pa_types = need("pyarrow.types", "parquet", f"compensating {source} (Parquet)")
    try:
        pfile = pq.ParquetFile(source)
    except Exception as exc:  # pyarrow raises ArrowInvalid (a ValueError), OSError...
        raise CliDataError(f"{source}: not a readable Parquet file: {exc}") from None
    schema = pfile.schema_arrow
    check_unique_names(str(source), list(schema.names), header_line=False)
    _check_columns(source, needed, list(schema.names))
    for name in needed:
        kind = schema.field(name).type
        if not (pa_types.is_integer(kind) or pa_types.is_floating(kind)):
            raise CliDataError(
                f"{source}: column {name!r} is {kind}, not numeric; compensate reads numbers "
                "(a time column of timestamps: write it as seconds)"
            )
    batches = pfile.iter_batches(batch_size=chunk_rows, columns=list(needed))
    return (b.to_pandas().astype(np.float64) for b in batches)


def _flight_chunks(
    source: Path, cal: Calibration, instance: int, chunk_rows: int
) -> Generator[pd.DataFrame]:
    """Every sample of one IMU of a flight log (read undecimated), in frames."""
    session = open_session(source, cache=False, instance=instance, decimation_factor=1)
    if cal.units != session.units:
        raise CliDataError(
            f"{source}: the log is in {session.units} but the calibration in {cal.units}; "
            "compensate a flight log with a calibration of a flight log"
        )
    c = _FLIGHT_COLUMNS
    return (
        pd.DataFrame(
            {
                c["time"]: run.time_s[a : a + chunk_rows],
                c["temperature"]: run.temperature_c[a : a + chunk_rows],
                c["x"]: run.output[a : a + chunk_rows, 0],
                c["y"]: run.output[a : a + chunk_rows, 1],
                c["z"]: run.output[a : a + chunk_rows, 2],
            }
        )
        for run in session.runs
        for a in range(0, run.time_s.shape[0], chunk_rows)
    )


class _CsvSink:
    """Blocks of float columns as CSV lines."""

    def __init__(self, fh: IO[bytes], names: Sequence[str]) -> None:
        self.fh = fh
        fh.write((",".join(names) + "\n").encode("utf-8"))
        # Time, then temperature when it was logged, then the three accelerations.
        self.fmt = ["%.10g", "%.6g"][: len(names) - 3] + ["%.7f"] * 3

    def write(self, block: NDArray[np.float64]) -> None:
        np.savetxt(self.fh, block, delimiter=",", fmt=self.fmt)

    def close(self) -> None:
        """Nothing to finish: every line is written."""


class _ParquetSink:
    """Blocks of float columns as the row groups of one Parquet file (float64, exact)."""

    def __init__(self, pq: Any, fh: IO[bytes], names: Sequence[str]) -> None:
        import pyarrow as pa  # present: the caller imported pyarrow.parquet

        self.pa = pa
        self.schema = pa.schema([(n, pa.float64()) for n in names])
        self.writer = pq.ParquetWriter(fh, self.schema)

    def write(self, block: NDArray[np.float64]) -> None:
        arrays = [self.pa.array(block[:, i]) for i in range(block.shape[1])]
        self.writer.write_table(self.pa.Table.from_arrays(arrays, schema=self.schema))

    def close(self) -> None:
        """Write the Parquet footer."""
        self.writer.close()


def cmd_compensate(args: argparse.Namespace, out: TextIO) -> int:
    """``accelcore compensate``: a raw log of any size into acceleration in g, in chunks."""
    source = Path(args.input)
    flight = is_flight_log(source)
    inputs: list[str | Path] = [args.calibration, source]
    if args.session:
        inputs += SessionFormat.input_files(args.session)
    guard(inputs, [args.output])
    if args.chunk_rows < 1:
        raise UsageError("--chunk-rows must be >= 1")
    if args.instance != 0 and not flight:
        raise UsageError(f"--instance applies to flight logs (.ulg, .bin); {source} is not one")
    if flight and (args.session or args.column or args.delimiter or args.time_unit):
        raise UsageError(
            f"{source} is a flight log: its columns are known; drop --session, --column, "
            "--delimiter and --time-unit"
        )
    pq = None
    if Path(args.output).suffix.lower() == ".parquet":
        pq = need("pyarrow.parquet", "parquet", f"writing {args.output} (Parquet)")
    names, delimiter, time_scale = (_FLIGHT_COLUMNS, ",", 1.0) if flight else _layout(args)
    check_input_file(source, "log")  # a FIFO would block, a device never end
    cal = Calibration.load(args.calibration)
    if args.session and (units := SessionFormat.read(args.session, check_files=False).units) != (
        cal.units
    ):
        raise CliDataError(
            f"{source}: --session {args.session} says its logs are in {units} but the "
            f"calibration {args.calibration} is in {cal.units}: compensate a log with a "
            "calibration of its own units"
        )
    extra_names = sorted(
        {t.basis.column for m in cal.axes.values() for t in m.terms if t.basis.column is not None}
    )
    if flight and extra_names:
        raise CliDataError(
            f"{source}: the calibration needs column(s) {', '.join(extra_names)}, "
            "which a flight log does not hold"
        )
    needed = [names[k] for k in COLUMN_KEYS if names[k]] + extra_names
    chunks: Generator[pd.DataFrame]
    if flight:
        chunks = _flight_chunks(source, cal, args.instance, args.chunk_rows)
    elif source.suffix.lower() == ".parquet":
        chunks = _parquet_chunks(source, needed, args.chunk_rows)
    else:
        chunks = _text_chunks(source, delimiter, needed, args.chunk_rows)
    if args.session:
        chunks = _check_rate(chunks, source, args.session, names["time"], time_scale)
    target = require_folder(args.output)
    n_rows = n_out_of_range = n_nan = 0
    kept = [names["time"], *([names["temperature"]] if names["temperature"] else [])]
    out_names = [*kept, "x_g", "y_g", "z_g"]
    # Written chunk by chunk (the log may not fit in memory), replaced atomically at the end.
    bar = Progress(None, what="rows compensated", enabled=not args.quiet)
    with contextlib.closing(chunks), contextlib.closing(bar), atomic_open(target) as fh:
        sink = _CsvSink(fh, out_names) if pq is None else _ParquetSink(pq, fh, out_names)
        try:
            for frame, g, n_out in _compensate_chunks(cal, chunks, names, time_scale, extra_names):
                block = np.column_stack([*(frame[c].to_numpy() for c in kept), g])
                sink.write(block)
                n_rows += len(frame)
                bar.advance(len(frame))
                n_out_of_range += n_out
                n_nan += int(np.count_nonzero(~np.isfinite(g).all(axis=1)))
        except ValueError as exc:
            if isinstance(exc, (TimeOrderError, NonFiniteError)) and not flight:
                raise _at_row(exc, source, delimiter, names) from exc
            if isinstance(exc, AccelcoreError) or flight:
                raise
            raise _bad_cell(source, _DELIMITERS[delimiter], needed) or CliDataError(
                f"{source}: {exc}"
            ) from exc
        sink.close()
    print(f"compensated {n_rows} rows of {source} into {target} (columns x_g, y_g, z_g)", file=out)
    if n_nan:
        print(f"warning: {n_nan} rows had non-finite input and are NaN", file=sys.stderr)
    if n_out_of_range:
        lo, hi = cal.temperature_range_c
        print(
            f"warning: {n_out_of_range} rows lie outside the calibrated range {lo:.2f}…{hi:.2f} °C;"
            " the model is extrapolated there, its curvature along its tangent at the"
            " range's edge",
            file=sys.stderr,
        )
    return 0


def _check_rate(
    chunks: Generator[pd.DataFrame], source: Path, session: str, time: str, scale: float
) -> Generator[pd.DataFrame]:
    """Yield the chunks, refusing a log whose time steps contradict the session's rate.

    A ``time_unit`` of ms for a log in seconds read every step 1000x short: the
    compensation's lags and rates would follow another clock in silence (the load of a
    session refuses the same mismatch, :func:`accelcore.input.consistency`).
    """
    rate = SessionFormat.read(session, check_files=False).rate_hz
    first = next(chunks, None)
    if first is None:
        return
    steps = np.diff(first[time].to_numpy(dtype=np.float64) * scale)
    steps = steps[np.isfinite(steps) & (steps > 0)]
    if steps.size:
        step = float(np.median(steps))
        if not 1.0 / RATE_SLACK <= step * rate <= RATE_SLACK:
            chunks.close()
            raise CliDataError(
                f"{source}: its time stamps are {step:.6g} s apart in the --session's "
                f"time_unit, where its rate_hz = {rate:g} Hz says {1.0 / rate:.6g} s: rate_hz "
                "or time_unit is wrong for this log"
            )
    yield first
    yield from chunks


def _at_row(
    exc: TimeOrderError | NonFiniteError, source: Path, delimiter: str, names: Mapping[str, str]
) -> CliDataError:
    """Say where in the log the compensator's row is: line and column, or Parquet row.

    The compensator counts rows of the whole stream from 0 (``row`` of a non-finite time
    or temperature, its ``column`` 0 or 1; ``index`` of a time that goes back).
    """
    if isinstance(exc, TimeOrderError):
        k, role = int(exc.index), "time"
        what = f"time is not strictly increasing: {exc.previous_s!r} s then {exc.time_s!r} s"
    else:
        k, role = int(exc.row), ("time", "temperature")[min(int(exc.column), 1)]
        what = "not a finite number (empty, nan or inf)"
    name = names[role]
    if source.suffix.lower() == ".parquet":
        return CliDataError(f"{source}: row {k + 1}, column {name!r}: {what}")
    separator = _DELIMITERS[delimiter]
    with source.open(newline="", encoding="utf-8", errors="replace") as fh:
        header = [h.strip() for h in next(csv.reader(fh, delimiter=separator), [])]
        column = header.index(name) + 1 if name in header else 0
        seen = -1
        for line, text in enumerate(fh, start=2):
            if text.strip():  # pandas skips blank lines: count the rows it read
                seen += 1
                if seen == k:
                    return CliDataError(f"{source}:{line}:{column}: column {name!r}: {what}")
    return CliDataError(f"{source}: row {k + 1} of data, column {name!r}: {what}")


def _bad_cell(source: Path, delimiter: str, needed: Sequence[str]) -> ParseError | None:
    """Find the first cell of the needed columns that is not a number (line and column, 1-based).

    Only called after the fast reader failed, so a clean log is read once.
    """
    with source.open(newline="", encoding="utf-8", errors="replace") as fh:
        rows = csv.reader(fh, delimiter=delimiter)
        header = next(rows, [])
        wanted = [(i, name) for i, name in enumerate(header) if name in needed]
        for line, row in enumerate(rows, start=2):
            for i, name in wanted:
                cell = row[i].strip() if i < len(row) else ""
                if cell == "":
                    continue
                try:
                    float(cell)
                except ValueError:
                    err = ParseError(
                        f"{source}:{line}:{i + 1}: column {name!r}: {cell!r} is not a number"
                    )
                    err.path, err.line, err.column = str(source), line, i + 1
                    return err
    return None
