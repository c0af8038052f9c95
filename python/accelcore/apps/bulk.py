"""Bulk processing of archived chamber runs: every session under a folder, in parallel.

:func:`bulk` finds every session folder (one holding ``session.toml``) and every
flight log (PX4 ``.ulg``, ArduPilot ``.bin``; one IMU instance each) at any
depth under an archive, calibrates and diagnoses each, and writes per session
``OUT/<relative path>/calibration.json`` and ``diagnosis.json``, plus the fleet
table ``OUT/fleet.parquet`` (when pyarrow is installed) and ``OUT/fleet.csv`` (one row
per session and axis)
and ``OUT/failures.csv`` (session, stage, reason). The fleet rows are built in
:mod:`accelcore.apps.fleet_rows`; their ``warnings`` column holds the session's
data-quality findings (:func:`accelcore.input.quality.check_session`) in short.

Guarantees
----------
- One bad session never stops the batch: it lands in ``failures.csv``.
- Nothing is lost on a crash: every file is written with
  :func:`accelcore.files.atomic_write` (temporary name, fsync, rename); a
  session's ``fleet_rows.json`` is written last and marks it done. A rerun skips
  sessions whose outputs are newer than their inputs and redoes the rest, so
  ``kill -9`` then a rerun ends with the same fleet table.
- Results are deterministic: sessions are processed independently and the
  tables are sorted by session path, so ``--jobs`` does not change a byte.

Parallelism: sessions run in worker *processes* (``concurrent.futures``); the
Rust reader releases the GIL, but calibration and diagnosis spend much of their
time in NumPy and Python, so threads would serialise (see the README for the
measurement). Each worker gets its share of the cores: it reads a session's logs
with ``cores // jobs`` threads and runs NumPy's BLAS on one thread (the
products here are tall and thin, where BLAS threads gain nothing, and their
idle spinning took a quarter of the CPU from the other worker); a single-job
run keeps BLAS on one thread too. With a Dask ``client`` the same function runs
on a cluster, sessions as tasks.
"""

from __future__ import annotations

import csv
import io
import json
import os
import threading
import time
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, ThreadPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import pandas as pd
from threadpoolctl import threadpool_limits

from accelcore._accelcore import __version__, merge_runs, plan_split, read_run_range
from accelcore.apps.archive import (
    CALIBRATION_FILE,
    DIAGNOSIS_FILE,
    FAILURES_CSV,
    FLEET_CSV,
    FLEET_PARQUET,
    find_sessions,
    guard_outputs,
    input_mtime,
)
from accelcore.apps.fleet_rows import fleet_rows
from accelcore.apps.progress import Progress
from accelcore.diagnosis import diagnose as run_diagnosis
from accelcore.diagnosis import search as diagnosis_search
from accelcore.errors import AccelcoreError
from accelcore.files import atomic_write
from accelcore.fitting.calibrate import calibrate
from accelcore.input import session as session_reader
from accelcore.input.cache import CacheSetting
from accelcore.input.quality import check_session
from accelcore.input.readers.opener import is_flight_log, open_input
from accelcore.input.session import default_decimation_factor
from accelcore.outputs.report.fleet import FAILURE_COLUMNS, FLEET_COLUMNS

__all__ = [
    "BULK_SCHEMA",
    "FAILURE_COLUMNS",
    "FLEET_COLUMNS",
    "BulkResult",
    "bulk",
    "find_sessions",
    "process_session",
    "read_run_split",
    "watch_parent",
    "worker_count",
]

BULK_SCHEMA = "accelcore-bulk/2"  # 2: the warnings column


@dataclass
class SessionOutcome:
    """What processing one session gave: fleet rows, or a failure, and whether it was reused."""

    session: str
    rows: list[dict[str, Any]] = field(default_factory=list)
    failure: tuple[str, str] | None = None
    reused: bool = False


