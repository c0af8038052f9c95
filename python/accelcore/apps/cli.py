"""The ``accelcore`` command line (also ``python -m accelcore``).

Subcommands: ``calibrate``, ``compensate``, ``diagnose``, ``report``, ``bulk``,
``simulate``, ``bench`` and ``demo``; ``accelcore COMMAND --help`` shows each one's options
and an example. Exit status: 0 on success, 1 on a data error (a one-line
reason naming the file goes to stderr), 2 on a usage error.

``--json OUT`` writes a machine-readable result in the versioned schema
``accelcore-cli/1`` (see ``docs/cli.md``)::

    {"schema": "accelcore-cli/1", "command": "calibrate",
     "accelcore_version": "0.1.0", "result": {...}}

The file is written atomically (temporary name, then rename); ``--json -``
writes it to stdout instead of the human-readable output.
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
import os
import sys
import tomllib
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, TextIO

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from accelcore._accelcore import __version__
from accelcore.constants import DEFAULT_COLUMNS as _DEFAULT_COLUMNS
from accelcore.constants import DELIMITERS as _DELIMITERS
from accelcore.constants import TIME_UNITS as _TIME_UNITS
from accelcore.errors import AccelcoreError
from accelcore.outputs.tables import datasheet_section, summary_text

__all__ = ["JSON_SCHEMA", "build_parser", "json_document", "main", "write_json"]

#: Version tag of every ``--json`` document; bumped on any incompatible change.
JSON_SCHEMA = "accelcore-cli/1"
#: Rows read per chunk by ``accelcore compensate``.
DEFAULT_CHUNK_ROWS = 100_000

_COLUMN_KEYS = ("time", "temperature", "x", "y", "z")


class CliDataError(Exception):
    """A data problem the command line found itself (exit status 1)."""


class _UsageError(Exception):
    """A usage problem found after parsing (exit status 2)."""


# ---------------------------------------------------------------------- JSON output
def _plain(value: Any) -> Any:
    """Convert to strict-JSON data: NumPy to Python, tuples to lists, NaN/inf to None."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return [_plain(v) for v in value.tolist()]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        f = float(value)
        return f if math.isfinite(f) else None
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, Path):
        return str(value)
    if value is pd.NA or value is pd.NaT:
        return None
    raise TypeError(f"cannot write {type(value).__name__} to JSON")


def json_document(command: str, result: Mapping[str, Any]) -> dict[str, Any]:
    """Wrap a command's result in the ``accelcore-cli/1`` envelope.

    Parameters
    ----------
    command : str
        The subcommand (``calibrate``, ``diagnose``, ``simulate``).
    result : mapping
        The command's result; converted to strict JSON (NaN and infinities
        become ``null``, NumPy values become Python numbers).

    Returns
    -------
    dict
        ``{"schema", "command", "accelcore_version", "result"}``.
    """
    return {
        "schema": JSON_SCHEMA,
        "command": command,
        "accelcore_version": __version__,
        "result": _plain(result),
    }


def write_json(path: str | Path, document: Mapping[str, Any], stdout: TextIO | None = None) -> None:
    """Write a JSON document atomically (temporary file in the same folder, then rename).

    Parameters
    ----------
    path : str or Path
        Target file; ``"-"`` writes to ``stdout``.
    document : mapping
        Strict-JSON data.
    stdout : text stream, optional
        Where ``"-"`` writes (default ``sys.stdout``).
    """
    text = json.dumps(document, indent=2, sort_keys=False, allow_nan=False) + "\n"
    if str(path) == "-":
        (stdout or sys.stdout).write(text)
        return
    target = Path(path)
    tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, target)
    finally:
        if tmp.exists():
            tmp.unlink()


# ---------------------------------------------------------------------- commands
def _check_quality(session: Any) -> list[dict[str, Any]]:
    """Run the data-quality checks; each finding is also a warning printed on stderr."""
    import dataclasses

    from accelcore.input.quality import check_session

    return [dataclasses.asdict(issue) for issue in check_session(session, warn=True)]


