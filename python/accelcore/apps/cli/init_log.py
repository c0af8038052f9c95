"""``accelcore init LOG``: a ``session.toml`` beside one log that names it (``log =``).

The log's layout follows its suffix (:data:`accelcore.input.log_format.LOG_LAYOUTS`);
what reading it needs is guessed from it, asking nothing, and printed:

- a delimited log (``.csv``, ``.txt``, ``.tsv``, ``.dat``): the delimiter and columns
  from the header, and the orientation column, the first whose values (of the
  first 20 000 rows) are all labels ``OX+`` ... ``OZ-``; without one, the log is
  the one run of a ``[[run]]`` session instead (:mod:`accelcore.apps.cli.init`);
- a Parquet file: the columns from its schema, the orientation column as above,
  else one orientation for the file from its name or its mean output (gravity);
  units, rate, sensor and serial from its metadata when it states them;
- a TDMS file: the channels from its first group; each group's orientation from
  its ``orientation`` property, else from the group's name, else from its mean
  output against the other groups; units from the channels' ``unit_string``.

Units are otherwise guessed from the size of the output, the rate from the median
time step (a TDMS file's ``wf_increment``); ``--units`` and ``--rate-hz`` override
them.

Part of the applications room.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np
import pandas as pd

from accelcore.apps.cli.guesses import (
    ROLES,
    delimiter_of,
    guess_columns,
    label_column,
    orientation_from_means,
    orientation_from_name,
    rate_of,
    time_unit_of,
    toml_value,
    units_of,
)
from accelcore.apps.cli.inputs import CliDataError, need
from accelcore.constants import AXES, DELIMITERS, SESSION_FORMAT, TIME_UNITS, UNITS
from accelcore.files import atomic_write
from accelcore.input.log_format import DELIMITED, PARQUET, TDMS, log_layout
from accelcore.input.readers.own_settings import UNIT_STRINGS

__all__ = ["LogGuess", "guess_log", "write_log_session"]

#: Rows looked at to find the orientation column.
SAMPLE_ROWS = 20_000


@dataclass
class LogGuess:
    """What ``init`` makes of one log: the keys of its ``session.toml`` and how each was found.

    ``columns`` holds the roles found (and ``orientation``, the label column);
    ``orientation`` the file's one orientation, or each TDMS group's, when not
    in a column; ``how`` the printed reason of each guessed setting.
    """

    log: Path
    layout: str
    units: str
    rate_hz: float
    time_unit: str
    columns: dict[str, str]
    delimiter: str | None = None
    orientation: str | dict[str, str] | None = None
    runs: list[str] = field(default_factory=list)  # orientation of each run, in order
    sensor: str | None = None
    serial: str | None = None
    how: dict[str, str] = field(default_factory=dict)


def _settle_units(guess: LogGuess, args: argparse.Namespace, stated: str | None) -> None:
    if args.units:
        guess.units, guess.how["units"] = args.units, ""
    elif stated is not None:
        guess.how["units"] = " (stated by the file)"


def _labels(values: pd.Series) -> pd.Series:
    return values.astype("string").str.strip().str.upper()


def _runs(labels: pd.Series) -> list[str]:
    """Return the orientation of each run: every contiguous stretch of one label."""
    known = [str(v) for v in labels.dropna() if str(v)]
    return [v for i, v in enumerate(known) if i == 0 or v != known[i - 1]]


def _means_by_label(frame: pd.DataFrame, axes: list[str], labels: pd.Series) -> np.ndarray:
    return frame[axes].groupby(labels.to_numpy()).mean().to_numpy(dtype=np.float64)


def _numbers(values: pd.Series) -> np.ndarray:
    return pd.to_numeric(values, errors="coerce").to_numpy(dtype=np.float64)


def _stated_rate(meta: Mapping[str, str]) -> float | None:
    """Return the rate_hz Parquet metadata states, when it is a positive number."""
    try:
        rate = float(meta["rate_hz"])
    except (KeyError, ValueError):
        return None
    return rate if math.isfinite(rate) and rate > 0 else None


def _integers(frame: pd.DataFrame, axes: list[str]) -> bool:
    v = frame[axes].to_numpy(dtype=np.float64)
    return bool(np.array_equal(v[np.isfinite(v)], np.round(v[np.isfinite(v)])))


def _require_roles(log: Path, columns: Mapping[str, str], header: list[str], optional: str) -> None:
    missing = [r for r in ROLES if r not in columns and r != optional]
    if missing:
        raise CliDataError(
            f"{log}: no column recognised as {', '.join(missing)} among {', '.join(header)}"
        )


def _rate(
    log: Path,
    seconds: np.ndarray,
    args: argparse.Namespace,
    how: dict[str, str],
    stated: float | None = None,
) -> float:
    if args.rate_hz is not None:
        how["rate"] = ""
        return float(args.rate_hz)
    if stated is not None:
        how["rate"] = " (stated by the file)"
        return stated
    rate = rate_of(seconds)
    if rate is None:
        raise CliDataError(f"{log}: fewer than two time stamps; give --rate-hz")
    how["rate"] = " (median time step)"
    return rate


def _delimited(log: Path, args: argparse.Namespace) -> LogGuess | None:
    with log.open(encoding="utf-8-sig", errors="replace") as fh:
        first_line = fh.readline()
    delimiter = DELIMITERS[args.delimiter] if args.delimiter else delimiter_of(first_line)
    header = [h.strip() for h in first_line.rstrip("\r\n").split(delimiter)]
    columns = guess_columns(header)
    _require_roles(log, columns, header, optional="")
    others = [h for h in header if h not in columns.values()]
    if not others:
        return None
    read: dict[str, Any] = {"sep": delimiter, "skipinitialspace": True, "encoding": "utf-8-sig"}
    try:
        sample = pd.read_csv(log, usecols=others, dtype=str, nrows=SAMPLE_ROWS, **read)
        label = label_column({c: sample[c].tolist() for c in others})
        if label is None:
            return None
        frame = pd.read_csv(log, usecols=[*columns.values(), label], dtype={label: str}, **read)
    except (ValueError, pd.errors.ParserError) as exc:
        raise CliDataError(f"{log}: cannot be read as a delimited log: {exc}") from None
    return _from_frame(log, DELIMITED, frame, columns, label, args, delimiter=delimiter)


def _from_frame(
    log: Path,
    layout: str,
    frame: pd.DataFrame,
    columns: dict[str, str],
    label: str,
    args: argparse.Namespace,
    *,
    delimiter: str | None = None,
    stated_units: str | None = None,
    stated_rate: float | None = None,
    seconds: np.ndarray | None = None,
) -> LogGuess:
    """Guess a log whose label column says each run's orientation."""
    axes = [columns[a] for a in AXES]
    labels = _labels(frame[label])
    time_unit = time_unit_of(columns["time"])
    if seconds is None:
        seconds = _numbers(frame[columns["time"]]) * TIME_UNITS[time_unit]
    how: dict[str, str] = {"units": " (guessed from the output size)"}
    units = stated_units or units_of(_means_by_label(frame, axes, labels), _integers(frame, axes))
    guess = LogGuess(
        log=log,
        layout=layout,
        units=units,
        rate_hz=_rate(log, seconds, args, how, stated_rate),
        time_unit=time_unit,
        columns={**columns, "orientation": label},
        delimiter=delimiter,
        runs=_runs(labels),
        how=how,
    )
    guess.how["orientation"] = f" (column {label!r})"
    _settle_units(guess, args, stated_units)
    return guess


