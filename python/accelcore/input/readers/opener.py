"""One way in for every command that takes a session: a session folder, a single log, a flight log.

A path is

- a *flight log* when it is a file ending in ``.ulg`` (PX4 ULog, read by
  :func:`~accelcore.input.readers.read_ulog`) or ``.bin`` (ArduPilot DataFlash,
  read by :func:`~accelcore.input.readers.read_dataflash`);
- a *single log* when it is a file ending in ``.csv``, ``.txt``, ``.tsv``, ``.dat``
  (delimited, with an orientation column), ``.parquet`` or ``.tdms``
  (:data:`accelcore.input.log_format.LOG_LAYOUTS`), read through the
  ``session.toml`` beside it that names it, else with the settings the file
  states (:func:`accelcore.input.single_log.open_log`);
- else a session folder, read by :func:`accelcore.load_session` (its run files,
  or the one log its ``session.toml`` names).

The command line and ``bulk`` both open their inputs here, so a new kind of log is
added in one place; :func:`input_problem` says in one line what stands in the way
before anything is read.

May import: the foundation, :mod:`accelcore.input.session`,
:mod:`accelcore.input.single_log` and the rest of :mod:`accelcore.input.readers`.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from accelcore.errors import AccelcoreError
from accelcore.input.cache import CacheSetting
from accelcore.input.format import TOML_NAME, SessionFormat
from accelcore.input.log_format import LOG_LAYOUTS, PARQUET, TDMS, log_layout
from accelcore.input.readers.dataflash import read_dataflash
from accelcore.input.readers.ulog import read_ulog
from accelcore.input.session import Session
from accelcore.input.single_log import alone_problem, load_session, open_log, session_naming

__all__ = [
    "FLIGHT_LOGS",
    "FlightLogKind",
    "input_files",
    "input_problem",
    "is_flight_log",
    "is_session_input",
    "is_single_log",
    "missing_extra",
    "open_input",
]


@dataclass(frozen=True)
class FlightLogKind:
    """A kind of flight log: its reader and the optional dependency the reader needs."""

    name: str
    read: Callable[..., Session]
    module: str
    extra: str


#: Flight logs taken in place of a session folder, by file suffix (lower case).
FLIGHT_LOGS: dict[str, FlightLogKind] = {
    ".ulg": FlightLogKind("PX4 ULog", read_ulog, "pyulog", "px4"),
    ".bin": FlightLogKind("ArduPilot DataFlash", read_dataflash, "pymavlink.DFReader", "ardupilot"),
}


def is_flight_log(path: str | Path) -> bool:
    """Return True when ``path`` names a flight log (a ``.ulg`` or ``.bin`` file, not a folder).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    bool
    """
    p = Path(path)
    return p.suffix.lower() in FLIGHT_LOGS and not p.is_dir()


def is_single_log(path: str | Path) -> bool:
    """Return True when ``path`` names a single log (``.csv``, ``.parquet``, ``.tdms`` ...).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    bool
        A path ending in a suffix of :data:`~accelcore.input.log_format.LOG_LAYOUTS`
        that is not a folder.
    """
    return log_layout(path) is not None and not Path(path).is_dir()


def is_session_input(path: str | Path) -> bool:
    """Return True when ``path`` is a session: a folder holding ``session.toml``, or a log.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    bool
    """
    return (Path(path) / TOML_NAME).is_file() or is_flight_log(path) or is_single_log(path)


def input_files(path: str | Path) -> tuple[Path, ...]:
    """Return the files read from a session argument (for the output checks).

    Parameters
    ----------
    path : str or Path
        A session folder, a single log or a flight log.

    Returns
    -------
    tuple of pathlib.Path
        The log itself (and the ``session.toml`` that names it, if any), or
        ``session.toml`` and the run files (or the one log) it names.
    """
    if is_flight_log(path):
        return (Path(path),)
    if is_single_log(path):
        try:
            folder = session_naming(path)
        except (AccelcoreError, OSError):
            folder = None  # the read fails later, before anything is written
        return (Path(path),) if folder is None else SessionFormat.input_files(folder)
    return SessionFormat.input_files(path)


def missing_extra(path: str | Path) -> str | None:
    """Say what to install when ``path`` is a flight log whose reader's dependency is absent.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    str or None
        One line naming the extra (``reading LOG.ulg (PX4 ULog) needs pyulog: pip
        install accelcore[px4]``), or None when nothing is missing.
    """
    if is_flight_log(path):
        kind = FLIGHT_LOGS[Path(path).suffix.lower()]
        name, module, extra = kind.name, kind.module, kind.extra
    elif is_single_log(path) and log_layout(path) in _LOG_EXTRAS:
        name = str(log_layout(path))
        module, extra = _LOG_EXTRAS[name]
    else:
        return None
    try:
        found = importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):  # a module set to None in sys.modules
        found = False
    if found:
        return None
    package = module.split(".")[0]
    return f"reading {path} ({name}) needs {package}: pip install accelcore[{extra}]"


#: The optional dependency (module, extra) of the single logs that need one.
_LOG_EXTRAS = {PARQUET: ("pyarrow.parquet", "parquet"), TDMS: ("nptdms", "tdms")}


def input_problem(path: str | Path) -> str | None:
    """Say in one line what stands in the way of reading a session argument, before reading it.

    Parameters
    ----------
    path : str or Path
        What a command was given as its session.

    Returns
    -------
    str or None
        The reader's missing dependency (:func:`missing_extra`); a file that is
        neither a log accelcore reads nor a session folder; a single log that
        does not state what reading it needs, with no ``session.toml`` naming it
        (what to do: ``accelcore init FILE``, or a ``session.toml`` with ``log =``),
        or that is a run file of the session beside it
        (:func:`~accelcore.input.single_log.alone_problem`).
        None when nothing is known to stand in the way (a folder: its errors come
        from reading it).
    """
    missing = missing_extra(path)
    if missing is not None:
        return missing
    p = Path(path)
    if p.exists() and not p.is_dir() and not is_flight_log(p) and not is_single_log(p):
        known = ", ".join([*LOG_LAYOUTS, *FLIGHT_LOGS])
        return (
            f"{path}: not a session folder, nor a log accelcore reads ({known}); "
            "a session is a folder holding session.toml, or one of those logs"
        )
    if not is_single_log(p) or not p.is_file():
        return None
    try:
        return alone_problem(p)
    except (AccelcoreError, ImportError, OSError):
        return None  # reading it says what is wrong, naming the file


def open_input(
    path: str | Path, *, instance: int = 0, cache: CacheSetting = True, **options: Any
) -> Session:
    """Open a session folder, a single log, or one IMU instance of a flight log.

    Parameters
    ----------
    path : str or Path
        A session folder (holding ``session.toml``), a single log (``.csv``,
        ``.txt``, ``.tsv``, ``.dat``, ``.parquet``, ``.tdms``: :func:`open_log`),
        a PX4 ``.ulg`` or an ArduPilot ``.bin`` log.
    instance : int, default 0
        The IMU instance of a flight log (ignored for the others).
    cache : bool, str or os.PathLike, default True
        The run cache of a session folder's run files, as in
        :func:`accelcore.load_session` (logs are not cached).
    **options
        Passed to the reader (``decimation_factor``, ``min_count``, ...).

    Returns
    -------
    Session

    Raises
    ------
    accelcore.ParameterError
        The flight log has no instance ``instance`` (the message names the file
        and the instances it holds).
    """
    if is_flight_log(path):
        kind = FLIGHT_LOGS[Path(path).suffix.lower()]
        return kind.read(path, instance=instance, **options)
    if is_single_log(path):
        return open_log(path, cache=cache, **options)
    return load_session(path, cache=cache, **options)
