"""The session format: ``session.toml`` read and validated once, into a :class:`SessionFormat`.

This module is the one owner of ``session.toml`` (format ``accelcore-session/1``,
see ``docs/session-format.md``). :func:`accelcore.load_session` keeps what it
read on :attr:`accelcore.Session.format`; every other room (the CLI, plots,
bulk) takes the settings from there, or calls :meth:`SessionFormat.read`,
instead of parsing the TOML again.

May import: the foundation only (:mod:`accelcore.constants`, :mod:`accelcore.errors`,
:mod:`accelcore.files`).
"""

from __future__ import annotations

import difflib
import hashlib
import math
import os
import stat
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from accelcore._accelcore import digest_bytes
from accelcore.constants import (
    DEFAULT_COLUMNS,
    DELIMITERS,
    ORIENTATIONS,
    SAMPLE_TIME_UNIT,
    SESSION_FORMAT,
    STANDARD_GRAVITY,
    TIME_UNITS,
    UNITS,
)
from accelcore.errors import AccelcoreIOError, SessionFormatError
from accelcore.files import check_input_file, file_kind
from accelcore.input.log_format import LOG_KEYS, LogSpec, read_log_keys, run_columns

__all__ = [
    "TOML_NAME",
    "RunSpec",
    "SessionFormat",
    "check_distinct_columns",
    "check_units",
    "gravity_of",
]

#: Name of the settings file of a session folder.
TOML_NAME = "session.toml"
#: A session.toml is a few kB; a larger file is not read (a 2 GB sparse file would be).
MAX_TOML_BYTES = 16 << 20


def gravity_of(orientation: str) -> NDArray[np.float64]:
    """Return the gravity vector in g that an orientation label implies.

    Parameters
    ----------
    orientation : str
        One of ``OX+ OX- OY+ OY- OZ+ OZ-`` (case-insensitive).

    Returns
    -------
    ndarray of float64, shape (3,)
        Gravity on x, y, z in g.

    Raises
    ------
    accelcore.SessionFormatError
        An unknown label.
    """
    key = orientation.strip().upper()
    if key not in ORIENTATIONS:
        raise SessionFormatError(
            f"unknown orientation {orientation!r}; expected one of {', '.join(ORIENTATIONS)}"
        )
    return np.array(ORIENTATIONS[key], dtype=np.float64)


def check_units(units: object, where: str) -> str:
    """Return ``units`` if it is one of :data:`accelcore.constants.UNITS`.

    Parameters
    ----------
    units : object
        The value given.
    where : str
        What the message names (a file, or an argument).

    Returns
    -------
    str

    Raises
    ------
    accelcore.SessionFormatError
        Any other value.
    """
    if not isinstance(units, str) or units not in UNITS:
        raise SessionFormatError(f"{where}: units must be one of {', '.join(UNITS)}, got {units!r}")
    return str(units)


@dataclass(frozen=True)
class RunSpec:
    """One ``[[run]]`` table of ``session.toml``.

    Attributes
    ----------
    file : str
        The log file as written in ``session.toml`` (relative to the folder).
    path : pathlib.Path
        The log file: the session folder joined with ``file``.
    orientation : str
        ``OX+`` ... ``OZ-`` (upper case, stripped).
    continues : bool or None
        The optional ``continues`` key: True, this log continues the run listed
        before it (a logger that starts a new file, its clock restarted or not);
        False, it is a run of its own even where its clock follows on (a new
        power-on); None (absent), told from the clock.
    """

    file: str
    path: Path
    orientation: str
    continues: bool | None = None

    @property
    def gravity_g(self) -> NDArray[np.float64]:
        """Gravity on x, y, z in g that the orientation implies."""
        return gravity_of(self.orientation)