def _parquet(log: Path, args: argparse.Namespace) -> LogGuess:
    pa = need("pyarrow", "parquet", f"accelcore init {log}")
    pq = need("pyarrow.parquet", "parquet", f"accelcore init {log}")
    try:
        pf = pq.ParquetFile(str(log))
    except (pa.ArrowInvalid, OSError) as exc:
        raise CliDataError(f"{log}: not a Parquet file: {exc}") from None
    schema = pf.schema_arrow
    meta = {
        k.decode("utf-8", "replace"): v.decode("utf-8", "replace")
        for k, v in (schema.metadata or {}).items()
    }
    header = list(schema.names)
    columns = guess_columns(header)
    _require_roles(log, columns, header, optional="")
    texts = [
        f.name
        for f in schema
        if f.name not in columns.values()
        and (
            pa.types.is_string(f.type)
            or pa.types.is_large_string(f.type)
            or pa.types.is_dictionary(f.type)
        )
    ]
    label = None
    if texts:
        first = next(pf.iter_batches(batch_size=SAMPLE_ROWS, columns=texts), None)
        if first is not None:
            label = label_column({c: first.column(c).to_pylist() for c in texts})
    frame = pq.read_table(str(log), columns=[*columns.values(), *([label] if label else [])])
    frame = frame.to_pandas()
    time = frame[columns["time"]]
    if pd.api.types.is_datetime64_any_dtype(time.dtype):
        seconds = (time - time.iloc[0]).dt.total_seconds().to_numpy(dtype=np.float64)
    else:
        seconds = _numbers(time) * TIME_UNITS[time_unit_of(columns["time"])]
    stated = meta.get("units") if meta.get("units") in UNITS else None
    rate = _stated_rate(meta)
    if label is not None:
        guess = _from_frame(
            log,
            PARQUET,
            frame,
            columns,
            label,
            args,
            stated_units=stated,
            stated_rate=rate,
            seconds=seconds,
        )
    else:
        guess = _one_orientation(log, frame, columns, args, (stated, rate), seconds)
    guess.sensor, guess.serial = meta.get("sensor") or None, meta.get("serial") or None
    return guess


