"""One way in for every command that takes a session: a session folder or a flight log.

A path is a *flight log* when it is a file ending in ``.ulg`` (PX4 ULog, read by
:func:`~accelcore.input.readers.read_ulog`) or ``.bin`` (ArduPilot DataFlash, read by
:func:`~accelcore.input.readers.read_dataflash`); anything else is a session folder
read by :func:`accelcore.load_session`. The command line and ``bulk`` both open
their inputs here, so a new kind of log is added in one place.

May import: the foundation, :mod:`accelcore.input.session` and the rest of
:mod:`accelcore.input.readers`.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from accelcore.input.cache import CacheSetting
from accelcore.input.format import SessionFormat
from accelcore.input.readers.dataflash import read_dataflash
from accelcore.input.readers.ulog import read_ulog
from accelcore.input.session import Session, load_session

__all__ = [
    "FLIGHT_LOGS",
    "FlightLogKind",
    "input_files",
    "is_flight_log",
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


def input_files(path: str | Path) -> tuple[Path, ...]:
    """Return the files read from a session argument (for the output checks).

    Parameters
    ----------
    path : str or Path
        A session folder or a flight log.

    Returns
    -------
    tuple of pathlib.Path
        The flight log itself, or ``session.toml`` and the run files it names.
    """
    return (Path(path),) if is_flight_log(path) else SessionFormat.input_files(path)


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
    if not is_flight_log(path):
        return None
    kind = FLIGHT_LOGS[Path(path).suffix.lower()]
    try:
        found = importlib.util.find_spec(kind.module) is not None
    except (ImportError, ValueError):  # a module set to None in sys.modules
        found = False
    if found:
        return None
    package = kind.module.split(".")[0]
    return f"reading {path} ({kind.name}) needs {package}: pip install accelcore[{kind.extra}]"


def open_input(
    path: str | Path, *, instance: int = 0, cache: CacheSetting = True, **options: Any
) -> Session:
    """Open a session folder, or one IMU instance of a flight log.

    Parameters
    ----------
    path : str or Path
        A session folder (holding ``session.toml``), a PX4 ``.ulg`` or an ArduPilot
        ``.bin`` log.
    instance : int, default 0
        The IMU instance of a flight log (ignored for a session folder).
    cache : bool, str or os.PathLike, default True
        The run cache of a session folder, as in :func:`accelcore.load_session`
        (flight logs are not cached).
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
    return load_session(path, cache=cache, **options)