def process_session(
    archive: str | Path,
    rel: str,
    out: str | Path,
    *,
    diagnose: bool = True,
    force: bool = False,
    cache: CacheSetting = True,
    instance: int = 0,
) -> SessionOutcome:
    """Calibrate (and diagnose) one session and write its outputs; never raises on bad data.

    Parameters
    ----------
    archive : str or Path
        The archive root.
    rel : str
        The session folder (or flight log) relative to ``archive``.
    out : str or Path
        The output root.
    diagnose : bool, default True
        Also run :func:`accelcore.diagnose` and write ``diagnosis.json``.
    force : bool, default False
        Redo the session even if its outputs are up to date.
    cache : bool, str or os.PathLike, default True
        The run cache, as in :func:`accelcore.load_session`.
    instance : int, default 0
        The IMU instance read from a flight log (a session folder ignores it).

    Returns
    -------
    SessionOutcome
    """
    src = Path(archive) / rel
    dst = Path(out) / rel
    marker = dst / "fleet_rows.json"
    # The instance read is part of a flight log's input; a session folder has none.
    read_instance = instance if is_flight_log(src) else None
    try:
        if not force and marker.is_file() and marker.stat().st_mtime >= input_mtime(src):
            doc = json.loads(marker.read_text())
            if (
                doc.get("schema") == BULK_SCHEMA
                and doc.get("accelcore_version") == __version__
                and doc.get("instance") == read_instance
            ):
                return SessionOutcome(rel, rows=list(doc["rows"]), reused=True)
    except (OSError, json.JSONDecodeError, KeyError):
        pass  # unreadable marker: redo the session
    stage = "load"
    try:
        session = open_input(src, instance=instance, cache=cache)
        stage = "calibrate"
        cal = calibrate(session)
        dst.mkdir(parents=True, exist_ok=True)
        cal.save(dst / CALIBRATION_FILE)
        quality = check_session(session, warn=False)
        diag = None
        if diagnose:
            stage = "diagnose"
            diag = run_diagnosis(session, cal, quality=quality)
            atomic_write(dst / DIAGNOSIS_FILE, json.dumps(diag.to_dict(), indent=1, sort_keys=True))
        stage = "report"
        rows = fleet_rows(rel, cal, diag, quality)
        doc = {"schema": BULK_SCHEMA, "accelcore_version": __version__, "rows": rows}
        if read_instance is not None:
            doc["instance"] = read_instance
        atomic_write(
            marker,
            json.dumps(
                doc,
                sort_keys=True,
                allow_nan=True,
            ),
        )
        return SessionOutcome(rel, rows=rows)
    except (AccelcoreError, OSError, ValueError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        return SessionOutcome(rel, failure=(stage, f"{type(exc).__name__}: {reason}"))
    except Exception as exc:
        last = traceback.extract_tb(exc.__traceback__)[-1]
        return SessionOutcome(
            rel,
            failure=(
                stage,
                f"internal error {type(exc).__name__}: {exc} "
                f"(at {Path(last.filename).name}:{last.lineno})",
            ),
        )


@dataclass(frozen=True)
class BulkResult:
    """Summary of a bulk run.

    Attributes
    ----------
    fleet : pandas.DataFrame
        One row per session and axis (also written to fleet.csv / fleet.parquet).
    failures : pandas.DataFrame
        One row per failed session: session, stage, reason.
    n_sessions, n_reused : int
        Sessions found, and sessions whose up-to-date outputs were reused.
    elapsed_s : float
    not_written : tuple of str
        Outputs left out for want of an optional dependency, each with the extra
        to install (``"fleet.parquet needs pyarrow: pip install accelcore[parquet]"``).
    """

    fleet: pd.DataFrame
    failures: pd.DataFrame
    n_sessions: int
    n_reused: int
    elapsed_s: float
    not_written: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        """True when no session failed."""
        return self.failures.empty


def _table_bytes(frame: pd.DataFrame, columns: Sequence[str]) -> bytes:
    buf = io.StringIO()
    frame.to_csv(
        buf,
        index=False,
        columns=list(columns),
        lineterminator="\n",
        quoting=csv.QUOTE_MINIMAL,
        float_format="%.17g",
    )
    return buf.getvalue().encode("utf-8")


#: What a bulk run without pyarrow leaves out, and how to get it.
NO_PARQUET = "fleet.parquet needs pyarrow: pip install accelcore[parquet]"


def _write_tables(out: Path, fleet: pd.DataFrame, failures: pd.DataFrame) -> tuple[str, ...]:
    """Write the fleet tables; return what was left out for want of an optional dependency."""
    atomic_write(out / FLEET_CSV, _table_bytes(fleet, FLEET_COLUMNS))
    atomic_write(out / FAILURES_CSV, _table_bytes(failures, FAILURE_COLUMNS))
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:  # optional: the [parquet] extra; the CSV tables are complete
        stale = out / FLEET_PARQUET
        if stale.is_file():  # from an earlier run: it would disagree with fleet.csv
            stale.unlink()
        return (NO_PARQUET,)
    table = pa.Table.from_pandas(fleet, preserve_index=False)
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    atomic_write(out / FLEET_PARQUET, sink.getvalue().to_pybytes())
    return ()


def worker_count(jobs: int | None, n_sessions: int) -> int:
    """Worker processes to start: ``jobs`` (default all cores), capped by the sessions and cores.

    Parameters
    ----------
    jobs : int or None
        Requested workers (``--jobs``).
    n_sessions : int
        Sessions to process.

    Returns
    -------
    int
        At least 1; never more than the sessions or the cores.
    """
    cores = os.cpu_count() or 1
    wanted = cores if jobs is None else jobs
    return max(1, min(wanted, n_sessions, cores))


def watch_parent(parent_pid: int, interval_s: float = 1.0) -> None:
    """End this worker process when its parent is gone (a ``kill -9`` leaves no one to stop it).

    Starts a daemon thread that checks every ``interval_s`` that the process
    which asked for this worker (``parent_pid``) is alive and that this worker's
    own parent (that process when workers are forked, a fork server otherwise) is
    the one it started with; once either fails, the worker exits at once with
    status 1.

    Parameters
    ----------
    parent_pid : int
        Process id of the process that started the pool.
    interval_s : float, default 1.0
        Seconds between checks.
    """
    first_parent = os.getppid()

    def alive(pid: int) -> bool:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        except PermissionError:
            return True
        return True

    def watch() -> None:
        while os.getppid() == first_parent and alive(parent_pid):
            time.sleep(interval_s)
        os._exit(1)

    threading.Thread(target=watch, name="accelcore-watch-parent", daemon=True).start()


def _start_worker(parent_pid: int, threads: int) -> None:
    """Initialise a worker process: watch the parent, take a share of the cores.

    ``threads`` (cores // jobs) reads the logs of a session and runs the diagnosis'
    time-constant searches; BLAS runs on one.
    """
    watch_parent(parent_pid)
    session_reader.read_threads = threads
    diagnosis_search.search_threads = threads
    threadpool_limits(limits=1, user_api="blas")


def _run_local(
    archive: Path,
    sessions: Sequence[str],
    out: Path,
    jobs: int,
    options: dict[str, Any],
    on_done: Callable[[SessionOutcome], None],
) -> list[SessionOutcome]:
    """Process the sessions here or in worker processes; ``options`` go to process_session."""
    outcomes: list[SessionOutcome] = []
    if jobs <= 1:
        with threadpool_limits(limits=1, user_api="blas"):
            for rel in sessions:
                o = process_session(archive, rel, out, **options)
                on_done(o)
                outcomes.append(o)
        return outcomes
    share = max(1, (os.cpu_count() or 1) // jobs)
    with ProcessPoolExecutor(
        max_workers=jobs, initializer=_start_worker, initargs=(os.getpid(), share)
    ) as pool:
        futures: list[Future[SessionOutcome]] = [
            pool.submit(process_session, archive, rel, out, **options) for rel in sessions
        ]
        for fut in as_completed(futures):
            o = fut.result()
            on_done(o)
            outcomes.append(o)
    return outcomes


def _run_dask(
    client: Any,
    archive: Path,
    sessions: Sequence[str],
    out: Path,
    options: dict[str, Any],
    on_done: Callable[[SessionOutcome], None],
) -> list[SessionOutcome]:
    import distributed

    dask_completed: Any = distributed.as_completed  # untyped package

    futures = [
        client.submit(
            process_session,
            str(archive),
            rel,
            str(out),
            **options,
            pure=False,
            key=f"accelcore-session-{i}",
        )
        for i, rel in enumerate(sessions)
    ]
    outcomes = []
    for fut in dask_completed(futures):
        o = fut.result()
        on_done(o)
        outcomes.append(o)
    return outcomes


def bulk(
    archive: str | Path,
    out: str | Path,
    *,
    jobs: int | None = None,
    client: Any = None,
    scheduler: str | None = None,
    diagnose: bool = True,
    force: bool = False,
    progress: bool = True,
    stream: TextIO | None = None,
    cache: CacheSetting = True,
    instance: int = 0,
) -> BulkResult:
    """Calibrate and diagnose every session under ``archive``; write per-session and fleet outputs.

    Parameters
    ----------
    archive : str or Path
        Folder searched (any depth) for session folders.
    out : str or Path
        Output folder (created).
    jobs : int, optional
        Worker processes; default: all cores. Capped by the sessions to do and
        the cores (:func:`worker_count`); 1 runs in this process. Workers end
        when this process dies (:func:`watch_parent`).
    client : dask.distributed.Client, optional
        Run sessions as tasks on this Dask cluster instead.
    scheduler : str, optional
        Address ``tcp://HOST:PORT`` of a Dask scheduler to connect to.
    diagnose : bool, default True
        Also diagnose each session.
    force : bool, default False
        Redo sessions whose outputs are up to date.
    progress : bool, default True
        Show progress on ``stream`` (a bar on a terminal, log lines otherwise).
    stream : text stream, optional
        Where progress goes; default stderr.
    cache : bool, str or os.PathLike, default True
        The run cache used to load each session (:func:`accelcore.load_session`);
        a folder given here must be reachable from every worker.
    instance : int, default 0
        The IMU instance read from each flight log of the archive.

    Returns
    -------
    BulkResult
    """
    start = time.monotonic()
    archive_p, out_p = Path(archive), Path(out)
    sessions = find_sessions(archive_p)
    guard_outputs(archive_p, sessions, out_p)
    out_p.mkdir(parents=True, exist_ok=True)
    bar = Progress(
        len(sessions), stream=stream, enabled=progress, log_lines=True, rate=True, delay_s=0.0
    )

    def done(o: SessionOutcome) -> None:
        bar.advance(
            item=o.session, status="FAILED" if o.failure else ("reused" if o.reused else "ok")
        )

    own_client = None
    if scheduler is not None and client is None:
        import distributed

        make_client: Any = distributed.Client  # untyped package
        client = own_client = make_client(scheduler)
    options = {"diagnose": diagnose, "force": force, "cache": cache, "instance": instance}
    try:
        if client is not None:
            outcomes = _run_dask(client, archive_p, sessions, out_p, options, done)
        else:
            n_jobs = worker_count(jobs, len(sessions))
            outcomes = _run_local(archive_p, sessions, out_p, n_jobs, options, done)
    finally:
        bar.close()
        if own_client is not None:
            own_client.close()
    outcomes.sort(key=lambda o: o.session)
    rows = [r for o in outcomes for r in o.rows]
    fleet = pd.DataFrame(rows, columns=list(FLEET_COLUMNS))
    failures = pd.DataFrame(
        [
            {"session": o.session, "stage": o.failure[0], "reason": o.failure[1]}
            for o in outcomes
            if o.failure
        ],
        columns=list(FAILURE_COLUMNS),
    )
    not_written = _write_tables(out_p, fleet, failures)
    return BulkResult(
        fleet,
        failures,
        len(sessions),
        sum(o.reused for o in outcomes),
        time.monotonic() - start,
        not_written,
    )


def read_run_split(
    path: str | Path,
    *,
    pieces: int | None = None,
    client: Any = None,
    delimiter: str = ",",
    time_column: str = "time_s",
    temperature_column: str = "temp_c",
    channel_columns: Sequence[str] = ("x", "y", "z"),
    time_scale_to_s: float = 1.0,
    factor: int | None = None,
    rate_hz: float = 20.0,
    min_count: int = 1,
) -> Any:
    """Read and decimate one very long log in parallel pieces, then merge them.

    The log is cut into line-aligned byte ranges (:func:`accelcore._accelcore.plan_split`);
    each piece is read and decimated on its own (threads here, or tasks on a
    Dask ``client``) on the block grid of the whole log, and the pieces are
    merged (:func:`accelcore._accelcore.merge_runs`): blocks cut by a boundary
    are joined, so the result equals :func:`accelcore._accelcore.read_run` of
    the whole file.

    Parameters
    ----------
    path : str or Path
        The log.
    pieces : int, optional
        Number of pieces; default: the number of cores (or of Dask workers).
    client : dask.distributed.Client, optional
        Read the pieces as tasks on this cluster (the file must be visible to
        the workers at the same path).
    delimiter, time_column, temperature_column, channel_columns, time_scale_to_s
        The log's layout, as in ``session.toml``.
    factor, rate_hz, min_count
        Decimation, as in :class:`accelcore.core.Decimator`; the default
        ``factor`` follows ``rate_hz`` (blocks of about 0.5 s,
        :func:`accelcore.input.session.default_decimation_factor`).

    Returns
    -------
    accelcore._accelcore.RunData
    """
    layout: dict[str, Any] = {
        "delimiter": delimiter,
        "time_column": time_column,
        "temperature_column": temperature_column,
        "channel_columns": list(channel_columns),
        "time_scale_to_s": time_scale_to_s,
    }
    if pieces is None:
        if client is not None:
            pieces = max(1, len(client.scheduler_info().get("workers", {})))
        else:
            pieces = os.cpu_count() or 1
    ranges, t0_s = plan_split(str(path), pieces, **layout)
    if t0_s is None:
        raise AccelcoreError(f"{path}: no data row with a finite time")
    if factor is None:
        factor = default_decimation_factor(rate_hz)
    kwargs = {**layout, "t0_s": t0_s, "factor": factor, "rate_hz": rate_hz}
    if client is not None:
        futures = [
            client.submit(read_run_range, str(path), a, b, pure=False, **kwargs) for a, b in ranges
        ]
        parts = client.gather(futures)
    else:
        with ThreadPoolExecutor(max_workers=len(ranges)) as pool:
            parts = list(
                pool.map(lambda r: read_run_range(str(path), r[0], r[1], **kwargs), ranges)
            )
    return merge_runs(parts, min_count=min_count, rate_hz=rate_hz)
