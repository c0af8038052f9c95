"""The subcommands of the command line: one ``cmd_*(args, out) -> status`` per command.

Each takes the parsed options and the stream for results, and returns the exit
status; a data problem raises :class:`CliDataError` (status 1), a usage problem
found after parsing :class:`UsageError` (status 2).

Part of the applications room: may import every other room.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import importlib
import sys
import warnings
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, TextIO

import numpy as np
import pandas as pd
from numpy.typing import NDArray

import accelcore
from accelcore import datasheets, simulate
from accelcore.apps import demo
from accelcore.apps.bulk import bulk
from accelcore.apps.cli.documents import json_document, require_folder, write_json
from accelcore.constants import DEFAULT_COLUMNS as _DEFAULT_COLUMNS
from accelcore.constants import DELIMITERS as _DELIMITERS
from accelcore.constants import TIME_UNITS as _TIME_UNITS
from accelcore.errors import (
    AccelcoreError,
    AccelcoreIOError,
    OutputConflictError,
    ParseError,
    TemperatureRangeWarning,
)
from accelcore.files import atomic_open, check_outputs
from accelcore.input.format import SessionFormat
from accelcore.input.quality import check_session
from accelcore.input.readers import read_dataflash, read_ulog
from accelcore.input.session import Session
from accelcore.outputs import exports
from accelcore.outputs.report import fleet_report, is_bulk_output, session_report
from accelcore.outputs.tables import datasheet_section, summary_text
from accelcore.result.calibration import Calibration

__all__ = [
    "CliDataError",
    "UsageError",
    "cmd_bench",
    "cmd_bulk",
    "cmd_calibrate",
    "cmd_compensate",
    "cmd_demo",
    "cmd_diagnose",
    "cmd_export",
    "cmd_report",
    "cmd_simulate",
]

_COLUMN_KEYS = ("time", "temperature", "x", "y", "z")


class CliDataError(Exception):
    """A data problem the command line found itself (exit status 1)."""


class UsageError(Exception):
    """A usage problem found after parsing (exit status 2)."""


#: Flight-stack logs a command takes in place of a session folder, by file suffix.
_FLIGHT_LOGS = {".ulg": read_ulog, ".bin": read_dataflash}


def _flight_log(path: str | Path) -> bool:
    p = Path(path)
    return p.suffix.lower() in _FLIGHT_LOGS and not p.is_dir()


def _session_inputs(path: str | Path) -> tuple[Path, ...]:
    """Files a command reads from a session argument (a folder, or one flight log)."""
    return (Path(path),) if _flight_log(path) else SessionFormat.input_files(path)


def _open_session(path: str | Path, *, cache: bool) -> Session:
    """Open a session folder, or a PX4 ULog / ArduPilot DataFlash log (first IMU instance)."""
    if _flight_log(path):
        return _FLIGHT_LOGS[Path(path).suffix.lower()](path)
    return accelcore.load_session(path, cache=cache)


def _guard(inputs: Iterable[str | Path], outputs: Iterable[str | Path | None]) -> None:
    """Before reading anything: no output may alias an input, and every output's folder exists.

    Raises :class:`accelcore.errors.OutputConflictError` (exit status 2) or an
    :class:`accelcore.AccelcoreIOError` naming the output (exit status 1).
    """
    wanted = [o for o in outputs if o is not None and str(o) != "-"]
    check_outputs(inputs, wanted)
    for o in wanted:
        folder = Path(o).parent
        if not folder.is_dir():
            err = AccelcoreIOError(f"{o}: cannot write the output: folder {folder} does not exist")
            err.path = str(o)
            raise err


def _check_quality(session: Session) -> list[dict[str, Any]]:
    """Run the data-quality checks; each finding is also a warning printed on stderr."""
    return [dataclasses.asdict(issue) for issue in check_session(session, warn=True)]


def cmd_calibrate(args: argparse.Namespace, out: TextIO) -> int:
    """``accelcore calibrate``: summary, datasheet comparison, ``--save`` and ``--json``."""
    if not args.window[0] < args.window[1]:
        raise UsageError(f"--window LO HI needs LO < HI, got {args.window[0]:g} {args.window[1]:g}")
    _guard(_session_inputs(args.session), [args.save, args.json])
    session = _open_session(args.session, cache=not args.no_cache)
    quality = _check_quality(session)
    cal = accelcore.calibrate(
        session, args.method, t_ref_c=args.t_ref, window_c=(args.window[0], args.window[1])
    )
    text, records = datasheet_section(cal)
    if args.save:
        cal.save(args.save)
    if args.json:
        summary = cal.summary().reset_index().to_dict(orient="records")
        result = {
            "session": str(args.session),
            "saved_to": None if args.save is None else str(args.save),
            "summary": summary,
            "datasheet": records,
            "calibration": cal.to_dict(),
            "quality": quality,
        }
        write_json(args.json, json_document("calibrate", result), out)
    if args.json != "-":
        print(summary_text(cal), file=out)
        print(file=out)
        print(text, file=out)
        if args.save:
            print(f"\ncalibration saved to {args.save}", file=out)
    return 0


def _session_format(folder: str) -> dict[str, Any]:
    fmt = SessionFormat.read(folder, check_files=False)
    return {"delimiter": fmt.delimiter, "time_unit": fmt.time_unit, "columns": dict(fmt.columns)}


def _parse_column_options(items: Sequence[str]) -> dict[str, str]:
    columns: dict[str, str] = {}
    for item in items:
        key, sep, name = item.partition("=")
        if not sep or key not in _COLUMN_KEYS or not name:
            raise UsageError(
                f"--column expects KEY=NAME with KEY one of {', '.join(_COLUMN_KEYS)}, got {item!r}"
            )
        columns[key] = name
    return columns


def _compensate_chunks(
    cal: Calibration,
    chunks: Iterator[pd.DataFrame],
    names: Mapping[str, str],
    time_scale: float,
    extra_names: Sequence[str],
) -> Iterator[tuple[pd.DataFrame, NDArray[np.float64], int]]:
    """Yield per chunk: the input frame, acceleration in g, and samples outside the range."""
    comp = cal.compensator()
    for frame in chunks:
        before = comp.n_out_of_range
        with warnings.catch_warnings():
            # The command reports the total once at the end instead.
            warnings.simplefilter("ignore", TemperatureRangeWarning)
            g = comp.push(
                frame[[names["x"], names["y"], names["z"]]].to_numpy(dtype=np.float64),
                frame[names["temperature"]].to_numpy(dtype=np.float64),
                frame[names["time"]].to_numpy(dtype=np.float64) * time_scale,
                {k: frame[k].to_numpy(dtype=np.float64) for k in extra_names},
            )
        yield frame, g, comp.n_out_of_range - before


def cmd_compensate(args: argparse.Namespace, out: TextIO) -> int:
    """``accelcore compensate``: a raw log of any size into acceleration in g, in chunks."""
    inputs: list[str | Path] = [args.calibration, args.input]
    if args.session:
        inputs += SessionFormat.input_files(args.session)
    _guard(inputs, [args.output])
    fmt: dict[str, Any] = {"delimiter": ",", "time_unit": "s", "columns": {}}
    if args.session:
        fmt = _session_format(args.session)
    if args.delimiter is not None:
        fmt["delimiter"] = args.delimiter
    if args.time_unit is not None:
        fmt["time_unit"] = args.time_unit
    fmt["columns"].update(_parse_column_options(args.column))
    if fmt["delimiter"] not in _DELIMITERS:
        raise UsageError(f"delimiter must be ',', '\\t' or ';', got {fmt['delimiter']!r}")
    if fmt["time_unit"] not in _TIME_UNITS:
        raise UsageError(f"time unit must be one of {', '.join(_TIME_UNITS)}")
    if args.chunk_rows < 1:
        raise UsageError("--chunk-rows must be >= 1")
    names = {**_DEFAULT_COLUMNS, **fmt["columns"]}
    if len(set(names.values())) < len(names):
        raise UsageError(f"two columns share one name: {names}; each role needs its own column")
    cal = Calibration.load(args.calibration)
    extra_names = sorted(
        {t.basis.column for m in cal.axes.values() for t in m.terms if t.basis.column is not None}
    )
    needed = [names[k] for k in _COLUMN_KEYS] + extra_names
    source = Path(args.input)
    try:
        header = pd.read_csv(source, sep=_DELIMITERS[fmt["delimiter"]], nrows=0)
    except pd.errors.EmptyDataError as exc:
        raise CliDataError(f"{source}: empty file, no header row") from exc
    missing = [c for c in needed if c not in header.columns]
    if missing:
        raise CliDataError(
            f"{source}: missing column(s) {', '.join(missing)}; found {', '.join(header.columns)} "
            "(name them with --column KEY=NAME or --session)"
        )
    target = require_folder(args.output)
    reader = pd.read_csv(
        source,
        sep=_DELIMITERS[fmt["delimiter"]],
        usecols=needed,
        dtype=dict.fromkeys(needed, np.float64),
        chunksize=args.chunk_rows,
    )
    n_rows = n_out_of_range = n_nan = 0
    out_names = [names["time"], names["temperature"], "x_g", "y_g", "z_g"]
    # Written chunk by chunk (the log may not fit in memory), replaced atomically at the end.
    with reader, atomic_open(target) as fh:
        fh.write((",".join(out_names) + "\n").encode("utf-8"))
        try:
            for frame, g, n_out in _compensate_chunks(
                cal, iter(reader), names, _TIME_UNITS[fmt["time_unit"]], extra_names
            ):
                block = np.column_stack(
                    [frame[names["time"]].to_numpy(), frame[names["temperature"]].to_numpy(), g]
                )
                np.savetxt(fh, block, delimiter=",", fmt=["%.10g", "%.6g"] + ["%.7f"] * 3)
                n_rows += len(frame)
                n_out_of_range += n_out
                n_nan += int(np.count_nonzero(~np.isfinite(g).all(axis=1)))
        except ValueError as exc:
            if isinstance(exc, AccelcoreError):
                raise
            raise _bad_cell(source, _DELIMITERS[fmt["delimiter"]], needed) or CliDataError(
                f"{source}: {exc}"
            ) from exc
    print(f"compensated {n_rows} rows of {source} into {target} (columns x_g, y_g, z_g)", file=out)
    if n_nan:
        print(f"warning: {n_nan} rows had non-finite input and are NaN", file=sys.stderr)
    if n_out_of_range:
        lo, hi = cal.temperature_range_c
        print(
            f"warning: {n_out_of_range} rows lie outside the calibrated range {lo:.2f}…{hi:.2f} °C;"
            " the model is extrapolated there, not clamped",
            file=sys.stderr,
        )
    return 0


def cmd_export(args: argparse.Namespace, out: TextIO) -> int:
    """``accelcore export``: a calibration file as PX4, ArduPilot or imucal parameters."""
    _guard([args.calibration], [args.output])
    cal = Calibration.load(args.calibration)
    result: exports.Px4Export | exports.ArduPilotExport | exports.ImucalExport
    if args.target == "px4":
        result = exports.export_px4(cal, instance=args.instance, device_id=args.device_id)
    elif args.target == "ardupilot":
        result = exports.export_ardupilot(cal, imu=args.imu)
    else:
        result = exports.export_imucal(cal, temperature_c=args.temperature)
    require_folder(args.output)
    result.write(args.output)
    print(result.text(), file=out)
    print(f"written: {args.output}", file=out)
    return 0


def _bad_cell(source: Path, delimiter: str, needed: Sequence[str]) -> ParseError | None:
    """Find the first cell of the needed columns that is not a number (line and column, 1-based).

    Only called after the fast reader failed, so a clean log is read once.
    """
    with source.open(newline="", encoding="utf-8", errors="replace") as fh:
        rows = csv.reader(fh, delimiter=delimiter)
        header = next(rows, [])
        wanted = [(i, name) for i, name in enumerate(header) if name in needed]
        for line, row in enumerate(rows, start=2):
            for i, name in wanted:
                cell = row[i].strip() if i < len(row) else ""
                if cell == "":
                    continue
                try:
                    float(cell)
                except ValueError:
                    err = ParseError(
                        f"{source}:{line}:{i + 1}: column {name!r}: {cell!r} is not a number"
                    )
                    err.path, err.line, err.column = str(source), line, i + 1
                    return err
    return None


def cmd_diagnose(args: argparse.Namespace, out: TextIO) -> int:
    """``accelcore diagnose``: calibrate, diagnose, print the table or write ``--json``."""
    # Looked up when the command runs, so an installation (or a test) without the
    # diagnosis gets a usage error instead of a failed import of the whole CLI.
    try:
        diagnosis = importlib.import_module("accelcore.diagnosis")
    except ImportError as exc:
        raise UsageError(f"diagnosis is not available in this installation ({exc})") from exc
    _guard(_session_inputs(args.session), [args.json])
    session = _open_session(args.session, cache=not args.no_cache)
    quality = _check_quality(session)
    result = diagnosis.diagnose(session)
    if args.json:
        body = {
            "session": str(args.session),
            "diagnosis": result.to_dict(),
            "quality": quality,
        }
        write_json(args.json, json_document("diagnose", body), out)
    if args.json != "-":
        print(result.text(), file=out)
    return 0


def cmd_bulk(args: argparse.Namespace, out: TextIO) -> int:
    """``accelcore bulk``: every session under an archive; status 1 when any failed."""
    if args.jobs is not None and args.jobs < 1:
        raise UsageError("--jobs must be >= 1")
    _guard_bulk(Path(args.archive), Path(args.output))
    result = bulk(
        args.archive,
        args.output,
        jobs=args.jobs,
        scheduler=args.scheduler,
        diagnose=not args.no_diagnose,
        force=args.force,
        progress=not args.quiet,
        cache=not args.no_cache,
    )
    n_failed = len(result.failures)
    print(
        f"{result.n_sessions} sessions ({result.n_reused} up to date, {n_failed} failed) in "
        f"{result.elapsed_s:.1f} s: {Path(args.output) / 'fleet.csv'}, fleet.parquet, "
        "failures.csv",
        file=out,
    )
    for row in result.failures.itertuples():
        print(f"accelcore bulk: failed: {row.session} ({row.stage}): {row.reason}", file=sys.stderr)
    return 1 if n_failed else 0


def _guard_bulk(archive: Path, output: Path) -> None:
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


def cmd_report(args: argparse.Namespace, out: TextIO) -> int:
    """``accelcore report``: the HTML page of a session or of a bulk output."""
    try:
        import matplotlib  # optional: the [plot] extra
    except ImportError as exc:
        raise UsageError(f"reports need matplotlib: pip install accelcore[plot] ({exc})") from exc
    matplotlib.use("Agg")  # files only, never a window
    src = Path(args.path)
    page_file = Path(args.output or src) / "index.html"
    if (src / "session.toml").is_file():
        check_outputs(_session_inputs(src), [page_file])
    else:
        fleet = [src / n for n in ("fleet.csv", "fleet.parquet", "failures.csv")]
        check_outputs(fleet, [page_file])
    try:
        if is_bulk_output(src):
            page = fleet_report(src, args.output)
        elif (src / "session.toml").is_file():
            if args.output is None:
                raise UsageError("a session report needs -o DIR")
            page = session_report(_open_session(src, cache=not args.no_cache), args.output)
        elif not src.is_dir():
            raise CliDataError(f"{src}: no such folder")
        else:
            raise CliDataError(
                f"{src}: neither a session folder (session.toml) nor a bulk output (fleet.csv)"
            )
    except ValueError as exc:
        if isinstance(exc, AccelcoreError):
            raise
        raise CliDataError(f"{src}: {exc}") from exc
    print(f"report written to {page}", file=out)
    return 0


def cmd_simulate(args: argparse.Namespace, out: TextIO) -> int:
    """``accelcore simulate``: a simulated session with known truth."""
    known = datasheets.measured_names()
    match = [n for n in known if _norm(n) == _norm(args.sensor)]
    if not match:
        raise UsageError(f"--sensor must be one of {', '.join(known)}, got {args.sensor!r}")
    try:
        sim = simulate.session(
            args.out,
            match[0],
            seed=args.seed,
            duration_h=args.duration_h,
            soak_min=args.soak_min,
            cool_back=args.cool_back,
            orientations=args.orientations,
            serial=args.serial,
            overwrite=args.overwrite,
        )
    except (TypeError, ValueError) as exc:
        if isinstance(exc, AccelcoreError):
            raise
        raise UsageError(str(exc)) from exc
    t = sim.truth
    result = {
        "path": str(sim.path),
        "sensor": sim.sensor,
        "serial": sim.serial,
        "units": sim.units,
        "rate_hz": sim.rate_hz,
        "seed": sim.seed,
        "runs": [
            {"file": r.file, "orientation": r.orientation, "rows": r.n_samples} for r in sim.runs
        ],
        "truth": {
            "zero_g_offset": t.zero_g_offset,
            "sensitivity_per_g": t.sensitivity_per_g,
            "offset_tc_mg_per_c": t.offset_tc_mg_per_c,
            "sensitivity_tc_pct_per_c": t.sensitivity_tc_pct_per_c,
            "reference_temperature_c": t.reference_temperature_c,
        },
    }
    if args.json:
        write_json(args.json, json_document("simulate", result), out)
    if args.json != "-":
        rows = sum(r.n_samples for r in sim.runs)
        print(
            f"wrote {sim.path}: {sim.sensor}, {len(sim.runs)} runs "
            f"({', '.join(r.orientation for r in sim.runs)}), {rows} rows, seed {sim.seed}",
            file=out,
        )
    return 0


def _norm(name: str) -> str:
    return "".join(c for c in name.lower() if c.isalnum())


def cmd_bench(args: argparse.Namespace, out: TextIO) -> int:
    """``accelcore bench``: every argument goes to :func:`accelcore.apps.bench.main`."""
    # Looked up when the command runs: the harness is not needed by any other command.
    try:
        bench = importlib.import_module("accelcore.apps.bench")
    except ImportError as exc:
        raise UsageError(f"the benchmarks are not available in this installation ({exc})") from exc
    return int(bench.main(list(args.bench_args)))


def cmd_demo(args: argparse.Namespace, out: TextIO) -> int:
    """``accelcore demo``: generate (once), calibrate and print the example session."""
    return int(
        demo.run(directory=args.dir, regenerate=args.regenerate, out=out, cache=not args.no_cache)
    )
