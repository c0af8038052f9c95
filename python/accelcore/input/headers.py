"""Header names of a delimited log: each must be distinct, or one column would win in silence.

:func:`check_log_header` reads only the first non-blank line of a log, so it
runs before the Rust reader parses the file (which, given a repeated name, would
use the first column of that name). The other readers call
:func:`check_unique_names` on the names they find (a Parquet schema, a TDMS group).

May import: the foundation only.
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path

from accelcore.errors import ParseError

__all__ = ["check_log_header", "check_unique_names", "first_line_fields"]


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


def check_log_header(path: str | Path, separator: str) -> None:
    """Refuse a delimited log whose header repeats a column name (reads one line).

    Parameters
    ----------
    path : str or Path
        The log.
    separator : str
        The field separator.

    Raises
    ------
    accelcore.ParseError
        As :func:`check_unique_names`. A file that cannot be opened is left to
        the reader, whose error names it.
    """
    try:
        names = first_line_fields(path, separator)
    except OSError:
        return
    check_unique_names(str(path), names, header_line=True)