@dataclass(frozen=True)
class SessionFormat:
    """Everything ``session.toml`` says, validated.

    Attributes
    ----------
    folder : pathlib.Path
        The session folder.
    version : str
        The ``format`` key (always :data:`accelcore.constants.SESSION_FORMAT`).
    units : str
        ``V``, ``LSB``, ``g``, ``mg`` or ``m/s2``.
    rate_hz : float
        Nominal sample rate of the logs.
    sensor, serial : str or None
        Datasheet name and the part's serial, when given (empty means None).
    delimiter : str
        The ``delimiter`` key as written (a comma, a semicolon, a tab or ``tab``);
        :attr:`separator` is the character it stands for.
    time_unit : str
        Unit of the time column: ``s``, ``ms``, ``us``, ``ns``, or ``sample`` (a
        sample index: seconds are ``index / rate_hz``).
    columns : mapping of str to str
        Log column of each role (``time``, ``temperature``, ``x``, ``y``, ``z``),
        defaults filled in; an empty ``temperature`` means the logs hold no
        temperature (:attr:`has_temperature`). Every other column of a log is an
        extra observable.
    runs : tuple of RunSpec
        The ``[[run]]`` tables, in order (none when the session names one log).
    sha256 : str
        SHA-256 of the bytes of ``session.toml`` that were parsed.
    lab : mapping of str to str
        The optional ``[lab]`` table (``date``, ``operator``, ``chamber``,
        ``reference_probe``, ``notes``): the lab's record, carried into the
        calibration's provenance.
    gravity_m_s2 : float
        The local gravity, m/s² (the ``gravity_m_s2`` key; default standard
        gravity): what 1 g of the orientations is in a session in ``m/s2``.
    log : LogSpec or None
        The one log the session names (``log =``, :mod:`accelcore.input.log_format`)
        in place of ``[[run]]`` tables; None for a folder of run files.
    """

    folder: Path
    version: str
    units: str
    rate_hz: float
    sensor: str | None
    serial: str | None
    delimiter: str
    time_unit: str
    columns: Mapping[str, str]
    runs: tuple[RunSpec, ...]
    sha256: str
    lab: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))
    gravity_m_s2: float = STANDARD_GRAVITY
    log: LogSpec | None = None

    @property
    def toml_path(self) -> Path:
        """The ``session.toml`` file."""
        return self.folder / TOML_NAME

    @property
    def separator(self) -> str:
        """The field separator character the ``delimiter`` key stands for."""
        return DELIMITERS[self.delimiter]

    @property
    def time_scale_to_s(self) -> float:
        """Seconds per unit of the time column (``1 / rate_hz`` for a sample index)."""
        if self.time_unit == SAMPLE_TIME_UNIT:
            return 1.0 / self.rate_hz
        return TIME_UNITS[self.time_unit]

    @property
    def has_temperature(self) -> bool:
        """False when ``[columns]`` says ``temperature = ""``: no temperature was logged."""
        return self.columns["temperature"] != ""

    @property
    def channel_columns(self) -> tuple[str, str, str]:
        """Log columns of x, y and z."""
        return (self.columns["x"], self.columns["y"], self.columns["z"])

    def toml_digest(self, digest: str) -> str:
        """Return the digest of ``session.toml`` as parsed (:attr:`sha256` says which bytes).

        ``digest``: ``"sha256"`` (the parsed bytes' own) or ``"blake3"`` (the file read
        again, and refused if it changed since it was parsed).
        """
        if digest == "sha256":
            return self.sha256
        try:
            data = self.toml_path.read_bytes()  # a few hundred bytes, read again
        except OSError as exc:
            raise AccelcoreIOError(f"{self.toml_path}: cannot be read: {exc}") from exc
        if hashlib.sha256(data).hexdigest() != self.sha256:
            raise AccelcoreIOError(f"{self.toml_path}: changed while the session was read")
        return digest_bytes(data, digest)

    @property
    def run_files(self) -> tuple[Path, ...]:
        """Every run's log file, in order (the one log, for a session that names one)."""
        return (self.log.path,) if self.log is not None else tuple(r.path for r in self.runs)

    @classmethod
    def read(cls, path: str | Path, *, check_files: bool = True) -> SessionFormat:
        """Read and validate a session folder's ``session.toml``.

        Parameters
        ----------
        path : str or Path
            The session folder (holding ``session.toml``).
        check_files : bool, default True
            Also require every run file to exist.

        Returns
        -------
        SessionFormat

        Raises
        ------
        accelcore.SessionFormatError
            ``session.toml`` is missing, not TOML, of another format version, or
            has a missing or invalid key; the message names the file and the key.
        accelcore.AccelcoreIOError
            The folder, or (with ``check_files``) a run file, does not exist;
            ``session.toml`` is not a regular file (a FIFO, a folder, a link loop)
            or is over 16 MiB.
        """
        folder = Path(path)
        toml_path = folder / TOML_NAME
        if not folder.exists():
            raise AccelcoreIOError(f"{folder}: no such session folder")
        if not toml_path.is_file() and not os.path.lexists(toml_path):
            raise SessionFormatError(
                f"{toml_path}: missing (a session folder holds a session.toml)"
            )
        # A FIFO, a folder or a link loop is named for what it is; a 2 GB file is not read.
        check_input_file(toml_path, "session.toml", max_bytes=MAX_TOML_BYTES)
        data = toml_path.read_bytes()
        try:
            # A byte-order mark (some Windows editors write one) is not TOML: skip it.
            meta = tomllib.loads(data.decode("utf-8-sig"))
        except tomllib.TOMLDecodeError as exc:
            raise SessionFormatError(f"{toml_path}: not valid TOML: {exc}") from exc
        except UnicodeDecodeError as exc:
            raise SessionFormatError(f"{toml_path}: not UTF-8 text: {exc}") from exc
        return cls.from_mapping(
            meta,
            folder,
            sha256=hashlib.sha256(data).hexdigest(),
            check_files=check_files,
        )

    @staticmethod
    def input_files(path: str | Path) -> tuple[Path, ...]:
        """Return the files a command reads from a session folder (for output checks).

        ``session.toml`` and, when it can be parsed, every run file it names
        (existing or not). A ``session.toml`` that cannot be parsed gives only
        itself: reading the session fails later, before anything is written.

        Parameters
        ----------
        path : str or Path
            The session folder.

        Returns
        -------
        tuple of pathlib.Path
        """
        folder = Path(path)
        try:
            fmt = SessionFormat.read(folder, check_files=False)
        except (SessionFormatError, AccelcoreIOError, OSError):
            return (folder / TOML_NAME,)
        return (fmt.toml_path, *fmt.run_files)

    @classmethod
    def from_mapping(
        cls,
        meta: Mapping[str, Any],
        folder: str | Path,
        *,
        sha256: str = "",
        check_files: bool = True,
    ) -> SessionFormat:
        """Validate the parsed content of a ``session.toml``.

        Parameters
        ----------
        meta : mapping
            The TOML document, as :func:`tomllib.loads` returns it.
        folder : str or Path
            The session folder (run files are relative to it; messages name its
            ``session.toml``).
        sha256 : str, optional
            SHA-256 of the file's bytes, kept on the result.
        check_files : bool, default True
            Also require every run file to exist.

        Returns
        -------
        SessionFormat

        Raises
        ------
        accelcore.SessionFormatError, accelcore.AccelcoreIOError
            As :meth:`read`.
        """
        folder = Path(folder)
        where = str(folder / TOML_NAME)
        fmt = meta.get("format")
        if fmt is None:
            raise SessionFormatError(
                f"{where}: missing required key 'format' (= \"{SESSION_FORMAT}\")"
            )
        if fmt != SESSION_FORMAT:
            raise SessionFormatError(
                f"{where}: format {fmt!r} is not supported; expected {SESSION_FORMAT!r}"
            )
        _known_keys(meta, TOP_KEYS, where, "")
        for key in ("units", "rate_hz"):
            if key not in meta:
                raise SessionFormatError(f"{where}: missing required key '{key}'")
        units = check_units(meta["units"], where)
        rate_hz = meta["rate_hz"]
        if (
            isinstance(rate_hz, bool)  # TOML's true is no rate (Python's bool is an int)
            or not isinstance(rate_hz, (int, float))
            or not math.isfinite(rate_hz)
            or rate_hz <= 0
        ):
            raise SessionFormatError(f"{where}: rate_hz must be a positive number, got {rate_hz!r}")
        delimiter = meta.get("delimiter", ",")
        if not isinstance(delimiter, str) or delimiter not in DELIMITERS:
            raise SessionFormatError(
                f"{where}: delimiter must be ',', '\\t' or ';', got {delimiter!r}"
            )
        time_unit = meta.get("time_unit", "s")
        units_of_time = (*TIME_UNITS, SAMPLE_TIME_UNIT)
        if not isinstance(time_unit, str) or time_unit not in units_of_time:
            raise SessionFormatError(
                f"{where}: time_unit must be one of {', '.join(units_of_time)}, got {time_unit!r}"
            )
        gravity = meta.get("gravity_m_s2", STANDARD_GRAVITY)
        if (
            isinstance(gravity, bool)
            or not isinstance(gravity, (int, float))
            or not 9.7 <= gravity <= 9.9
        ):
            raise SessionFormatError(
                f"{where}: gravity_m_s2 must be the local gravity in m/s² (9.7 to 9.9; "
                f"standard {STANDARD_GRAVITY}), got {gravity!r}"
            )
        log = read_log_keys(meta, folder, where)
        columns = _columns(run_columns(meta.get("columns", {})), where)
        if log is not None and log.orientation_column is not None:
            named = {k: v for k, v in columns.items() if v}
            check_distinct_columns({**named, "orientation": log.orientation_column}, where)
        if log is not None and check_files:
            _check_run_file(log.path, f"{where}, key 'log'", "log")
        runs = () if log else _runs(meta.get("run"), folder, where, check_files=check_files)
        sensor = meta.get("sensor") or None
        serial = meta.get("serial") or None
        lab = _lab(meta.get("lab", {}), where)
        return cls(
            folder=folder,
            version=str(fmt),
            units=units,
            rate_hz=float(rate_hz),
            sensor=str(sensor) if sensor else None,
            serial=str(serial) if serial else None,
            delimiter=delimiter,
            time_unit=time_unit,
            columns=MappingProxyType(columns),
            runs=runs,
            sha256=sha256,
            lab=MappingProxyType(lab),
            gravity_m_s2=float(gravity),
            log=log,
        )


