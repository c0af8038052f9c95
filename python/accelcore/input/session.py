"""Sessions: one sensor's thermal-chamber test, read into decimated runs.

A session folder holds ``session.toml`` and one log per run (format
``accelcore-session/1``, see ``docs/session-format.md``). :func:`load_session`
streams each log through the Rust reader straight into the decimator, so a
multi-hour 20 Hz log is never held in memory whole; only the 2 Hz blocks are
kept. :meth:`Session.from_arrays` builds the same object from in-memory NumPy
arrays or pandas DataFrames.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from concurrent.futures import wait
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, TypedDict

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from accelcore import core
from accelcore._accelcore import RunTally, read_run
from accelcore.constants import (
    AXES,
    DEFAULT_COLUMNS,
    ORIENTATIONS,
    SESSION_FORMAT,
    STANDARD_GRAVITY,
)
from accelcore.errors import (
    InsufficientDataError,
    ParameterError,
    SessionFormatError,
    TimeOrderError,
)
from accelcore.input.cache import CacheSetting, Probe, RunCache, RunRecord
from accelcore.input.consistency import check_labels, check_rate
from accelcore.input.defaults import check_gravity, default_decimation_factor, fill_unlogged
from accelcore.input.format import SessionFormat, check_units, gravity_of
from accelcore.input.frames import check_complete_rows, frame_columns, run_table
from accelcore.input.run import Run, RunStats
from accelcore.input.temperature_units import impossible_temperature, not_a_temperature
from accelcore.pools import shared_pool

__all__ = [
    "AXES",
    "DIGESTS",
    "FORMAT",
    "ORIENTATIONS",
    "Run",
    "RunStats",
    "Session",
    "SessionFormat",
    "default_decimation_factor",
    "gravity_of",
    "load_session",
]

FORMAT = SESSION_FORMAT
#: Content digests :func:`load_session` can take of each file; the first is the default.
DIGESTS: tuple[str, ...] = ("blake3", "sha256")


@dataclass(frozen=True)
class Session:
    """One sensor's thermal-chamber test: settings and decimated runs.

    Attributes
    ----------
    runs : tuple of Run
        A session that logged no temperature has NaN temperatures
        (:attr:`has_temperature` is False).
    units : str
        ``V``, ``LSB``, ``g``, ``mg`` or ``m/s2``.
    rate_hz : float
        Nominal raw sample rate.
    sensor : str or None
        Datasheet name, when given.
    serial : str or None
        The part's serial.
    path : str or None
        The session folder, when read from disk.
    decimation_factor : int
        Raw samples per block.
    file_digests : dict of str to str
        Hex digest of ``session.toml`` and every run file, taken while reading them.
    digest : str
        The algorithm of ``file_digests``: ``"blake3"`` (the default of
        :func:`load_session`) or ``"sha256"``.
    format : SessionFormat or None
        What ``session.toml`` says (delimiter, columns, time unit, run files...),
        when read from disk; None for :meth:`from_arrays` and the other readers.
    log_sensor : dict of str to int
        Who the sensor is in the flight stack whose log was read: ``px4_device_id``
        (``sensor_accel.device_id``, when one value) and ``px4_instance``
        (:func:`accelcore.input.readers.read_ulog`), ``ardupilot_imu`` (1-based,
        :func:`accelcore.input.readers.read_dataflash`); empty otherwise. A
        calibration keeps it in its provenance, and the PX4 and ArduPilot exports
        take it as their defaults.
    gravity_m_s2 : float
        The local gravity, m/s² (default standard gravity): what the 1 g of the
        orientations is in a session in ``m/s2``.
    """

    runs: tuple[Run, ...]
    units: str
    rate_hz: float
    sensor: str | None = None
    serial: str | None = None
    path: str | None = None
    decimation_factor: int = 10
    file_digests: dict[str, str] = field(default_factory=dict)
    format: SessionFormat | None = None
    digest: str = DIGESTS[0]
    gravity_m_s2: float = STANDARD_GRAVITY
    log_sensor: dict[str, int] = field(default_factory=dict)

    @property
    def file_sha256(self) -> dict[str, str]:
        """SHA-256 of every file when the session was read with ``digest="sha256"``; else empty."""
        return dict(self.file_digests) if self.digest == "sha256" else {}

    @property
    def orientations(self) -> tuple[str, ...]:
        """Orientation of every run, in order."""
        return tuple(r.orientation for r in self.runs)

    @property
    def has_temperature(self) -> bool:
        """True when some run logged a finite temperature (False: no temperature column)."""
        return any(bool(np.isfinite(r.temperature_c).any()) for r in self.runs)

    @property
    def extra_columns(self) -> tuple[str, ...]:
        """Extra observables logged in every run."""
        if not self.runs:
            return ()
        common = set(self.runs[0].extras)
        for r in self.runs[1:]:
            common &= set(r.extras)
        return tuple(k for k in self.runs[0].extras if k in common)

    def check_orientations(self) -> None:
        """Check that the runs agree with their labels, units and rate before any fit.

        Every pair of runs is compared, not only the ``+`` and ``-`` runs of one
        axis: per axis, each run's median output must sit where its labelled
        gravity puts it on one straight line through all runs
        (:func:`accelcore.input.consistency.check_labels`), the slope of that line
        must match the declared ``units`` (and the datasheet's sensitivity when
        the sensor is known), and no decimated block may hold more raw samples
        than the decimation factor allows at ``rate_hz``
        (:func:`accelcore.input.consistency.check_rate`).

        Raises
        ------
        accelcore.SessionFormatError
            Naming the runs whose labels do not match the gravity they saw, the
            units that contradict the data or the datasheet, or the rate that
            contradicts the time stamps.

        Warns
        -----
        accelcore.DataQualityWarning
            The scale of ``V`` or ``LSB`` data is far from the datasheet's (a
            range setting or supply the datasheet does not cover).
        """
        where = self.path or "session"
        check_rate(self.runs, self.rate_hz, self.decimation_factor, where)
        check_labels(self.runs, self.units, self.sensor, where, self.gravity_m_s2)

    def file_hashes(self) -> dict[str, str]:
        """Digest of ``session.toml`` and every run file, for provenance.

        Computed while the session was read (the files as they were then), with
        the algorithm :attr:`digest` names.
        """
        return dict(self.file_digests)

    @classmethod
    def from_arrays(
        cls,
        runs: Sequence[tuple[str, Mapping[str, ArrayLike] | Any]],
        *,
        units: str,
        rate_hz: float,
        sensor: str | None = None,
        serial: str | None = None,
        decimation_factor: int | None = None,
        columns: Mapping[str, str] | None = None,
        gravity_m_s2: float = STANDARD_GRAVITY,
    ) -> Session:
        """Build a session from in-memory data, decimated like a file would be.

        Parameters
        ----------
        runs : sequence of (orientation, data)
            ``data`` is a mapping of column name to 1-D array, or a pandas
            DataFrame, with the time, temperature, x, y, z columns (names as in
            ``columns``) and any extra observables. Time and temperature may be
            left out (see ``columns``).
        units : str
            ``V``, ``LSB``, ``g``, ``mg`` or ``m/s2``.
        rate_hz : float
            Nominal sample rate of the data.
        sensor, serial : str, optional
            Datasheet name and serial.
        decimation_factor : int, optional
            Raw samples per block (1 keeps the data as it is); default
            :func:`default_decimation_factor` of ``rate_hz`` (blocks of about 0.5 s).
        columns : mapping, optional
            Column names, defaults ``time_s, temp_c, x, y, z``. A time or
            temperature role named ``""``, or not named and whose default column
            the data lacks, is not logged: time is then the sample index over
            ``rate_hz``, and without temperature the session calibrates at one
            temperature (:attr:`Session.has_temperature` is False). Every run
            must agree on whether temperature was logged.
        gravity_m_s2 : float, default standard gravity
            The local gravity, m/s²: output per g of data in ``m/s2``.

        Returns
        -------
        Session
        """
        check_units(units, "units")
        if decimation_factor is None:
            decimation_factor = default_decimation_factor(rate_hz)
        _check_read_options(decimation_factor, 1, rate_hz)
        runs = list(runs)
        if not runs:
            raise InsufficientDataError("from_arrays: no runs given; a session needs at least one")
        built = []
        logged: set[bool] = set()
        for i, item in enumerate(runs, start=1):
            if not isinstance(item, tuple) or len(item) != 2:
                raise ParameterError(f"run {i}: expected an (orientation, data) pair")
            orientation, data = item
            gravity = gravity_of(str(orientation))
            label = f"run {i} ({str(orientation).strip().upper()})"
            if not isinstance(data, (Mapping, pd.DataFrame)):
                # Any other table (polars, pyarrow, ...): its columns, through the one
                # adapter (which refuses lazy frames and things that are not tables).
                data = dict(zip(*frame_columns(data, label), strict=True))
            data, names, has_temperature = fill_unlogged(data, columns, rate_hz)
            logged.add(has_temperature)
            if len(logged) > 1:
                raise SessionFormatError(
                    f"{label}: temperature is {'' if has_temperature else 'not '}logged here "
                    f"but {'not ' if has_temperature else ''}in an earlier run; every run of a "
                    "session logs it, or none does"
                )
            table, extra_names = run_table(data, label, names)
            check_complete_rows(table, names, extra_names, label)
            channels = np.column_stack(table[2:])
            time_s, temp_c = table[0], table[1]
            if has_temperature and (k := impossible_temperature(temp_c)) is not None:
                column = names.get("temperature") or DEFAULT_COLUMNS["temperature"]
                raise ParameterError(
                    f"{label}: column {column!r}, row {k}: {not_a_temperature(float(temp_c[k]))}"
                )
            dec = core.Decimator(
                factor=decimation_factor, rate_hz=rate_hz, n_channels=channels.shape[1]
            )
            try:
                dec.push(time_s, temp_c, channels)
            except TimeOrderError as e:
                # The core counts rows from 0 within this run's push: name the run too.
                time_column = names.get("time") or DEFAULT_COLUMNS["time"]
                err = TimeOrderError(
                    f"{label}: column {time_column!r}, row {e.index}: time is not strictly "
                    f"increasing ({e.previous_s:.9g} s then {e.time_s:.9g} s); a logger "
                    "restart or repeated rows: split the run or drop the repeats"
                )
                err.index, err.previous_s, err.time_s = e.index, e.previous_s, e.time_s
                raise err from e
            blocks = dec.finish()
            tally = RunTally(n_channels=channels.shape[1], rate_hz=rate_hz)
            tally.push(time_s, temp_c, channels)
            stats = RunStats.from_raw(tally.finish())
            built.append(
                _make_run(
                    str(orientation).strip().upper(),
                    gravity,
                    blocks,
                    extra_names,
                    None,
                    stats,
                    temperature=has_temperature,
                )
            )
        return cls(
            runs=tuple(built),
            units=units,
            rate_hz=float(rate_hz),
            sensor=sensor,
            serial=serial,
            path=None,
            decimation_factor=decimation_factor,
            gravity_m_s2=check_gravity(gravity_m_s2),
        )


def _check_read_options(
    decimation_factor: object, min_count: object, rate_hz: object = 1.0
) -> None:
    """Refuse bad arguments as the caller's error, never blamed on a file."""
    if isinstance(decimation_factor, bool) or not isinstance(decimation_factor, int):
        raise _parameter("decimation_factor", f"must be an integer, got {decimation_factor!r}")
    if decimation_factor < 1:
        raise _parameter("decimation_factor", f"must be >= 1, got {decimation_factor}")
    if isinstance(min_count, bool) or not isinstance(min_count, int):
        raise _parameter("min_count", f"must be an integer, got {min_count!r}")
    if not 1 <= min_count <= decimation_factor:
        raise _parameter(
            "min_count",
            f"must lie in 1…decimation_factor ({decimation_factor}), got {min_count}: a block "
            f"never holds more than {decimation_factor} samples",
        )
    if (
        isinstance(rate_hz, bool)
        or not isinstance(rate_hz, (int, float))
        or not math.isfinite(rate_hz)
        or rate_hz <= 0
    ):
        raise _parameter("rate_hz", f"must be a positive number, got {rate_hz!r}")


