"""``accelcore init FOLDER``: start a ``session.toml`` for a folder of logs, asking nothing.

Every delimited log of the folder (``.csv``, ``.tsv``, ``.txt``, ``.dat``) becomes a
run. What the format needs is guessed, and every guess is printed:

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
import json
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TextIO

import numpy as np
import pandas as pd

from accelcore.apps.cli.inputs import CliDataError, UsageError, guard
from accelcore.constants import (
    DELIMITERS,
    ORIENTATIONS,
    SESSION_FORMAT,
    STANDARD_GRAVITY,
    TIME_UNITS,
)
from accelcore.files import atomic_write
from accelcore.input.format import TOML_NAME

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

_UNIT = r"(_?(s|sec|ms|us|ns))?"

#: Header names recognised for each role (matched whole, case-insensitive), in order
#: of preference.
COLUMN_PATTERNS: Mapping[str, tuple[str, ...]] = {
    "time": (
        rf"time{_UNIT}",
        rf"timestamp{_UNIT}",
        rf"elapsed{_UNIT}",
        r"time_?usec",
        rf"t{_UNIT}",
    ),
    "temperature": (
        r"temp(erature)?(_?(c|degc))?",
        r"(die|sensor|chip|board|imu)_?temp(erature)?(_?c)?",
        r"t_?(c|degc)",
        r"t",
    ),
    **{
        a: (
            rf"{a}",
            rf"a_?{a}",
            rf"acc(el(eration)?)?_?{a}",
            rf"{a}_?(g|v|raw|lsb|acc|out|mps2|m_?s2)",
        )
        for a in "xyz"
    },
}

_ROLES = ("time", "temperature", "x", "y", "z")
_SIGNS = {"pos": "+", "plus": "+", "up": "+", "p": "+", "neg": "-", "minus": "-", "down": "-"}
_SIGNS.update({"n": "-", "+": "+", "-": "-"})
_WORD = r"pos|plus|up|neg|minus|down|p|n"
_NAME_PATTERNS = (
    rf"(?<![a-z])o?(?P<axis>[xyz])[_\- ]?(?P<sign>{_WORD})(?![a-z])",
    r"(?<![a-z])o?(?P<axis>[xyz]) ?(?P<sign>[+-])",
    r"(?P<sign>[+-]) ?(?P<axis>[xyz])(?![a-z])",
    r"(?<![a-z])(?P<sign>pos|plus|neg|minus)[_\- ]?(?P<axis>[xyz])(?![a-z])",
)


def orientation_from_name(name: str) -> str | None:
    """Return the orientation a file name states (``x_pos`` → ``OX+``), or None.

    Parameters
    ----------
    name : str
        A file name; its suffix is ignored.

    Returns
    -------
    str or None
        One of ``OX+ … OZ-`` when the name states exactly one, else None.
    """
    stem = Path(name).stem.lower()
    found = set()
    for pattern in _NAME_PATTERNS:
        for m in re.finditer(pattern, stem):
            found.add(f"O{m['axis'].upper()}{_SIGNS[m['sign']]}")
    return found.pop() if len(found) == 1 else None


def orientation_from_means(means: Mapping[str, np.ndarray], units: str) -> dict[str, str]:
    """Guess each log's orientation from its mean output: the axis gravity moves most.

    The offset of each axis is taken as 0 for ``g`` and ``m/s2``, else as the
    middle of that axis's means over the logs (six positions: the mean of ``+`` and
    ``-``). A log whose largest deviation is not clearly larger (3×) than the next
    gets no guess.

    Parameters
    ----------
    means : mapping of str to array of shape (3,)
        Per log name, the mean x, y, z output.
    units : str

    Returns
    -------
    dict of str to str
        Per log name with a clear answer, its orientation.
    """
    table = np.array(list(means.values()), dtype=np.float64).reshape(-1, 3)
    offset = (
        np.zeros(3) if units in ("g", "m/s2") else (table.max(axis=0) + table.min(axis=0)) / 2.0
    )
    guesses = {}
    for name, row in zip(means, table, strict=True):
        dev = row - offset
        order = np.argsort(-np.abs(dev))
        top, second = abs(dev[order[0]]), abs(dev[order[1]])
        if top > 0 and top >= 3.0 * second:
            guesses[name] = f"O{'XYZ'[order[0]]}{'+' if dev[order[0]] > 0 else '-'}"
    return guesses


def guess_columns(header: Sequence[str]) -> dict[str, str]:
    """Find the column of each role (time, temperature, x, y, z) among header names.

    Parameters
    ----------
    header : sequence of str

    Returns
    -------
    dict of str to str
        The roles found, each with its column name.
    """
    found: dict[str, str] = {}
    for role, patterns in COLUMN_PATTERNS.items():
        for pattern in patterns:
            free = [h for h in header if h not in found.values()]
            hit = next((h for h in free if re.fullmatch(pattern, h.strip().lower())), None)
            if hit is not None:
                found[role] = hit
                break
    return found


def _time_unit(column: str) -> str:
    m = re.search(r"(ms|us|ns|usec)$", column.strip().lower())
    return {"usec": "us"}.get(m.group(1), m.group(1)) if m else "s"


def _delimiter(first_line: str) -> str:
    counts = {d: first_line.count(d) for d in (",", "\t", ";")}
    return max(counts, key=lambda d: counts[d])


def _units(means: np.ndarray, values_are_integers: bool) -> str:
    norms = np.linalg.norm(means, axis=1)
    if values_are_integers and np.all(np.abs(means).max(axis=1) > 50):
        return "LSB"
    if np.all((norms > 0.8) & (norms < 1.2)):
        return "g"
    if np.all((norms > 0.8 * STANDARD_GRAVITY) & (norms < 1.2 * STANDARD_GRAVITY)):
        return "m/s2"
    return "V"


def _toml(value: str | float) -> str:
    return repr(float(value)) if isinstance(value, float) else json.dumps(value, ensure_ascii=False)


def _document(
    settings: Mapping[str, str | float], columns: Mapping[str, str], runs: Mapping[str, str]
) -> str:
    lines = [f"format = {_toml(SESSION_FORMAT)}"]
    lines += [f"{k} = {_toml(v)}" for k, v in settings.items()]
    lines += ["", "[columns]"] + [f"{k} = {_toml(v)}" for k, v in columns.items()]
    for file, orientation in runs.items():
        lines += ["", "[[run]]", f"file = {_toml(file)}", f"orientation = {_toml(orientation)}"]
    return "\n".join(lines) + "\n"


def cmd_init(args: argparse.Namespace, out: TextIO) -> int:
    """``accelcore init``: write FOLDER/session.toml from what the logs show."""
    folder = Path(args.folder)
    if not folder.is_dir():
        raise CliDataError(f"{folder}: no such folder")
    target = folder / TOML_NAME
    if target.exists() and not args.force:
        raise UsageError(f"{target} exists; --force writes over it")
    logs = sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in LOG_SUFFIXES)
    if not logs:
        raise CliDataError(f"{folder}: no log files ({', '.join(LOG_SUFFIXES)})")
    guard(logs, [target])
    with logs[0].open(encoding="utf-8", errors="replace") as fh:
        first_line = fh.readline()
    if args.delimiter is not None and args.delimiter not in DELIMITERS:
        raise UsageError(f"--delimiter must be ',', '\\t' or ';', got {args.delimiter!r}")
    delimiter = DELIMITERS[args.delimiter] if args.delimiter else _delimiter(first_line)
    header = [h.strip() for h in first_line.rstrip("\r\n").split(delimiter)]
    columns = guess_columns(header)
    missing = [r for r in _ROLES if r not in columns]
    if missing:
        raise CliDataError(
            f"{logs[0]}: no column recognised as {', '.join(missing)} among {', '.join(header)}"
        )
    time_unit = _time_unit(columns["time"])
    frames: dict[str, pd.DataFrame] = {}
    for log in logs:
        try:
            frames[log.name] = pd.read_csv(log, sep=delimiter, usecols=list(columns.values()))
        except (ValueError, pd.errors.ParserError) as exc:
            raise CliDataError(
                f"{log}: not a log of the same layout as {logs[0].name}: {exc}"
            ) from None
    axes = [columns[a] for a in "xyz"]
    means = {n: f[axes].mean().to_numpy(dtype=np.float64) for n, f in frames.items()}
    integers = all(
        np.array_equal(v, np.round(v)) for v in (f[axes].to_numpy() for f in frames.values())
    )
    units = args.units or _units(np.array(list(means.values())), integers)
    rate = args.rate_hz
    if rate is None:
        t = frames[logs[0].name][columns["time"]].to_numpy(dtype=np.float64)
        t = t * TIME_UNITS[time_unit]
        steps = np.diff(t[np.isfinite(t)])
        steps = steps[steps > 0]
        if steps.size == 0:
            raise CliDataError(f"{logs[0]}: fewer than two time stamps; give --rate-hz")
        rate = float(f"{1.0 / float(np.median(steps)):.6g}")
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
    atomic_write(target, _document(settings, {r: columns[r] for r in _ROLES}, runs))
    shown = {"\t": "tab"}.get(delimiter, delimiter)
    print(f"wrote {target}: {len(runs)} runs", file=out)
    print(f"  units {units}{'' if args.units else ' (guessed from the output size)'}, "
          f"rate {rate:g} Hz{'' if args.rate_hz else ' (median time step)'}, "
          f"delimiter {shown!r}, time unit {time_unit}", file=out)  # fmt: skip
    print("  columns: " + ", ".join(f"{r}={columns[r]}" for r in _ROLES), file=out)
    width = max(len(n) for n in runs)
    for name, orientation in runs.items():
        print(f"  {name:<{width}}  {orientation}  ({how[name]})", file=out)
    if len(set(runs.values())) < len(ORIENTATIONS):
        print(f"  orientations: {' '.join(sorted(set(runs.values())))} (not all six)", file=out)
    return 0