#: Keys of ``session.toml``'s top level, of a ``[[run]]`` table and of ``[lab]``.
TOP_KEYS = (
    "format",
    "sensor",
    "serial",
    "units",
    "rate_hz",
    "delimiter",
    "time_unit",
    "gravity_m_s2",
    "columns",
    "run",
    "lab",
    *LOG_KEYS,
)
RUN_KEYS = ("file", "orientation", "continues")
LAB_KEYS = ("date", "operator", "chamber", "reference_probe", "notes")


def _known_keys(table: Mapping[str, object], known: Sequence[str], where: str, name: str) -> None:
    """Refuse a key the format does not know, suggesting the nearest known one."""
    for key in table:
        if key in known:
            continue
        near = difflib.get_close_matches(key, known, n=1, cutoff=0.6)
        hint = f"; did you mean '{near[0]}'?" if near else f"; known keys: {', '.join(known)}"
        raise SessionFormatError(f"{where}: unknown key '{key}'{name}{hint}")


def _lab(given: object, where: str) -> dict[str, str]:
    """Check the optional ``[lab]`` table: the lab's record, carried into every result."""
    if not isinstance(given, dict):
        raise SessionFormatError(f"{where}: [lab] must be a table ({', '.join(LAB_KEYS)})")
    _known_keys(given, LAB_KEYS, where, " in [lab]")
    return {k: str(v) for k, v in given.items()}