def _cmd_calibrate(args: argparse.Namespace, out: TextIO) -> int:
    import accelcore

    session = accelcore.load_session(args.session, cache=not args.no_cache)
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
    path = Path(folder) / "session.toml"
    try:
        with open(path, "rb") as fh:
            meta = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise CliDataError(f"{path}: not valid TOML: {exc}") from exc
    return {
        "delimiter": meta.get("delimiter", ","),
        "time_unit": meta.get("time_unit", "s"),
        "columns": dict(meta.get("columns", {})),
    }


def _parse_column_options(items: Sequence[str]) -> dict[str, str]:
    columns: dict[str, str] = {}
    for item in items:
        key, sep, name = item.partition("=")
        if not sep or key not in _COLUMN_KEYS or not name:
            raise _UsageError(
                f"--column expects KEY=NAME with KEY one of {', '.join(_COLUMN_KEYS)}, got {item!r}"
            )
        columns[key] = name
    return columns


def _compensate_chunks(
    cal: Any,
    chunks: Iterator[pd.DataFrame],
    names: Mapping[str, str],
    time_scale: float,
    extra_names: Sequence[str],
) -> Iterator[tuple[pd.DataFrame, NDArray[np.float64], int]]:
    """Yield per chunk: the input frame, acceleration in g, and samples outside the range."""
    import warnings

    from accelcore.errors import TemperatureRangeWarning

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


def _cmd_compensate(args: argparse.Namespace, out: TextIO) -> int:
    from accelcore import Calibration

    fmt: dict[str, Any] = {"delimiter": ",", "time_unit": "s", "columns": {}}
    if args.session:
        fmt = _session_format(args.session)
    if args.delimiter is not None:
        fmt["delimiter"] = args.delimiter
    if args.time_unit is not None:
        fmt["time_unit"] = args.time_unit
    fmt["columns"].update(_parse_column_options(args.column))
    if fmt["delimiter"] not in _DELIMITERS:
        raise _UsageError(f"delimiter must be ',', '\\t' or ';', got {fmt['delimiter']!r}")
    if fmt["time_unit"] not in _TIME_UNITS:
        raise _UsageError(f"time unit must be one of {', '.join(_TIME_UNITS)}")
    if args.chunk_rows < 1:
        raise _UsageError("--chunk-rows must be >= 1")
    names = {**_DEFAULT_COLUMNS, **fmt["columns"]}
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
    reader = pd.read_csv(
        source,
        sep=_DELIMITERS[fmt["delimiter"]],
        usecols=needed,
        dtype=dict.fromkeys(needed, np.float64),
        chunksize=args.chunk_rows,
    )
    target = Path(args.output)
    tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    n_rows = n_out_of_range = n_nan = 0
    out_names = [names["time"], names["temperature"], "x_g", "y_g", "z_g"]
    try:
        with reader, open(tmp, "w", encoding="utf-8", newline="") as fh:
            fh.write(",".join(out_names) + "\n")
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
                raise CliDataError(f"{source}: {exc}") from exc
        os.replace(tmp, target)
    finally:
        if tmp.exists():
            tmp.unlink()
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


def _cmd_diagnose(args: argparse.Namespace, out: TextIO) -> int:
    import accelcore

    try:
        diagnosis = importlib.import_module("accelcore.diagnosis")
    except ImportError as exc:
        raise _UsageError(f"diagnosis is not available in this installation ({exc})") from exc
    session = accelcore.load_session(args.session, cache=not args.no_cache)
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


def _cmd_bulk(args: argparse.Namespace, out: TextIO) -> int:
    from accelcore.apps.bulk import bulk

    if args.jobs is not None and args.jobs < 1:
        raise _UsageError("--jobs must be >= 1")
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


