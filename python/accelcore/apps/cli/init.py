"""``accelcore init FOLDER|LOG``: start a ``session.toml`` for logs, asking nothing.

Every delimited log of a folder (``.csv``, ``.tsv``, ``.txt``, ``.dat``) becomes a
run. Given one log instead (``accelcore init chamber.csv``, ``.parquet``,
``.tdms``), the ``session.toml`` beside it names that log (``log =``;
:mod:`accelcore.apps.cli.init_log`), or, for a delimited log without an
orientation column, makes it the one run. What the format needs is guessed
(:mod:`accelcore.apps.cli.guesses`), and every guess is printed:

- the delimiter, from the header line (the most frequent of ``,``, tab, ``;``);
- the columns, from the header names (:data:`COLUMN_PATTERNS`: ``time``/``t_ms``/
  ``timestamp``, ``temp``/``temperature``/``die_temp``, ``x``/``ax``/``acc_x``/``x_g``
  ...), and the time unit from the time column's suffix (``_ms``, ``_us``, ``_ns``);
- each run's orientation from its file name (``x_pos``, ``OX+``, ``xp``, ``zminus``,
  ``+z`` ...; :func:`orientation_from_name`), failing that from the direction of the
  log's mean output (gravity) against the other logs (:func:`orientation_from_means`);
- the units from the size of the output (``g``, ``m/s2``, integer ``LSB``, else ``V``)
  and the rate from the median time step; ``--units`` and ``--rate-hz`` override them.

Part of the applications room.
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from pathlib import Path
from typing import TextIO

import numpy as np
import pandas as pd

from accelcore._accelcore import MAX_PREAMBLE_LINES
from accelcore.apps.cli.guesses import (
    COLUMN_PATTERNS,
    ROLES,
    delimiter_of,
    guess_columns,
    orientation_from_means,
    orientation_from_name,
    rate_of,
    time_unit_of,
    toml_value,
    units_of,
)
from accelcore.apps.cli.init_log import guess_log, write_log_session
from accelcore.apps.cli.inputs import CliDataError, UsageError, guard
from accelcore.constants import DELIMITERS, ORIENTATIONS, SESSION_FORMAT, TIME_UNITS
from accelcore.files import atomic_write
from accelcore.input.format import TOML_NAME
from accelcore.input.log_format import log_layout

__all__ = [
    "COLUMN_PATTERNS",
    "LOG_SUFFIXES",
    "cmd_init",
    "guess_columns",
    "orientation_from_means",
    "orientation_from_name",
]

#: Files taken as logs.
LOG_SUFFIXES = (".csv", ".tsv", ".txt", ".dat")


def _document(
    settings: Mapping[str, str | float], columns: Mapping[str, str], runs: Mapping[str, str]
) -> str:
    lines = [f"format = {toml_value(SESSION_FORMAT)}"]
    lines += [f"{k} = {toml_value(v)}" for k, v in settings.items()]
    lines += ["", "[columns]"] + [f"{k} = {toml_value(v)}" for k, v in columns.items()]
    for file, orientation in runs.items():
        lines += [
            "",
            "[[run]]",
            f"file = {toml_value(file)}",
            f"orientation = {toml_value(orientation)}",
        ]
    return "\n".join(lines) + "\n"


def cmd_init(args: argparse.Namespace, out: TextIO) -> int:
    """``accelcore init``: write session.toml for a folder of logs, or beside one log."""
    path = Path(args.folder)
    if args.delimiter is not None and args.delimiter not in DELIMITERS:
        raise UsageError(f"--delimiter must be ',', '\\t' or ';', got {args.delimiter!r}")
    if path.is_file() or (log_layout(path) is not None and not path.is_dir()):
        if not path.is_file():
            raise CliDataError(f"{path}: no such file")
        target = path.parent / TOML_NAME
        _check_target(target, args.force)
        guard([path], [target])
        guess = guess_log(path, args)
        if guess is None:  # a delimited log without labels: one run, as in a folder
            return _init_runs(path.parent, [path], args, out)
        return write_log_session(guess, target, args, out)
    folder = path
    if not folder.is_dir():
        raise CliDataError(f"{folder}: no such folder")
    target = folder / TOML_NAME
    _check_target(target, args.force)
    logs = sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in LOG_SUFFIXES)
    if not logs:
        raise CliDataError(f"{folder}: no log files ({', '.join(LOG_SUFFIXES)})")
    guard(logs, [target])
    return _init_runs(folder, logs, args, out)


def _check_target(target: Path, force: bool) -> None:
    """Refuse to write over a session.toml unless forced."""
    if (target.exists() or target.is_symlink()) and not force:
        raise UsageError(f"{target} exists; --force writes over it")


def _header(log: Path, args: argparse.Namespace) -> tuple[int, str, list[str]]:
    """Return the lines above a log's header, its delimiter and its names.

    The header is the first non-blank line whose names give a time and x, y, z
    column, within the reader's :data:`MAX_PREAMBLE_LINES` (a logger's settings lines
    above it, as the reader skips them); else the first non-blank line.
    """
    first: tuple[int, str, list[str]] | None = None
    with log.open(encoding="utf-8", errors="replace") as fh:
        for i, line in enumerate(fh):
            if i >= MAX_PREAMBLE_LINES:
                break
            if not line.strip():
                continue
            line = line.lstrip("\ufeff")
            delimiter = DELIMITERS[args.delimiter] if args.delimiter else delimiter_of(line)
            names = [h.strip() for h in line.rstrip("\r\n").split(delimiter)]
            first = first or (i, delimiter, names)
            if all(r in guess_columns(names) for r in ROLES if r != "temperature"):
                return i, delimiter, names
    if first is None:
        raise CliDataError(f"{log}: no header line")
    return first


def _init_runs(folder: Path, logs: list[Path], args: argparse.Namespace, out: TextIO) -> int:
    """Write FOLDER/session.toml with one run per log."""
    target = folder / TOML_NAME
    skip, delimiter, header = _header(logs[0], args)
    columns = guess_columns(header)
    # Without a temperature column the session is one at one temperature (imucal's
    # six positions): `temperature = ""`, said in the summary.
    missing = [r for r in ROLES if r not in columns and r != "temperature"]
    if missing:
        raise CliDataError(
            f"{logs[0]}: no column recognised as {', '.join(missing)} among {', '.join(header)}"
        )
    columns.setdefault("temperature", "")
    time_unit = time_unit_of(columns["time"])
    frames: dict[str, pd.DataFrame] = {}
    used = [c for c in columns.values() if c]
    for log in logs:
        try:
            frames[log.name] = pd.read_csv(log, sep=delimiter, usecols=used, skiprows=skip)
        except (ValueError, pd.errors.ParserError) as exc:
            raise CliDataError(
                f"{log}: not a log of the same layout as {logs[0].name}: {exc}"
            ) from None
    axes = [columns[a] for a in "xyz"]
    means = {n: f[axes].mean().to_numpy(dtype=np.float64) for n, f in frames.items()}
    integers = all(
        np.array_equal(v, np.round(v)) for v in (f[axes].to_numpy() for f in frames.values())
    )
    units = args.units or units_of(np.array(list(means.values())), integers)
    rate = args.rate_hz
    if rate is None:
        t = frames[logs[0].name][columns["time"]].to_numpy(dtype=np.float64)
        rate = rate_of(t * TIME_UNITS[time_unit])
        if rate is None:
            raise CliDataError(f"{logs[0]}: fewer than two time stamps; give --rate-hz")
    by_gravity = orientation_from_means(means, units)
    runs: dict[str, str] = {}
    how: dict[str, str] = {}
    for name in frames:
        named = orientation_from_name(name)
        if named is not None:
            runs[name], how[name] = named, "file name"
        elif name in by_gravity:
            runs[name], how[name] = by_gravity[name], "mean output (gravity)"
        else:
            raise CliDataError(
                f"{folder / name}: cannot tell its orientation from its name or its mean output; "
                "name the file after it (x_pos, OX+, zminus, ...)"
            )
    settings: dict[str, str | float] = {}
    if args.sensor:
        settings["sensor"] = args.sensor
    if args.serial:
        settings["serial"] = args.serial
    settings.update(units=units, rate_hz=rate, delimiter=delimiter, time_unit=time_unit)
    atomic_write(target, _document(settings, {r: columns[r] for r in ROLES}, runs))
    shown = {"\t": "tab"}.get(delimiter, delimiter)
    print(f"wrote {target}: {len(runs)} runs", file=out)
    print(f"  units {units}{'' if args.units else ' (guessed from the output size)'}, "
          f"rate {rate:g} Hz{'' if args.rate_hz else ' (median time step)'}, "
          f"delimiter {shown!r}, time unit {time_unit}", file=out)  # fmt: skip
    print("  columns: " + ", ".join(f"{r}={columns[r]}" for r in ROLES if columns[r]), file=out)
    if not columns["temperature"]:
        print(
            '  no temperature column: temperature = "" (a calibration at one temperature)',
            file=out,
        )
    width = max(len(n) for n in runs)
    for name, orientation in runs.items():
        print(f"  {name:<{width}}  {orientation}  ({how[name]})", file=out)
    if len(set(runs.values())) < len(ORIENTATIONS):
        print(f"  orientations: {' '.join(sorted(set(runs.values())))} (not all six)", file=out)
    return 0