def _parameter(name: str, text: str) -> ParameterError:
    err = ParameterError(f"{name} {text}")
    err.parameter = name
    return err


class _Blocks(Protocol):
    """What :func:`_make_run` reads of decimated blocks (Rust's, or the run cache's)."""

    @property
    def count(self) -> NDArray[np.int64]: ...
    @property
    def time_s(self) -> NDArray[np.float64]: ...
    @property
    def temperature_c(self) -> NDArray[np.float64]: ...
    @property
    def channels(self) -> NDArray[np.float64]: ...


def _make_run(
    orientation: str,
    gravity: NDArray[np.float64],
    blocks: _Blocks,
    extra_names: Sequence[str],
    source: str | None,
    stats: RunStats,
    *,
    temperature: bool = True,
    continues: bool | None = None,
) -> Run:
    """Build a run from decimated blocks; without ``temperature``, its temperatures are NaN."""
    channels = blocks.channels
    extras = {name: channels[:, 3 + i].copy() for i, name in enumerate(extra_names)}
    return Run(
        orientation=orientation,
        gravity_g=gravity,
        time_s=blocks.time_s,
        temperature_c=blocks.temperature_c
        if temperature
        else np.full(blocks.temperature_c.shape, np.nan),
        output=np.ascontiguousarray(channels[:, :3]),
        count=blocks.count,
        extras=extras,
        source=source,
        stats=stats,
        continues=continues,
    )