def _cmd_report(args: argparse.Namespace, out: TextIO) -> int:
    import accelcore

    try:
        import matplotlib

        report = importlib.import_module("accelcore.outputs.report")
    except ImportError as exc:
        raise _UsageError(f"reports need matplotlib: pip install accelcore[plot] ({exc})") from exc
    matplotlib.use("Agg")  # files only, never a window
    src = Path(args.path)
    try:
        if report.is_bulk_output(src):
            page = report.fleet_report(src, args.output)
        elif (src / "session.toml").is_file():
            if args.output is None:
                raise _UsageError("a session report needs -o DIR")
            page = report.session_report(
                accelcore.load_session(src, cache=not args.no_cache), args.output
            )
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


def _cmd_simulate(args: argparse.Namespace, out: TextIO) -> int:
    from accelcore import datasheets, simulate

    known = datasheets.measured_names()
    match = [n for n in known if _norm(n) == _norm(args.sensor)]
    if not match:
        raise _UsageError(f"--sensor must be one of {', '.join(known)}, got {args.sensor!r}")
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
        raise _UsageError(str(exc)) from exc
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


def _cmd_bench(args: argparse.Namespace, out: TextIO) -> int:
    try:
        bench = importlib.import_module("accelcore.apps.bench")
    except ImportError as exc:
        raise _UsageError(f"the benchmarks are not available in this installation ({exc})") from exc
    return int(bench.main(list(args.bench_args)))


def _cmd_demo(args: argparse.Namespace, out: TextIO) -> int:
    from accelcore.apps import demo

    return int(
        demo.run(directory=args.dir, regenerate=args.regenerate, out=out, cache=not args.no_cache)
    )


# ---------------------------------------------------------------------- parser
_EPILOGS = {
    "calibrate": """example:
  accelcore calibrate examples/adxl335-demo/generated --method joint --t-ref 25 \\
      --window 0 60 --json cal-result.json --save adxl335.cal.json""",
    "compensate": """example:
  accelcore compensate adxl335.cal.json flight_log.csv -o flight_log_g.csv \\
      --column temperature=die_temp --column time=t_ms --time-unit ms

  The output holds the time and temperature columns, then x_g, y_g, z_g.""",
    "diagnose": """example:
  accelcore diagnose examples/adxl335-demo/generated --json diagnosis.json""",
    "bulk": """example:
  accelcore bulk /data/chamber-archive -o /data/calibrations --jobs 2
  accelcore bulk /data/chamber-archive -o /data/calibrations --scheduler tcp://10.0.0.5:8786

  Writes OUT/<session>/calibration.json and diagnosis.json, OUT/fleet.csv,
  OUT/fleet.parquet and OUT/failures.csv. A rerun redoes only sessions whose
  inputs changed (or that failed). Exit status 1 when any session failed.""",
    "report": """example:
  accelcore report examples/adxl335-demo/generated -o /tmp/adxl335-report
  accelcore report /data/calibrations            (a bulk output: fleet report)

  Writes DIR/index.html, one self-contained page (figures embedded). On a
  session: datasheet comparison, the paper's Figures 4, 6 and 7, diagnosis
  table and residual plots. On a bulk output (a folder holding fleet.csv):
  temperature coefficients across parts against the datasheet limits, the
  fleet table and the failures; -o defaults to that folder.""",
    "simulate": """example:
  accelcore simulate /tmp/adxl335-session --sensor ADXL335 --seed 7 --duration-h 2""",
    "bench": """example:
  accelcore bench            (arguments after 'bench' go to the benchmark runner)""",
    "demo": """example:
  accelcore demo                      (the bundled example, generated on first use)
  accelcore demo --dir /tmp/demo      (somewhere else)""",
}


def _window(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"not a finite number: {text!r}")
    return value


def _add_no_cache(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--no-cache",
        action="store_true",
        help="read every log again; neither use nor fill the run cache (docs/cache.md)",
    )