def _one_orientation(
    log: Path,
    frame: pd.DataFrame,
    columns: dict[str, str],
    args: argparse.Namespace,
    stated_facts: tuple[str | None, float | None],
    seconds: np.ndarray,
) -> LogGuess:
    """Guess a Parquet file of one orientation: from its name, else its mean output."""
    stated, stated_rate = stated_facts
    axes = [columns[a] for a in AXES]
    mean = frame[axes].mean().to_numpy(dtype=np.float64)
    how: dict[str, str] = {"units": " (guessed from the output size)"}
    units = args.units or stated or units_of(mean.reshape(1, 3), _integers(frame, axes))
    orientation = orientation_from_name(log.name)
    how["orientation"] = " (file name)"
    if orientation is None:
        orientation = orientation_from_means({log.name: mean}, units).get(log.name)
        how["orientation"] = " (mean output (gravity))"
    if orientation is None:
        raise CliDataError(
            f"{log}: no column of orientation labels, and neither its name nor its mean "
            "output tells its orientation; name the file after it (x_pos, OX+, zminus, ...)"
        )
    guess = LogGuess(
        log=log,
        layout=PARQUET,
        units=units,
        rate_hz=_rate(log, seconds, args, how, stated_rate),
        time_unit=time_unit_of(columns["time"]),
        columns=columns,
        orientation=orientation,
        runs=[orientation],
        how=how,
    )
    _settle_units(guess, args, stated)
    return guess


def _tdms(log: Path, args: argparse.Namespace) -> LogGuess:
    nptdms = need("nptdms", "tdms", f"accelcore init {log}")
    try:
        tdms = nptdms.TdmsFile.read(str(log))
    except Exception as exc:  # npTDMS raises plain ValueError/KeyError on bad files
        raise CliDataError(f"{log}: not a TDMS file: {exc}") from None
    groups = [g for g in tdms.groups() if g.channels()]
    if not groups:
        raise CliDataError(f"{log}: no group holds channels")
    # The channels of the first group where every role is found (a settings group
    # before the runs says nothing).
    headers = [[c.name for c in g.channels()] for g in groups]
    guessed = [guess_columns(h) for h in headers]
    first = next((i for i, c in enumerate(guessed) if {"temperature", *AXES} <= set(c)), 0)
    header, columns = headers[first], guessed[first]
    _require_roles(log, columns, header, optional="time")
    needed = [columns[r] for r in ("temperature", *AXES)]
    groups = [g for g in groups if all(c in [ch.name for ch in g.channels()] for c in needed)]
    x = groups[0][columns["x"]]
    increment = x.properties.get("wf_increment")
    how: dict[str, str] = {"units": " (guessed from the output size)"}
    if "time" in columns:
        time_unit = time_unit_of(columns["time"])
        t = groups[0][columns["time"]][:]
        seconds = (
            (t - t[0]).astype("timedelta64[ns]").astype(np.float64) * 1e-9
            if np.issubdtype(t.dtype, np.datetime64)
            else np.asarray(t, dtype=np.float64) * TIME_UNITS[time_unit]
        )
    elif increment:
        time_unit, seconds = "s", np.empty(0)
    else:
        raise CliDataError(
            f"{log}: no time channel among {', '.join(header)} and no wf_increment property"
        )
    axes = [columns[a] for a in AXES]
    means = {g.name: np.array([np.mean(g[c][:]) for c in axes], dtype=np.float64) for g in groups}
    found = {
        str(g[c].properties.get("unit_string", "")).strip().lower() for g in groups for c in axes
    }
    stated = UNIT_STRINGS.get(found.pop()) if len(found) == 1 else None
    integers = all(np.array_equal(g[c][:], np.round(g[c][:])) for g in groups for c in axes)
    units = args.units or stated or units_of(np.array(list(means.values())), integers)
    guess = LogGuess(
        log=log,
        layout=TDMS,
        units=units,
        rate_hz=_rate(log, seconds, args, how, _wf_rate(increment)),
        time_unit=time_unit,
        columns=dict(columns),
        how=how,
    )
    _settle_units(guess, args, stated)
    _group_orientations(guess, groups, means)
    return guess  # sensor and serial: the reader takes the file's own properties


def _wf_rate(increment: object) -> float | None:
    """Return the rate a waveform's ``wf_increment`` states (6 significant digits)."""
    try:
        step = float(increment)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    return float(f"{1.0 / step:.6g}") if math.isfinite(step) and step > 0 else None