#: Logs of one session read at once; None: one per core. A bulk worker process sets
#: it to its share of the cores (:mod:`accelcore.apps.bulk`), so that jobs times
#: threads never exceeds the cores.
read_threads: int | None = None


class _ReadParams(TypedDict):
    """Keyword arguments of :func:`read_run`: all of them key the run cache."""

    delimiter: str
    time_column: str
    temperature_column: str
    channel_columns: list[str]
    keep_extra_columns: bool
    time_scale_to_s: float
    factor: int
    rate_hz: float
    min_count: int


def load_session(
    path: str | Path,
    *,
    decimation_factor: int | None = None,
    min_count: int = 1,
    cache: CacheSetting = True,
    digest: str = DIGESTS[0],
) -> Session:
    """Read a session folder, streaming every log through the Rust reader and decimator.

    Parameters
    ----------
    path : str or Path
        The session folder (holding ``session.toml``).
    decimation_factor : int, optional
        Raw samples per block; default :func:`default_decimation_factor` of the
        session's ``rate_hz``: blocks of about 0.5 s, so 10 turns 20 Hz into 2 Hz
        as in the seed paper, and a log at 2 Hz or slower is kept as it is.
    min_count : int, default 1
        Blocks with fewer valid raw samples are dropped.
    cache : bool, str or os.PathLike, default True
        The persistent run cache (:mod:`accelcore.input.cache`). True: the default
        folder, ``$ACCELCORE_CACHE_DIR``, else ``$XDG_CACHE_HOME/accelcore/runs``,
        else ``~/.cache/accelcore/runs`` (off when ``ACCELCORE_CACHE=0``); a
        path: that folder; False: never read or write a cache.
    digest : {"blake3", "sha256"}, default "blake3"
        The content digest of every file (:attr:`Session.file_digests`, the
        calibration's provenance), taken in the reader's parsing pass.

    Returns
    -------
    Session

    Raises
    ------
    accelcore.SessionFormatError
        ``session.toml`` is missing, invalid, of another format version, or names
        an unknown orientation; the message names the file and the key.
    accelcore.ParseError
        A log cannot be parsed; ``.path``, ``.line`` and ``.column`` say where.
    accelcore.AccelcoreIOError
        The folder or a run file does not exist or cannot be read.

    Warns
    -----
    accelcore.input.cache.CacheWarning
        The cache folder cannot be written (once per call); the result is the
        same as without the cache.

    Notes
    -----
    With the cache, the decimated blocks, reader statistics and digest of each
    run file are kept, keyed by the file's resolved path, every reader parameter
    (``session.toml``'s delimiter, columns and time unit, ``rate_hz``,
    ``decimation_factor``, ``min_count``, ``digest``) and the accelcore version. An entry is
    used only while the file's size, mtime, ctime, inode and device are
    unchanged, so a repeat load of an archived session skips parsing and
    hashing and gives an identical :class:`Session`. Files changed less than
    2 s before they are read are not cached. ``session.toml`` is always read
    and hashed.
    """
    check_load_options(decimation_factor, min_count, digest)
    return load_folder(
        SessionFormat.read(path),
        decimation_factor=decimation_factor,
        min_count=min_count,
        cache=cache,
        digest=digest,
    )


