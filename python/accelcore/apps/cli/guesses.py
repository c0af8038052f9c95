"""What ``accelcore init`` guesses from a log: columns, time unit, delimiter, units, orientation.

Shared by the folder of logs (:mod:`accelcore.apps.cli.init`) and the single log
(:mod:`accelcore.apps.cli.init_log`); every guess is printed by the command that
makes it.

Part of the applications room.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from accelcore.constants import ORIENTATIONS, STANDARD_GRAVITY

__all__ = [
    "COLUMN_PATTERNS",
    "ROLES",
    "delimiter_of",
    "guess_columns",
    "label_column",
    "orientation_from_means",
    "orientation_from_name",
    "rate_of",
    "toml_value",
    "units_of",
]

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

#: The roles of a log's columns, in the order session.toml lists them.
ROLES = ("time", "temperature", "x", "y", "z")
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


def time_unit_of(column: str) -> str:
    """Return the time unit a time column's name ends in (``t_ms``: ``ms``); default ``s``."""
    m = re.search(r"(ms|us|ns|usec)$", column.strip().lower())
    return {"usec": "us"}.get(m.group(1), m.group(1)) if m else "s"


def delimiter_of(first_line: str) -> str:
    """Return the most frequent of comma, tab and semicolon in a header line."""
    counts = {d: first_line.count(d) for d in (",", "\t", ";")}
    return max(counts, key=lambda d: counts[d])


def units_of(means: np.ndarray, values_are_integers: bool) -> str:
    """Guess the units from the mean output of each run (rows): LSB, g, m/s2, else V."""
    norms = np.linalg.norm(means, axis=1)
    if values_are_integers and np.all(np.abs(means).max(axis=1) > 50):
        return "LSB"
    if np.all((norms > 0.8) & (norms < 1.2)):
        return "g"
    if np.all((norms > 0.8 * STANDARD_GRAVITY) & (norms < 1.2 * STANDARD_GRAVITY)):
        return "m/s2"
    return "V"


def toml_value(value: str | float) -> str:
    """Write a string or a number as a TOML value."""
    return repr(float(value)) if isinstance(value, float) else json.dumps(value, ensure_ascii=False)


def rate_of(seconds: np.ndarray) -> float | None:
    """Return the rate of the median step between time stamps (6 significant digits), or None.

    Parameters
    ----------
    seconds : ndarray
        Time stamps, s (steps that are not positive, e.g. where a run restarts, are
        left out).

    Returns
    -------
    float or None
        None with fewer than two increasing time stamps.
    """
    t = np.asarray(seconds, dtype=np.float64)
    steps = np.diff(t[np.isfinite(t)])
    steps = steps[steps > 0]
    if steps.size == 0:
        return None
    return float(f"{1.0 / float(np.median(steps)):.6g}")


def label_column(samples: Mapping[str, Sequence[Any]]) -> str | None:
    """Return the first column whose values are all orientation labels (``OX+`` ... ``OZ-``).

    Parameters
    ----------
    samples : mapping of str to sequence
        Per column name (in the log's order), a sample of its values; blank
        and missing values are passed over.

    Returns
    -------
    str or None
        The label column, or None when no column holds only labels.
    """
    for name, values in samples.items():
        texts = [str(v).strip().upper() for v in values if v is not None and v == v]
        texts = [t for t in texts if t]
        if texts and all(t in ORIENTATIONS for t in texts):
            return name
    return None
