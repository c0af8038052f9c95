"""Sessions of one log: ``session.toml``'s ``log =`` read by the reader its suffix picks.

A session folder's ``session.toml`` names run files (``[[run]]`` tables, read by
:func:`accelcore.input.session.load_session`) or one log (``log = "chamber.csv"``,
:mod:`accelcore.input.log_format`): a delimited log with an orientation column
(:func:`~accelcore.input.readers.read_orientation_log`), a Parquet file
(:func:`~accelcore.input.readers.read_parquet`) or a TDMS file
(:func:`~accelcore.input.readers.read_tdms`). :func:`load_session` reads either
kind (it is :func:`accelcore.load_session`); the session's settings come from
``session.toml`` (units, rate, sensor, columns, delimiter, time unit, settling
time), so the Session is the one the reader returns for those arguments, with
the session folder, its format and the digests of ``session.toml`` and the log.

A log given alone (no ``session.toml``) is read by :func:`open_log`: through the
``session.toml`` beside it that names it, else from what the file says of itself
(:mod:`accelcore.input.readers.own_settings`).

May import: the foundation and the rest of the input room (:mod:`.format`,
:mod:`.log_format`, :mod:`.session`, :mod:`.readers`); never the opener above it.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from accelcore._accelcore import digest_bytes
from accelcore.errors import AccelcoreIOError, SessionFormatError
from accelcore.input import session as folders
from accelcore.input.cache import CacheSetting
from accelcore.input.format import TOML_NAME, SessionFormat
from accelcore.input.log_format import (
    DELIMITED,
    LOG_LAYOUTS,
    PARQUET,
    TDMS,
    LogSpec,
    log_layout,
)
from accelcore.input.readers.orientation_log import read_orientation_log
from accelcore.input.readers.own_settings import own_settings
from accelcore.input.readers.parquet import read_parquet
from accelcore.input.readers.tdms import read_tdms
from accelcore.input.session import DIGESTS, Session

__all__ = [
    "alone_problem",
    "load_session",
    "open_log",
    "read_log_session",
    "session_naming",
    "what_to_do",
]


def _read(spec: LogSpec, fmt: SessionFormat, **options: Any) -> Session:
    """Call the reader of the log's layout with what ``session.toml`` says."""
    shared: dict[str, Any] = {
        "units": fmt.units,
        "rate_hz": fmt.rate_hz,
        "time_unit": fmt.time_unit,
        "sensor": fmt.sensor,
        "serial": fmt.serial,
        "settle_s": spec.settle_s,
        **options,
    }
    columns = dict(fmt.columns)
    if spec.layout == DELIMITED:
        assert spec.orientation_column is not None  # a delimited log always has one
        return read_orientation_log(
            spec.path,
            orientation_column=spec.orientation_column,
            columns=columns,
            delimiter=fmt.delimiter,
            **shared,
        )
    if spec.layout == PARQUET:
        assert spec.orientation is None or isinstance(spec.orientation, str)
        return read_parquet(
            spec.path,
            orientation=spec.orientation,
            orientation_column=spec.orientation_column,
            columns=columns,
            **shared,
        )
    assert spec.layout == TDMS
    return read_tdms(
        spec.path,
        group=None if spec.groups is None else list(spec.groups),
        channel_map=columns,
        orientation=spec.orientation,
        **shared,
    )


def _state(path: Path) -> tuple[int, int, int, int]:
    st = path.stat()
    return (st.st_size, st.st_mtime_ns, st.st_ino, st.st_dev)


def _log_digest(path: Path, digest: str, before: tuple[int, int, int, int]) -> str:
    """Digest of the log as it was read: refused if the file changed meanwhile.

    The readers read through pyarrow, npTDMS or pandas, so the log is hashed in a
    pass of its own (in one piece: ``digest_bytes`` takes bytes).
    """
    try:
        data = path.read_bytes()
        after = _state(path)
    except OSError as exc:
        raise AccelcoreIOError(f"{path}: cannot be read: {exc.strerror}") from exc
    if after != before:
        raise AccelcoreIOError(f"{path}: changed while the session was read")
    return digest_bytes(data, digest)