def build_parser() -> argparse.ArgumentParser:
    """Return the ``accelcore`` argument parser.

    Returns
    -------
    argparse.ArgumentParser
    """
    fmt = argparse.RawDescriptionHelpFormatter
    parser = argparse.ArgumentParser(
        prog="accelcore",
        description="Thermal calibration of MEMS accelerometers (Rust-accelerated).",
        epilog="Exit status: 0 success, 1 data error, 2 usage error. "
        "'accelcore COMMAND --help' shows an example for each command.",
    )
    parser.add_argument("--version", action="version", version=f"accelcore {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    def add(name: str, help_text: str, **kw: Any) -> argparse.ArgumentParser:
        return sub.add_parser(
            name,
            help=help_text,
            description=help_text,
            epilog=_EPILOGS[name],
            formatter_class=fmt,
            **kw,
        )

    p = add("calibrate", "calibrate a session: summary and datasheet comparison")
    p.add_argument("session", metavar="SESSION", help="session folder (holding session.toml)")
    p.add_argument("--method", choices=("joint", "paper"), default="joint", help="default: joint")
    p.add_argument("--t-ref", type=_window, default=25.0, metavar="C", help="default: 25 °C")
    p.add_argument(
        "--window",
        nargs=2,
        type=_window,
        default=(0.0, 60.0),
        metavar=("LO", "HI"),
        help="temperature window of the fit, °C (default: 0 60)",
    )
    p.add_argument("--json", metavar="OUT", help="write the result as JSON ('-': stdout)")
    p.add_argument("--save", metavar="CAL.json", help="save the calibration file")
    _add_no_cache(p)
    p.set_defaults(func=_cmd_calibrate, data_path="session")

    p = add("compensate", "turn a raw log into acceleration in g with a saved calibration")
    p.add_argument("calibration", metavar="CAL.json", help="file written by calibrate --save")
    p.add_argument("input", metavar="INPUT.csv", help="raw log (any size: read in chunks)")
    p.add_argument("-o", "--output", required=True, metavar="OUT.csv", help="output CSV")
    p.add_argument(
        "--session",
        metavar="SESSION",
        help="take delimiter, time_unit and [columns] from this session's session.toml",
    )
    p.add_argument(
        "--column",
        action="append",
        default=[],
        metavar="KEY=NAME",
        help="column name, KEY one of time, temperature, x, y, z (repeatable)",
    )
    p.add_argument("--delimiter", help="',' (default), '\\t' or ';'")
    p.add_argument("--time-unit", choices=tuple(_TIME_UNITS), help="default: s")
    p.add_argument("--chunk-rows", type=int, default=DEFAULT_CHUNK_ROWS, help=argparse.SUPPRESS)
    p.set_defaults(func=_cmd_compensate, data_path="input")

    p = add("diagnose", "calibrate and diagnose what the model still gets wrong")
    p.add_argument("session", metavar="SESSION", help="session folder (holding session.toml)")
    p.add_argument("--json", metavar="OUT", help="write the result as JSON ('-': stdout)")
    _add_no_cache(p)
    p.set_defaults(func=_cmd_diagnose, data_path="session")

    p = add("bulk", "calibrate and diagnose every session under an archive folder")
    p.add_argument("archive", metavar="ARCHIVE", help="folder searched for sessions (any depth)")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="output folder")
    p.add_argument("--jobs", type=int, metavar="N", help="worker processes (default: all cores)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="run on a Dask cluster (tcp://HOST:PORT)")
    p.add_argument("--no-diagnose", action="store_true", help="calibrate only")
    p.add_argument("--force", action="store_true", help="redo sessions that are up to date")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    _add_no_cache(p)
    p.set_defaults(func=_cmd_bulk, data_path="archive")

    p = add("report", "write an HTML report of a session or of a bulk output")
    p.add_argument(
        "path", metavar="SESSION|OUT", help="session folder, or output folder of accelcore bulk"
    )
    p.add_argument(
        "-o",
        "--output",
        metavar="DIR",
        help="folder for index.html (required for a session; default for a bulk output: OUT)",
    )
    _add_no_cache(p)
    p.set_defaults(func=_cmd_report, data_path="path")

    p = add("simulate", "write a simulated session with known truth")
    p.add_argument("out", metavar="OUT", help="session folder to create (must be empty)")
    p.add_argument("--sensor", default="ADXL335", help="ADXL335 (default), ADXL327, ...")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--duration-h", type=float, default=2.0, help="hours per run (default 2)")
    p.add_argument(
        "--soak-min", type=float, default=10.0, help="soak at -2 °C before the ramp (default 10)"
    )
    p.add_argument("--cool-back", action="store_true", help="heat, then cool back")
    p.add_argument(
        "--orientations",
        nargs="+",
        default=["OX+", "OX-", "OY+", "OY-", "OZ+", "OZ-"],
        metavar="O",
        help="one run per entry (default: all six)",
    )
    p.add_argument("--serial", help="serial written to session.toml")
    p.add_argument("--overwrite", action="store_true", help="write into a non-empty folder")
    p.add_argument("--json", metavar="OUT", help="write the result as JSON ('-': stdout)")
    p.set_defaults(func=_cmd_simulate, data_path="out")

    p = add("bench", "benchmarks: accelcore vs the NumPy reference", add_help=False)
    p.add_argument("bench_args", nargs=argparse.REMAINDER, help=argparse.SUPPRESS)
    p.set_defaults(func=_cmd_bench, data_path=None)

    p = add("demo", "calibrate and diagnose the bundled example session")
    p.add_argument(
        "--dir",
        metavar="DIR",
        help="folder of the demo session (default: examples/adxl335-demo/generated in the "
        "source tree if writable, else a cache folder); generated there if absent",
    )
    p.add_argument("--regenerate", action="store_true", help="generate the session again")
    _add_no_cache(p)
    p.set_defaults(func=_cmd_demo, data_path="dir")
    return parser


def _one_line(exc: BaseException, path: str | None) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    if isinstance(exc, OSError) and not isinstance(exc, AccelcoreError) and exc.filename:
        text = f"{exc.strerror or text}: {exc.filename}"
    if path and path not in text:
        text = f"{path}: {text}"
    return text


def _show_warnings(caught: Sequence[warnings.WarningMessage], command: str) -> None:
    seen: set[str] = set()
    for w in caught:
        text = " ".join(str(w.message).split())
        if text not in seen:
            seen.add(text)
            print(f"accelcore {command}: warning: {text}", file=sys.stderr)


def main(argv: Sequence[str] | None = None, *, stdout: TextIO | None = None) -> int:
    """Run the command line.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name (default ``sys.argv[1:]``).
    stdout : text stream, optional
        Where results go (default ``sys.stdout``); errors and warnings go to stderr.

    Returns
    -------
    int
        Exit status: 0 success, 1 data error, 2 usage error.
    """
    args_list = list(sys.argv[1:] if argv is None else argv)
    out = stdout or sys.stdout
    if args_list[:1] == ["bench"]:  # everything after 'bench' belongs to the bench runner
        ns = argparse.Namespace(command="bench", bench_args=args_list[1:], data_path=None)
        handler: Callable[[argparse.Namespace, TextIO], int] = _cmd_bench
    else:
        parser = build_parser()
        try:
            ns = parser.parse_args(args_list)
        except SystemExit as exc:
            return int(exc.code) if isinstance(exc.code, int) else 2
        handler = ns.func
    path = getattr(ns, ns.data_path) if ns.data_path else None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            status = handler(ns, out)
        except BrokenPipeError:  # the reader went away (e.g. `accelcore demo | head`)
            if out is sys.stdout:
                devnull = os.open(os.devnull, os.O_WRONLY)
                os.dup2(devnull, sys.stdout.fileno())
            status = 1
        except _UsageError as exc:
            print(f"accelcore {ns.command}: error: {exc}", file=sys.stderr)
            status = 2
        except (AccelcoreError, OSError, CliDataError) as exc:
            print(f"accelcore {ns.command}: error: {_one_line(exc, path)}", file=sys.stderr)
            status = 1
        finally:
            _show_warnings(caught, ns.command)
    return status


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
