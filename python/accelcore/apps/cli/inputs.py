"""What every command does with its inputs before reading them: resolve, guard, open.

A command that takes a session takes a session folder, a single log (``.csv``,
``.parquet``, ``.tdms`` ...) or a flight log (PX4 ``.ulg``, ArduPilot ``.bin``;
:mod:`accelcore.input.readers.opener` owns which is which and how each is
opened). Before anything is read, :func:`guard` refuses an output that would
overwrite an input, and :func:`need` / :func:`open_session` turn a missing
optional dependency, or a log that does not say what reading it needs, into one
usage line saying what to do.

Part of the applications room.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterable
from pathlib import Path
from types import ModuleType
from typing import Any

from accelcore.errors import AccelcoreIOError, OutputConflictError
from accelcore.files import check_outputs
from accelcore.input.readers.opener import (
    input_files,
    input_problem,
    is_flight_log,
    is_single_log,
    open_input,
)
from accelcore.input.session import Session

__all__ = [
    "CliDataError",
    "UsageError",
    "guard",
    "guard_bulk",
    "need",
    "open_session",
    "session_inputs",
]


class CliDataError(Exception):
    """A data problem the command line found itself (exit status 1)."""


class UsageError(Exception):
    """A usage problem found after parsing (exit status 2)."""


def need(module: str, extra: str, what: str) -> ModuleType:
    """Import an optional dependency, or raise a :class:`UsageError` naming the extra.

    Parameters
    ----------
    module : str
        The module to import (``"pyarrow.parquet"``).
    extra : str
        The extra that installs it (``"parquet"``).
    what : str
        What needs it, for the message (``"fleet.parquet"``).

    Returns
    -------
    types.ModuleType
    """
    try:
        return importlib.import_module(module)
    except ImportError:
        package = module.split(".")[0]
        raise UsageError(f"{what} needs {package}: pip install accelcore[{extra}]") from None


def session_inputs(path: str | Path) -> tuple[Path, ...]:
    """Files a command reads from a session argument (a folder, or one flight log)."""
    return input_files(path)


def open_session(path: str | Path, *, cache: bool, instance: int = 0, **options: Any) -> Session:
    """Open a session folder, a single log, or IMU ``instance`` of a PX4 / ArduPilot log.

    ``options`` go to the reader (``decimation_factor``, ...).

    Raises
    ------
    UsageError
        ``--instance`` given for anything but a flight log; the reader is not
        installed (the message names the extra); a file that is no session; a
        single log that does not state its settings, with no ``session.toml``
        naming it (the message says what to do:
        :func:`~accelcore.input.readers.opener.input_problem`).
    accelcore.ParameterError
        The log has no such instance (the message names the file and the
        instances it holds).
    """
    if not is_flight_log(path) and instance != 0:
        what = "a single log" if is_single_log(path) else "a session folder"
        raise UsageError(f"--instance applies to flight logs (.ulg, .bin); {path} is {what}")
    problem = input_problem(path)
    if problem is not None:
        raise UsageError(problem)
    if not is_flight_log(path):
        return open_input(path, cache=cache, **options)
    return open_input(path, instance=instance, **options)


def guard(inputs: Iterable[str | Path], outputs: Iterable[str | Path | None]) -> None:
    """Before reading anything: no output may alias an input, and every output's folder exists.

    Raises :class:`accelcore.errors.OutputConflictError` (exit status 2) or an
    :class:`accelcore.AccelcoreIOError` naming the output (exit status 1).
    """
    wanted = [o for o in outputs if o is not None and str(o) != "-"]
    check_outputs(inputs, wanted)
    # Two outputs onto one file: the second would replace the first (--save o.json
    # --json o.json left the JSON document where the calibration was said to be saved).
    for i, o in enumerate(wanted):
        for other in wanted[:i]:
            if Path(o).resolve() == Path(other).resolve():
                conflict = OutputConflictError(
                    f"two outputs name one file, {other} and {o}: each needs its own"
                )
                conflict.output, conflict.input = str(o), str(other)
                raise conflict
    for o in wanted:
        folder = Path(o).parent
        if not folder.is_dir():
            err = AccelcoreIOError(f"{o}: cannot write the output: folder {folder} does not exist")
            err.path = str(o)
            raise err


def guard_bulk(archive: Path, output: Path) -> None:
    """Refuse a bulk output folder that is the archive or a session folder."""
    same = output.resolve() == archive.resolve()
    if not same and output.exists() and archive.exists():
        same = output.samefile(archive)
    if same or (output / "session.toml").is_file():
        what = "the archive" if same else "a session folder (it holds session.toml)"
        err = OutputConflictError(
            f"output {output} is {what}; bulk would write its results among the "
            f"sessions of {archive}: choose another output folder"
        )
        err.output, err.input = str(output), str(archive)
        raise err