def _group_orientations(
    guess: LogGuess, groups: list[Any], means: Mapping[str, np.ndarray]
) -> None:
    """Each group's orientation: its property (nothing to write), else its name, else gravity."""
    stated = {g.name: g.properties.get("orientation") for g in groups}
    if all(v is not None for v in stated.values()):
        guess.runs = [str(v).strip().upper() for v in stated.values()]
        guess.how["orientation"] = " (each group's orientation property)"
        return
    by_gravity = orientation_from_means(means, guess.units)
    table: dict[str, str] = {}
    ways = set()
    for name in stated:
        named = orientation_from_name(name)
        if named is not None:
            table[name] = named
            ways.add("group name")
        elif name in by_gravity:
            table[name] = by_gravity[name]
            ways.add("mean output (gravity)")
        else:
            raise CliDataError(
                f"{guess.log}#{name}: cannot tell the group's orientation from a property, its "
                "name or its mean output; give the group an orientation property"
            )
    guess.orientation, guess.runs = table, list(table.values())
    guess.how["orientation"] = f" ({', '.join(sorted(ways))})"


def guess_log(log: Path, args: argparse.Namespace) -> LogGuess | None:
    """Guess what reading one log needs.

    Parameters
    ----------
    log : Path
        The log (a suffix of :data:`~accelcore.input.log_format.LOG_LAYOUTS`).
    args : argparse.Namespace
        ``init``'s options (``--units``, ``--rate-hz``, ``--delimiter``).

    Returns
    -------
    LogGuess or None
        None for a delimited log without an orientation column (a one-run log).

    Raises
    ------
    CliDataError
        No column of a role, no time, an orientation that cannot be told.
    UsageError
        Not a single log; pyarrow or npTDMS missing (the message names the extra).
    """
    layout = log_layout(log)
    if layout is None:
        raise CliDataError(
            f"{log}: not a log accelcore reads (.csv, .txt, .tsv, .dat, .parquet, .tdms)"
        )
    if args.delimiter is not None and layout != DELIMITED:
        raise CliDataError(f"{log}: --delimiter applies to a delimited log, not a {layout} file")
    if layout == DELIMITED:
        return _delimited(log, args)
    if layout == PARQUET:
        return _parquet(log, args)
    return _tdms(log, args)


def _document(guess: LogGuess, args: argparse.Namespace) -> str:
    settings: dict[str, str | float] = {}
    if args.sensor or guess.sensor:
        settings["sensor"] = args.sensor or guess.sensor or ""
    if args.serial or guess.serial:
        settings["serial"] = args.serial or guess.serial or ""
    settings.update(units=guess.units, rate_hz=guess.rate_hz)
    if guess.delimiter is not None:
        settings["delimiter"] = guess.delimiter
    settings.update(time_unit=guess.time_unit, log=guess.log.name)
    if isinstance(guess.orientation, str):
        settings["orientation"] = guess.orientation
    lines = [f"format = {toml_value(SESSION_FORMAT)}"]
    lines += [f"{k} = {toml_value(v)}" for k, v in settings.items()]
    lines += ["", "[columns]"] + [f"{k} = {toml_value(v)}" for k, v in guess.columns.items()]
    if isinstance(guess.orientation, dict):
        lines += ["", "[orientation]"]
        lines += [f"{toml_value(g)} = {toml_value(o)}" for g, o in guess.orientation.items()]
    return "\n".join(lines) + "\n"


def write_log_session(guess: LogGuess, target: Path, args: argparse.Namespace, out: TextIO) -> int:
    """Write ``target`` (the ``session.toml`` beside the log) and print every guess.

    Parameters
    ----------
    guess : LogGuess
    target : Path
    args : argparse.Namespace
        ``init``'s options (``--sensor``, ``--serial``).
    out : text stream

    Returns
    -------
    int
        Exit status 0.
    """
    atomic_write(target, _document(guess, args))
    shown = {"\t": "tab"}.get(guess.delimiter or "", guess.delimiter)
    n = len(guess.runs)
    runs = f"{n} run{'s' * (n != 1)}"
    print(f"wrote {target}: log {guess.log.name} ({guess.layout}), {runs}", file=out)
    parts = [
        f"units {guess.units}{guess.how.get('units', '')}",
        f"rate {guess.rate_hz:g} Hz{guess.how.get('rate', '')}",
        *([f"delimiter {shown!r}"] if shown else []),
        f"time unit {guess.time_unit}",
    ]
    print("  " + ", ".join(parts), file=out)
    print("  columns: " + ", ".join(f"{r}={n}" for r, n in guess.columns.items()), file=out)
    print(f"  orientations: {' '.join(guess.runs)}{guess.how.get('orientation', '')}", file=out)
    return 0
