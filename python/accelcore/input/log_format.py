"""The keys of a ``session.toml`` that names one log (``log = "chamber.parquet"``).

A session is a folder of run files (``[[run]]`` tables), or one log whose layout
its suffix says: a delimited log with an orientation column (``.csv``, ``.txt``,
``.tsv``, ``.dat``), a Parquet file (``.parquet``) or an NI TDMS file (``.tdms``).
This module checks the keys only such a session has, and which keys each layout
takes (a key that does not apply is an error naming it, never ignored);
:class:`~accelcore.input.format.SessionFormat` keeps the result as its ``log``,
and :mod:`accelcore.input.single_log` reads the log. See ``docs/session-format.md``.

May import: the foundation only.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

from accelcore.constants import ORIENTATIONS
from accelcore.errors import SessionFormatError

__all__ = [
    "DELIMITED",
    "LOG_KEYS",
    "LOG_LAYOUTS",
    "ORIENTATION_COLUMN",
    "PARQUET",
    "TDMS",
    "LogSpec",
    "log_layout",
    "read_log_keys",
    "run_columns",
]

#: The layouts of a single log, by name (as :attr:`LogSpec.layout` holds them).
DELIMITED = "delimited log with an orientation column"
PARQUET = "Parquet"
TDMS = "TDMS"

#: Layout of a single log by file suffix (lower case).
LOG_LAYOUTS: Mapping[str, str] = MappingProxyType(
    {
        ".csv": DELIMITED,
        ".txt": DELIMITED,
        ".tsv": DELIMITED,
        ".dat": DELIMITED,
        ".parquet": PARQUET,
        ".tdms": TDMS,
    }
)

#: Top-level keys of a session that names one log (and of no other session).
LOG_KEYS = ("log", "orientation", "group", "settle_s")

#: The label column's default name (``[columns] orientation``).
ORIENTATION_COLUMN = "orientation"


@dataclass(frozen=True)
class LogSpec:
    """What ``session.toml`` says of the one log it names.

    Attributes
    ----------
    file : str
        The ``log`` key as written (relative to the session folder).
    path : pathlib.Path
        The log: the session folder joined with ``file``.
    layout : str
        :data:`DELIMITED`, :data:`PARQUET` or :data:`TDMS`, from the suffix.
    orientation_column : str or None
        The label column (``[columns] orientation``; default ``orientation``), or
        None: a Parquet file of one orientation, or a TDMS file.
    orientation : str, mapping of str to str, or None
        ``orientation =``: a Parquet file's one orientation; a TDMS file's
        orientation of every group, or of each group by name; None: the column,
        or each TDMS group's ``orientation`` property.
    groups : tuple of str or None
        ``group =``: the TDMS groups read, in order; None: every group holding
        the channels.
    settle_s : float
        Seconds dropped at the start of every run (the positioner settling).
    """

    file: str
    path: Path
    layout: str
    orientation_column: str | None = None
    orientation: str | Mapping[str, str] | None = None
    groups: tuple[str, ...] | None = None
    settle_s: float = 0.0


def log_layout(path: str | os.PathLike[str]) -> str | None:
    """Return the layout a single log's suffix names, or None for any other file.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    str or None
        :data:`DELIMITED`, :data:`PARQUET` or :data:`TDMS`.
    """
    return LOG_LAYOUTS.get(Path(path).suffix.lower())


def run_columns(given: object) -> object:
    """Return the ``[columns]`` table without its ``orientation`` key (checked here).

    Parameters
    ----------
    given : object
        The ``[columns]`` table as parsed (anything: the caller checks its type).

    Returns
    -------
    object
        The roles of a run file's columns only.
    """
    if isinstance(given, dict):
        return {k: v for k, v in given.items() if k != "orientation"}
    return given


def _label(value: object, where: str, key: str) -> str:
    text = value.strip().upper() if isinstance(value, str) else None
    if text not in ORIENTATIONS:
        raise SessionFormatError(
            f"{where}: {key} = {value!r} is not an orientation; expected one of "
            f"{', '.join(ORIENTATIONS)}"
        )
    return str(text)


def _not_here(where: str, key: str, layout: str, why: str) -> SessionFormatError:
    return SessionFormatError(f"{where}: key '{key}' does not apply to a {layout} log: {why}")


def read_log_keys(meta: Mapping[str, Any], folder: Path, where: str) -> LogSpec | None:
    """Check the keys of a session that names one log; None for a session of ``[[run]]`` tables.

    Parameters
    ----------
    meta : mapping
        The parsed ``session.toml``.
    folder : Path
        The session folder (``log`` is relative to it).
    where : str
        The ``session.toml`` file, for messages.

    Returns
    -------
    LogSpec or None

    Raises
    ------
    accelcore.SessionFormatError
        Both ``log`` and ``[[run]]``; a suffix that names no layout; a key that does
        not apply (to ``[[run]]`` tables, or to this layout); a bad value. The
        message names the file and the key.
    """
    columns = meta.get("columns", {})
    named_column = columns.get("orientation") if isinstance(columns, dict) else None
    if "log" not in meta:
        for key in LOG_KEYS[1:]:
            if key in meta:
                raise SessionFormatError(
                    f"{where}: key '{key}' applies to a session that names one log "
                    '(log = "FILE"), not to [[run]] tables'
                )
        if named_column is not None:
            raise SessionFormatError(
                f"{where}: [columns] orientation applies to a session that names one log "
                '(log = "FILE"); a [[run]] table says its orientation'
            )
        return None
    file = meta["log"]
    if "run" in meta:
        raise SessionFormatError(
            f"{where}: both log = and [[run]] tables; a session is one log or a set of runs"
        )
    if not isinstance(file, str) or not file.strip():
        raise SessionFormatError(f"{where}: log must name a file, got {file!r}")
    layout = log_layout(file)
    if layout is None:
        raise SessionFormatError(
            f"{where}: log = {file!r}: unknown suffix {Path(file).suffix or '(none)'!r}; "
            f"a single log is one of {', '.join(LOG_LAYOUTS)} (delimited with an orientation "
            "column, Parquet, TDMS)"
        )
    if "delimiter" in meta and layout != DELIMITED:
        raise _not_here(where, "delimiter", layout, "it has no delimiter")
    if named_column is not None and not (isinstance(named_column, str) and named_column.strip()):
        raise SessionFormatError(f"{where}: [columns] orientation must name a column")
    given = meta.get("orientation")
    column: str | None = named_column or ORIENTATION_COLUMN
    orientation: str | dict[str, str] | None = None
    if layout == DELIMITED and given is not None:
        why = "the orientation column says it ([columns] orientation)"
        raise _not_here(where, "orientation", layout, why)
    if layout == PARQUET and given is not None:
        if named_column is not None:
            raise SessionFormatError(
                f"{where}: give orientation = (one for the whole file) or [columns] "
                "orientation (a column of labels), not both"
            )
        orientation, column = _label(given, where, "orientation"), None
    if layout == TDMS:
        if named_column is not None:
            why = "each group's orientation property, or orientation =, says it"
            raise _not_here(where, "[columns] orientation", layout, why)
        column = None
        if isinstance(given, dict):
            orientation = {str(g): _label(v, where, f"orientation.{g}") for g, v in given.items()}
        elif given is not None:
            orientation = _label(given, where, "orientation")
    groups = meta.get("group")
    if groups is not None:
        if layout != TDMS:
            raise _not_here(where, "group", layout, "only a TDMS file has groups")
        groups = [groups] if isinstance(groups, str) else groups
        if (
            not isinstance(groups, list)
            or not groups
            or not all(isinstance(g, str) for g in groups)
        ):
            raise SessionFormatError(f"{where}: group must be a group name or a list of names")
    settle = meta.get("settle_s", 0.0)
    if (
        isinstance(settle, bool)
        or not isinstance(settle, (int, float))
        or not math.isfinite(settle)
        or settle < 0
    ):
        raise SessionFormatError(
            f"{where}: settle_s must be a number of seconds >= 0, got {settle!r}"
        )
    return LogSpec(
        file=file,
        path=folder / file,
        layout=layout,
        orientation_column=column,
        orientation=MappingProxyType(orientation) if isinstance(orientation, dict) else orientation,
        groups=None if groups is None else tuple(groups),
        settle_s=float(settle),
    )