def check_load_options(decimation_factor: int | None, min_count: int, digest: str) -> None:
    """Refuse bad :func:`load_session` arguments as the caller's error, before any file."""
    if decimation_factor is not None:
        _check_read_options(decimation_factor, min_count)
    if digest not in DIGESTS:
        raise _parameter("digest", f"must be one of {', '.join(DIGESTS)}, got {digest!r}")


def load_folder(
    fmt: SessionFormat,
    *,
    decimation_factor: int | None,
    min_count: int,
    cache: CacheSetting,
    digest: str,
) -> Session:
    """Read the run files of a parsed ``session.toml`` (:func:`load_session`'s work).

    The options are :func:`load_session`'s, already checked by the caller.
    """
    if fmt.log is not None:  # one log, not run files: accelcore.input.single_log reads it
        raise SessionFormatError(
            f"{fmt.toml_path}: names one log (log = {fmt.log.file!r}); read it with "
            "accelcore.load_session"
        )
    if decimation_factor is None:
        decimation_factor = default_decimation_factor(fmt.rate_hz)
        _check_read_options(decimation_factor, min_count)
    params: _ReadParams = {
        "delimiter": fmt.separator,
        "time_column": fmt.columns["time"],
        # No temperature logged: the reader averages the (always finite) time
        # column in its place, and the runs get NaN temperatures.
        "temperature_column": fmt.columns["temperature"] or fmt.columns["time"],
        "channel_columns": list(fmt.channel_columns),
        "keep_extra_columns": True,
        "time_scale_to_s": fmt.time_scale_to_s,
        "factor": decimation_factor,
        "rate_hz": fmt.rate_hz,
        "min_count": min_count,
    }

    def read(file: Path) -> tuple[RunRecord, str]:
        data = read_run(str(file), digest=digest, **params)
        assert data.digest is not None  # asked for
        return RunRecord.from_run_data(data), data.digest

    run_files = list(fmt.run_files)
    store = RunCache.open(cache)
    found: list[tuple[RunRecord, str] | None] = [None] * len(run_files)
    probes: list[Probe | None] = [None] * len(run_files)
    if store is not None:
        for i, (hit, probe) in enumerate(store.lookup_all(run_files, params, digest)):
            found[i], probes[i] = hit, probe

    def run_of(i: int) -> tuple[Run, RunRecord, str]:
        """Read run ``i`` unless the cache holds it; build its :class:`Run`."""
        record, hexdigest = found[i] or read(run_files[i])
        spec = fmt.runs[i]
        return (
            _make_run(
                spec.orientation,
                spec.gravity_g,
                record.blocks,
                record.channel_names[3:],
                str(spec.path),
                _run_stats(record),
                temperature=fmt.has_temperature,
                continues=spec.continues,
            ),
            record,
            hexdigest,
        )

    missing = [i for i, hit in enumerate(found) if hit is None]
    if len(missing) > 1:
        # The Rust reader releases the GIL: read the runs on all cores at once, each
        # hashed (provenance) in the same pass as it is parsed, and its arrays copied
        # into the run's own on the same thread.
        pool = shared_pool("accelcore-read", read_threads or os.cpu_count() or 1)
        tasks = [pool.submit(run_of, i) for i in range(len(run_files))]
        wait(tasks)  # every read ends before any error is raised, as in a pool of its own
        built = [task.result() for task in tasks]
    else:
        built = [run_of(i) for i in range(len(run_files))]
    if store is not None:
        for i in missing:
            store.store(probes[i], built[i][1], built[i][2])  # only if the file did not change
        store.finish()
    file_digests = {fmt.toml_path.name: fmt.toml_digest(digest)}
    for spec, (_, _, hexdigest) in zip(fmt.runs, built, strict=True):
        file_digests[spec.path.name] = hexdigest
    runs = [run for run, _, _ in built]
    return Session(
        runs=tuple(runs),
        units=fmt.units,
        rate_hz=fmt.rate_hz,
        sensor=fmt.sensor,
        serial=fmt.serial,
        path=str(fmt.folder),
        decimation_factor=decimation_factor,
        file_digests=file_digests,
        format=fmt,
        digest=digest,
        gravity_m_s2=fmt.gravity_m_s2,
    )


def _run_stats(data: RunRecord) -> RunStats:
    """Return what the reader saw in a run's raw log (a record, fresh or cached)."""
    return RunStats(
        n_rows=data.n_rows,
        n_skipped_nonfinite=data.n_skipped_nonfinite,
        n_truncated_rows=data.n_truncated_rows,
        n_gaps=data.n_gaps,
        max_interval_s=data.max_interval_s,
        duration_s=data.last_time_s - data.first_time_s,
        channel_min=data.channel_min,
        channel_max=data.channel_max,
        n_at_min=data.n_at_min,
        n_at_max=data.n_at_max,
    )
