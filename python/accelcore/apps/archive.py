"""An archive of sessions for bulk: which sessions it holds, and what bulk writes beside them.

:func:`find_sessions` lists the sessions under an archive folder; :func:`guard_outputs`
refuses a bulk whose outputs would write over any file a session reads;
:func:`input_mtime` is what the up-to-date check compares its outputs with.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from accelcore.errors import AccelcoreError
from accelcore.files import check_outputs
from accelcore.input.format import SessionFormat
from accelcore.input.readers.opener import FLIGHT_LOGS, is_flight_log

__all__ = [
    "CALIBRATION_FILE",
    "DIAGNOSIS_FILE",
    "FAILURES_CSV",
    "FLEET_CSV",
    "FLEET_PARQUET",
    "SESSION_OUTPUTS",
    "TABLE_OUTPUTS",
    "find_sessions",
    "guard_outputs",
    "input_mtime",
]


def find_sessions(archive: str | Path) -> list[str]:
    """Return every session under ``archive`` (any depth), relative and sorted.

    A session is a folder holding ``session.toml``, or a flight log (a PX4
    ``.ulg`` or ArduPilot ``.bin`` file) that lies outside every session folder.
    """
    root = Path(archive)
    if not root.is_dir():
        raise FileNotFoundError(f"{root}: no such archive folder")
    folders = {p.parent for p in root.rglob("session.toml") if p.is_file()}
    logs = {
        p
        for p in root.rglob("*")
        if p.suffix.lower() in FLIGHT_LOGS
        and is_flight_log(p)
        and not any(d in folders for d in p.parents)
    }
    return sorted(p.relative_to(root).as_posix() for p in folders | logs)


#: What bulk writes for each session, in ``OUT/<relative path>/``.
CALIBRATION_FILE, DIAGNOSIS_FILE = "calibration.json", "diagnosis.json"
SESSION_OUTPUTS = (CALIBRATION_FILE, DIAGNOSIS_FILE)

#: What bulk writes in ``OUT``.
FLEET_CSV, FAILURES_CSV, FLEET_PARQUET = "fleet.csv", "failures.csv", "fleet.parquet"
TABLE_OUTPUTS = (FLEET_CSV, FAILURES_CSV, FLEET_PARQUET)


def guard_outputs(archive: Path, sessions: Sequence[str], out: Path) -> None:
    """Refuse a bulk whose outputs would write over any file a session reads.

    Every output (each session's ``calibration.json`` and ``diagnosis.json``, the
    fleet tables) is checked against every session's inputs (``session.toml`` and the
    files it names, wherever they lie; a flight log) before anything is read or
    written, by :func:`accelcore.files.check_outputs`: an output folder inside the
    archive that holds sessions of its own (``bulk arch -o arch/p`` with ``arch/a`` and
    ``arch/p/a``) would put ``a``'s results over ``p/a``'s files.

    Raises
    ------
    accelcore.errors.OutputConflictError
        An output is, or links to, an input.
    """
    inputs: list[Path] = []
    for rel in sessions:
        path = archive / rel
        inputs += [path] if is_flight_log(path) else list(SessionFormat.input_files(path))
    outputs = [out / rel / name for rel in sessions for name in SESSION_OUTPUTS]
    check_outputs(inputs, [*outputs, *(out / name for name in TABLE_OUTPUTS)])


def input_mtime(session_dir: Path) -> float:
    """Newest modification time of session.toml and every file it names (or of the flight log)."""
    if is_flight_log(session_dir):
        return session_dir.stat().st_mtime
    newest = (session_dir / "session.toml").stat().st_mtime
    try:
        files = SessionFormat.read(session_dir, check_files=False).run_files
    except (AccelcoreError, OSError):
        return newest  # the session fails at load and is reported there
    for f in files:
        if f.is_file():
            newest = max(newest, f.stat().st_mtime)
    return newest
