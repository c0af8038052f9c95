"""Header names of a log: each must be distinct, or one column would win in silence.

The Rust reader behind :func:`accelcore.load_session` refuses a repeated name
itself. The readers written in Python call :func:`check_unique_names` on the
names they find (an orientation log's first line, read by
:func:`first_line_fields`, a Parquet schema, a TDMS group).

May import: the foundation only.
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path

from accelcore.errors import ParseError

__all__ = ["check_unique_names", "first_line_fields"]


def first_line_fields(path: str | Path, separator: str) -> list[str]:
    """Return the fields of the first non-blank line, as written (no renaming of repeats).

    Parameters
    ----------
    path : str or Path
        A delimited text log.
    separator : str
        The field separator.

    Returns
    -------
    list of str
        Stripped names; empty for an empty file.
    """
    with open(path, encoding="utf-8-sig", errors="replace", newline="") as fh:
        for line in fh:
            if line.strip():
                return [f.strip() for f in next(csv.reader([line], delimiter=separator))]
    return []


def check_unique_names(path: str, names: Sequence[str], *, header_line: bool) -> None:
    """Refuse a repeated column name.

    Parameters
    ----------
    path : str
        What the message names (a file, or a file and a group).
    names : sequence of str
        Column names in order.
    header_line : bool
        The names are line 1 of a text log (the message then says ``path:1:COL``).

    Raises
    ------
    accelcore.ParseError
        A name appears twice; ``.column`` is the 1-based position of the repeat.
    """
    seen: dict[str, int] = {}
    for i, name in enumerate(names):
        if name in seen:
            where = f"{path}:1:{i + 1}" if header_line else path
            err = ParseError(
                f"{where}: column name {name!r} appears twice in the header (columns "
                f"{seen[name] + 1} and {i + 1}); every column needs a distinct name"
            )
            err.path, err.line, err.column = path, 1, i + 1
            raise err
        seen[name] = i