def _columns(given: object, where: str) -> dict[str, str]:
    """Check the ``[columns]`` table and fill in the defaults."""
    if not isinstance(given, dict):
        raise SessionFormatError(f"{where}: [columns] must be a table of column names")
    bad = [k for k, v in given.items() if not isinstance(v, str)]
    if bad:
        raise SessionFormatError(
            f"{where}: [columns] values must be strings (column names): {', '.join(bad)}"
        )
    columns = {**DEFAULT_COLUMNS, **given}
    unknown = set(columns) - set(DEFAULT_COLUMNS)
    if unknown:
        raise SessionFormatError(
            f"{where}: unknown key(s) in [columns]: {', '.join(sorted(unknown))}"
        )
    empty = [k for k, v in columns.items() if not v.strip() and k != "temperature"]
    if empty:
        raise SessionFormatError(
            f"{where}: [columns] {', '.join(empty)} must name a column (only temperature may "
            'be "": no temperature logged)'
        )
    check_distinct_columns({k: v for k, v in columns.items() if v}, where)
    return columns


def check_distinct_columns(columns: Mapping[str, str], where: str) -> None:
    """Refuse a column mapping that gives one log column two roles.

    Parameters
    ----------
    columns : mapping of str to str
        Log column of each role (``time``, ``temperature``, ``x``, ``y``, ``z``).
    where : str
        What the message names (a file, or an argument).

    Raises
    ------
    accelcore.SessionFormatError
        Two roles name the same column.
    """
    seen: dict[str, str] = {}
    for role, name in columns.items():
        if name in seen:
            raise SessionFormatError(
                f"{where}: [columns] maps both {seen[name]} and {role} to the log column "
                f"{name!r}; each role needs its own column"
            )
        seen[name] = role