def read_log_session(
    fmt: SessionFormat,
    *,
    decimation_factor: int | None = None,
    min_count: int = 1,
    digest: str = DIGESTS[0],
) -> Session:
    """Read the one log a ``session.toml`` names (``fmt.log``) into a Session.

    Parameters
    ----------
    fmt : SessionFormat
        A session that names one log (:attr:`SessionFormat.log` is set).
    decimation_factor, min_count, digest
        As in :func:`load_session`.

    Returns
    -------
    Session
        The reader's session, with :attr:`~Session.path` the session folder,
        :attr:`~Session.format` ``fmt``, the local gravity of ``fmt`` and the
        digests of ``session.toml`` and of the log (keyed as ``log`` names it).
        Each run's ``source`` is the reader's (``LOG#L2-7201``, ``LOG#rows=...``,
        ``LOG#GROUP``).

    Raises
    ------
    accelcore.AccelcoreIOError
        The log changed while it was read.
    """
    spec = fmt.log
    if spec is None:
        raise SessionFormatError(f'{fmt.toml_path}: names no log (log = "FILE")')
    folders.check_load_options(decimation_factor, min_count, digest)
    before = _state(spec.path)
    session = _read(spec, fmt, decimation_factor=decimation_factor, min_count=min_count)
    digests = {
        fmt.toml_path.name: fmt.toml_digest(digest),
        spec.file: _log_digest(spec.path, digest, before),
    }
    return dataclasses.replace(
        session,
        path=str(fmt.folder),
        format=fmt,
        file_digests=digests,
        digest=digest,
        gravity_m_s2=fmt.gravity_m_s2,
    )


def load_session(
    path: str | Path,
    *,
    decimation_factor: int | None = None,
    min_count: int = 1,
    cache: CacheSetting = True,
    digest: str = DIGESTS[0],
) -> Session:
    """Read a session folder: its run files, or the one log its ``session.toml`` names.

    Parameters
    ----------
    path : str or Path
        The session folder (holding ``session.toml``).
    decimation_factor : int, optional
        Raw samples per block; default
        :func:`~accelcore.input.session.default_decimation_factor` of the
        session's ``rate_hz`` (blocks of about 0.5 s).
    min_count : int, default 1
        Blocks with fewer valid raw samples are dropped.
    cache : bool, str or os.PathLike, default True
        The run cache of ``[[run]]`` files (:func:`accelcore.input.session.load_session`).
        A session of one log is read again every time (the cache keeps run files).
    digest : {"blake3", "sha256"}, default "blake3"
        The content digest of every file (:attr:`Session.file_digests`).

    Returns
    -------
    Session

    Raises
    ------
    accelcore.SessionFormatError
        ``session.toml`` is missing or invalid (the message names the file and the
        key), or a log's orientation label is unknown (file, line, column).
    accelcore.ParseError
        A log cannot be parsed; ``.path``, ``.line`` and ``.column`` say where.
    accelcore.AccelcoreIOError
        The folder or a file it names does not exist or cannot be read.
    ImportError
        A Parquet or TDMS log, and pyarrow or npTDMS is not installed (the
        message names the extra).
    """
    folders.check_load_options(decimation_factor, min_count, digest)
    fmt = SessionFormat.read(path)
    if fmt.log is None:
        return folders.load_folder(
            fmt,
            decimation_factor=decimation_factor,
            min_count=min_count,
            cache=cache,
            digest=digest,
        )
    return read_log_session(
        fmt, decimation_factor=decimation_factor, min_count=min_count, digest=digest
    )


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve() or a.samefile(b)
    except OSError:
        return False


def _beside(path: str | Path) -> SessionFormat | None:
    """Read the ``session.toml`` in a log's folder, if there is one (its faults are raised)."""
    folder = Path(path).parent
    if not (folder / TOML_NAME).is_file():
        return None
    return SessionFormat.read(folder, check_files=False)


