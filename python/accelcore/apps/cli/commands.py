"""The subcommands of the command line: one ``cmd_*(args, out) -> status`` per command.

Each takes the parsed options and the stream for results, and returns the exit
status; a data problem raises :class:`CliDataError` (status 1), a usage problem
found after parsing :class:`UsageError` (status 2).

Part of the applications room: may import every other room.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import sys
from pathlib import Path
from typing import Any, TextIO

import accelcore
from accelcore import datasheets, simulate
from accelcore.apps import demo
from accelcore.apps.bulk import bulk
from accelcore.apps.cli.compensate import cmd_compensate
from accelcore.apps.cli.documents import json_document, require_folder, write_json
from accelcore.apps.cli.init import cmd_init
from accelcore.apps.cli.inputs import (
    CliDataError,
    UsageError,
    guard,
    guard_bulk,
    need,
    open_session,
    session_inputs,
)
from accelcore.apps.progress import Progress
from accelcore.errors import AccelcoreError
from accelcore.files import check_outputs
from accelcore.input.quality import check_session
from accelcore.input.readers.opener import input_problem, is_session_input
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
    "cmd_init",
    "cmd_report",
    "cmd_simulate",
]


def _check_quality(
    session: Session, window_c: tuple[float, float] | None = None
) -> list[dict[str, Any]]:
    """Run the data-quality checks; each finding is also a warning printed on stderr.

    ``window_c``: the fit's window (default: the logged range).
    """
    issues = check_session(session, window_c="logged" if window_c is None else window_c)
    return [dataclasses.asdict(issue) for issue in issues]


def cmd_calibrate(args: argparse.Namespace, out: TextIO) -> int:
    """``accelcore calibrate``: summary, datasheet comparison, ``--save`` and ``--json``."""
    window: tuple[float, float] | None = None
    if args.window is not None:
        window = (args.window[0], args.window[1])
        if not window[0] < window[1]:
            raise UsageError(f"--window LO HI needs LO < HI, got {window[0]:g} {window[1]:g}")
    guard(session_inputs(args.session), [args.save, args.json])
    with Progress(3, enabled=not args.quiet) as bar:
        bar.step("reading")
        session = open_session(args.session, cache=not args.no_cache, instance=args.instance)
        bar.step("checking the data")
        quality = _check_quality(session, window)
        bar.step("calibrating")
        cal = accelcore.calibrate(session, args.method, t_ref_c=args.t_ref, window_c=window)
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


def cmd_export(args: argparse.Namespace, out: TextIO) -> int:
    """``accelcore export``: a calibration file as PX4, ArduPilot or imucal parameters."""
    guard([args.calibration], [args.output])
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


def cmd_diagnose(args: argparse.Namespace, out: TextIO) -> int:
    """``accelcore diagnose``: calibrate, diagnose, print the table or write ``--json``."""
    # Looked up when the command runs, so an installation (or a test) without the
    # diagnosis gets a usage error instead of a failed import of the whole CLI.
    try:
        diagnosis = importlib.import_module("accelcore.diagnosis")
    except ImportError as exc:
        raise UsageError(f"diagnosis is not available in this installation ({exc})") from exc
    guard(session_inputs(args.session), [args.json, args.save])
    with Progress(3, enabled=not args.quiet) as bar:
        bar.step("reading")
        session = open_session(args.session, cache=not args.no_cache, instance=args.instance)
        bar.step("checking the data")
        issues = check_session(session, window_c="logged")
        quality = [dataclasses.asdict(issue) for issue in issues]
        bar.step("diagnosing")
        result = diagnosis.diagnose(session, quality=issues)  # the checks run once
    if args.save:
        result.calibration.save(args.save)
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
    guard_bulk(Path(args.archive), Path(args.output))
    if args.scheduler is not None:
        need("distributed", "dask", "bulk --scheduler")
    result = bulk(
        args.archive,
        args.output,
        jobs=args.jobs,
        scheduler=args.scheduler,
        diagnose=not args.no_diagnose,
        force=args.force,
        progress=not args.quiet,
        cache=not args.no_cache,
        instance=args.instance,
    )
    n_failed = len(result.failures)
    tables = "" if result.not_written else ", fleet.parquet"
    print(
        f"{result.n_sessions} sessions ({result.n_reused} up to date, {n_failed} failed) in "
        f"{result.elapsed_s:.1f} s: {Path(args.output) / 'fleet.csv'}{tables}, failures.csv",
        file=out,
    )
    for row in result.failures.itertuples():
        print(f"accelcore bulk: failed: {row.session} ({row.stage}): {row.reason}", file=sys.stderr)
    if result.not_written:
        # The work is done and the CSV tables are complete; what is missing is the installation's.
        raise UsageError(f"not written: {'; '.join(result.not_written)}")
    return 1 if n_failed else 0


def cmd_report(args: argparse.Namespace, out: TextIO) -> int:
    """``accelcore report``: the HTML page of a session or of a bulk output."""
    matplotlib = need("matplotlib", "plot", "accelcore report")
    matplotlib.use("Agg")  # files only, never a window
    src = Path(args.path)
    page_file = Path(args.output or src) / "index.html"
    session_input = is_session_input(src)
    if session_input and args.output is None:
        raise UsageError("a session report needs -o DIR")
    if session_input:
        check_outputs(session_inputs(src), [page_file])
    else:
        fleet = [src / n for n in ("fleet.csv", "fleet.parquet", "failures.csv")]
        check_outputs(fleet, [page_file])
    try:
        if is_bulk_output(src):
            with Progress(1, enabled=not args.quiet) as bar:
                bar.step("fleet report")
                page = fleet_report(src, args.output)
        elif session_input:
            with Progress(2, enabled=not args.quiet) as bar:
                bar.step("reading")
                session = open_session(src, cache=not args.no_cache, instance=args.instance)
                bar.step("calibrating, diagnosing, plotting")
                page = session_report(session, args.output)
        elif src.is_file():
            raise UsageError(input_problem(src) or f"{src}: not a session folder")
        elif not src.is_dir():
            raise CliDataError(f"{src}: no such folder")
        else:
            raise CliDataError(
                f"{src}: neither a session folder (session.toml), a log (.csv, .parquet, "
                ".tdms, .ulg, .bin ...) nor a bulk output (fleet.csv)"
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