def _runs(tables: object, folder: Path, where: str, *, check_files: bool) -> tuple[RunSpec, ...]:
    """Check the ``[[run]]`` tables, in order."""
    if not isinstance(tables, list) or not tables:
        raise SessionFormatError(
            f"{where}: no [[run]] table; a session needs at least one run "
            '(or log = "FILE": one log with an orientation column)'
        )
    specs: list[RunSpec] = []
    seen: dict[object, int] = {}  # each file's identity (:func:`_file_identity`): its run
    for i, table in enumerate(tables, start=1):
        if not isinstance(table, dict):
            raise SessionFormatError(f"{where}: [[run]] #{i} must be a table")
        _known_keys(table, RUN_KEYS, where, f" in [[run]] #{i}")
        for key in ("file", "orientation"):
            if key not in table:
                raise SessionFormatError(f"{where}: [[run]] #{i} is missing required key '{key}'")
        try:
            gravity_of(str(table["orientation"]))
        except SessionFormatError as exc:
            raise SessionFormatError(f"{where}: [[run]] #{i}: {exc}") from None
        if "\0" in str(table["file"]):
            raise SessionFormatError(
                f"{where}: [[run]] #{i}: file {table['file']!r} holds a NUL character; "
                "no file can be named so"
            )
        file = folder / str(table["file"])
        if check_files:
            _check_run_file(file, f"{where}, [[run]] #{i}")
        identity = _file_identity(file)
        if (first := seen.setdefault(identity, i)) != i:
            raise SessionFormatError(
                f"{where}: [[run]] #{i} reads {table['file']!r}, the same file as "
                f"[[run]] #{first} ({specs[first - 1].file!r}); "
                "each run needs its own log"
            )
        orientation = str(table["orientation"]).strip().upper()
        continues = table.get("continues")
        if continues is not None and not isinstance(continues, bool):
            raise SessionFormatError(
                f"{where}: [[run]] #{i}: continues must be true or false, got {continues!r}"
            )
        if continues and (i == 1 or specs[-1].orientation != orientation):
            before = "no [[run]]" if i == 1 else f"[[run]] #{i - 1} ({specs[-1].orientation})"
            raise SessionFormatError(
                f"{where}: [[run]] #{i} ({orientation}) says continues = true, but {before} "
                "comes before it in that orientation; list the pieces of one run in order, "
                "one after the other"
            )
        specs.append(RunSpec(str(table["file"]), file, orientation, continues))
    return tuple(specs)


def _file_identity(path: Path) -> object:
    """Return what two paths naming one file share (after links; hard links too).

    The device and inode of a file that exists (what :meth:`pathlib.Path.samefile`
    compares), else its resolved path: one ``stat`` per file, so checking n run files
    costs n calls, not n^2 / 2 comparisons of resolved paths.
    """
    try:
        st = path.stat()
    except OSError:
        try:
            return str(path.resolve())
        except (OSError, RuntimeError):  # a symlink loop: refused when the file is read
            return str(path.absolute())
    return (st.st_dev, st.st_ino)


def _check_run_file(file: Path, where: str, what: str = "run file") -> None:
    """Refuse a run file (or log) that is missing or not a regular file (a folder, FIFO, device)."""
    try:
        mode = file.stat().st_mode
    except FileNotFoundError:
        reason = f"{what} does not exist"
    except OSError as exc:
        reason = f"{what} cannot be read ({exc.strerror})"
    else:
        if stat.S_ISREG(mode):
            return
        reason = f"{what} is {file_kind(mode)}, not a log file"
    err = AccelcoreIOError(f"{file}: {reason} ({where})")
    err.path = str(file)
    raise err