def session_naming(path: str | Path) -> Path | None:
    """Return the session folder beside a log whose ``session.toml`` names it (``log =``).

    Parameters
    ----------
    path : str or Path
        A single log.

    Returns
    -------
    pathlib.Path or None
        The log's folder, when its ``session.toml`` has ``log =`` this file.

    Raises
    ------
    accelcore.SessionFormatError
        The ``session.toml`` beside the log cannot be read (it is the log's
        settings, so its fault is named rather than passed over).
    """
    fmt = _beside(path)
    if fmt is not None and fmt.log is not None and _same_file(fmt.log.path, Path(path)):
        return fmt.folder
    return None


def alone_problem(path: str | Path) -> str | None:
    """Say in one line why a log given alone cannot be read, and what to do; None if it can.

    Parameters
    ----------
    path : str or Path
        A single log.

    Returns
    -------
    str or None
        A run file of the session beside it (give the folder), or a log that does
        not state what reading it needs (:func:`what_to_do`); None when a
        ``session.toml`` beside it names it, or the file states enough.

    Raises
    ------
    accelcore.SessionFormatError, accelcore.ParseError, ImportError
        As :func:`session_naming` and
        :func:`~accelcore.input.readers.own_settings.own_settings`.
    """
    fmt = _beside(path)
    if fmt is not None and fmt.log is not None and _same_file(fmt.log.path, Path(path)):
        return None
    if fmt is not None and any(_same_file(f, Path(path)) for f in fmt.run_files):
        return (
            f"{path}: a run file of the session {fmt.folder} (its session.toml names it); "
            f"give the session folder {fmt.folder}"
        )
    settings = own_settings(path)
    return what_to_do(path, settings) if isinstance(settings, str) else None


def what_to_do(path: str | Path, why: str) -> str:
    """Say, in one line, why a log alone cannot be read and how to give its settings.

    Parameters
    ----------
    path : str or Path
        The log.
    why : str
        What is missing (``"a delimited log does not say its units or rate"``).

    Returns
    -------
    str
    """
    name = Path(path).name
    return (
        f"{path}: {why}; run 'accelcore init {path}' (writes a session.toml beside it from "
        f'what the log shows) or write a session.toml with log = "{name}" '
        "(docs/session-format.md)"
    )


def open_log(
    path: str | Path,
    *,
    decimation_factor: int | None = None,
    min_count: int = 1,
    cache: CacheSetting = True,
    digest: str = DIGESTS[0],
) -> Session:
    """Read a log given alone: through the ``session.toml`` that names it, else by itself.

    Parameters
    ----------
    path : str or Path
        A ``.csv``, ``.txt``, ``.tsv``, ``.dat``, ``.parquet`` or ``.tdms`` log.
    decimation_factor, min_count, cache, digest
        As in :func:`load_session`.

    Returns
    -------
    Session
        The session of the folder beside the log when its ``session.toml`` names
        it (``log =``); else the reader's session with the settings the file
        states (:func:`~accelcore.input.readers.own_settings.own_settings`) and
        the defaults of everything else (``path`` None, no digests, as a flight log).

    Raises
    ------
    accelcore.SessionFormatError
        The file does not say what reading it needs, or is a run file of the session
        beside it (one line: :func:`alone_problem`), or it is not a single log.
    """
    folders.check_load_options(decimation_factor, min_count, digest)
    layout = log_layout(path)
    if layout is None:
        raise SessionFormatError(f"{path}: not a single log ({', '.join(LOG_LAYOUTS)})")
    folder = session_naming(path)
    if folder is not None:
        return load_session(
            folder,
            decimation_factor=decimation_factor,
            min_count=min_count,
            cache=cache,
            digest=digest,
        )
    problem = alone_problem(path)
    if problem is not None:
        raise SessionFormatError(problem)
    settings = own_settings(path)
    if isinstance(settings, str):  # the file changed since alone_problem read it
        raise SessionFormatError(what_to_do(path, settings))
    options = {"decimation_factor": decimation_factor, "min_count": min_count, **settings}
    if layout == PARQUET:
        return read_parquet(path, **options)
    return read_tdms(path, **options)
