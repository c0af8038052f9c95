"""The options of the command line: :func:`build_parser` and each command's example.

Part of the applications room; each subcommand's handler is in
:mod:`accelcore.apps.cli.commands`.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from accelcore._accelcore import __version__
from accelcore.apps.cli import commands
from accelcore.constants import TIME_UNITS as _TIME_UNITS
from accelcore.constants import UNITS

__all__ = ["DEFAULT_CHUNK_ROWS", "build_parser"]

#: Rows read per chunk by ``accelcore compensate``.
DEFAULT_CHUNK_ROWS = 100_000

_EPILOGS = {
    "calibrate": """example:
  accelcore calibrate examples/adxl335-demo/generated --method joint --t-ref 25 \\
      --window 0 60 --json cal-result.json --save adxl335.cal.json
  accelcore calibrate thermal_sweep.ulg --instance 1 --save px4-imu1.cal.json
  accelcore calibrate chamber/sweep.parquet   (its session.toml names it: log = ...)""",
    "compensate": """example:
  accelcore compensate adxl335.cal.json flight_log.csv -o flight_log_g.csv \\
      --column temperature=die_temp --column time=t_ms --time-unit ms
  accelcore compensate px4-imu1.cal.json flight.ulg --instance 1 -o flight_g.csv

  accelcore compensate adxl335.cal.json flight_log.csv -o flight_log_g.parquet

  The output holds the time and temperature columns, then x_g, y_g, z_g: CSV,
  or Parquet when OUT ends in .parquet (pip install accelcore[parquet]).""",
    "export": """examples:
  accelcore export adxl335.cal.json --to px4 --device-id 2621474 -o tc_accel.params
  accelcore export adxl335.cal.json --to ardupilot --imu 1 -o tcal.param
  accelcore export adxl335.cal.json --to imucal -o adxl335.imucal.json

  PX4 (TC_A<i>_*, QGroundControl parameter file) and ArduPilot (INS_TCAL<n>_*,
  .param file) hold one cubic offset per axis: the export is the least-squares
  cubic of this calibration over its fitted range, and what it loses against the
  full model (max and RMS, mg; sensitivity drift) is printed. imucal holds bias,
  scale and misalignment at one temperature (--temperature, default T_ref).
  Conventions and signs: docs/interop.md.""",
    "diagnose": """example:
  accelcore diagnose examples/adxl335-demo/generated --json diagnosis.json
  accelcore diagnose chamber/ --save diagnosed.json   (then compensate or export it)
  accelcore diagnose chamber.bin --instance 1     (an ArduPilot log's second IMU)""",
    "bulk": """example:
  accelcore bulk /data/chamber-archive -o /data/calibrations --jobs 2
  accelcore bulk /data/chamber-archive -o /data/calibrations --scheduler tcp://10.0.0.5:8786

  A session is a folder holding session.toml, or a flight log (.ulg, .bin;
  IMU --instance). Writes OUT/<session>/calibration.json and diagnosis.json,
  OUT/fleet.csv, OUT/fleet.parquet (with pyarrow) and OUT/failures.csv. A
  rerun redoes only sessions whose inputs changed (or that failed). Exit
  status 1 when any session failed.""",
    "report": """example:
  accelcore report examples/adxl335-demo/generated -o /tmp/adxl335-report
  accelcore report /data/calibrations            (a bulk output: fleet report)
  accelcore report flight.ulg -o /tmp/flight-report

  Writes DIR/index.html, one self-contained page (figures embedded). On a
  session: datasheet comparison, the paper's Figures 4, 6 and 7, diagnosis
  table and residual plots. On a bulk output (a folder holding fleet.csv):
  temperature coefficients across parts against the datasheet limits, the
  fleet table and the failures; -o defaults to that folder.""",
    "init": """examples:
  accelcore init /data/chamber/part17
  accelcore init /data/chamber/part17 --units V --rate-hz 20 --sensor ADXL335 --force
  accelcore init /data/chamber/sweep.csv        (then: accelcore calibrate /data/chamber)

  Writes FOLDER/session.toml for the logs (.csv, .tsv, .txt, .dat) of FOLDER,
  one run each: delimiter, columns and time unit from the header, each run's
  orientation from its file name (x_pos, OX+, xp, zminus, +z ...) or else from
  its mean output (gravity), units from the size of the output and the rate
  from the median time step. Given one log (.csv, .txt, .tsv, .dat, .parquet,
  .tdms), writes the session.toml beside it with log = that file: the
  orientation column found among its columns (labels OX+ ... OZ-), a TDMS
  file's groups by their orientation property, name or mean output. Prints
  every guess; asks nothing. An existing session.toml is kept (exit status 2)
  unless --force; an input is never written over.""",
    "simulate": """example:
  accelcore simulate /tmp/adxl335-session --sensor ADXL335 --seed 7 --duration-h 2""",
    "bench": """example:
  accelcore bench                          (from a source checkout's root: ./benches)
  accelcore bench --benches ~/src/accelcore/benches --quick --cases kernels

  Runs the benchmark cases of a checkout's benches/ folder with the installed
  harness (accelcore.apps.bench); the cases are not installed with the package.
  Every argument after 'bench' goes to the harness: 'accelcore bench --help'.""",
    "demo": """example:
  accelcore demo                      (the bundled example, generated on first use)
  accelcore demo --dir /tmp/demo      (somewhere else)""",
}


#: What a SESSION argument may be.
_SESSION_HELP = (
    "session folder (holding session.toml), a single log it names or that states its "
    "settings (.csv, .parquet, .tdms ...), or a PX4 .ulg / ArduPilot .bin log"
)


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


def _positive(text: str) -> float:
    value = _window(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def _non_negative(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {value}")
    return value


def _add_instance(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--instance",
        type=_non_negative,
        default=0,
        metavar="N",
        help="IMU instance read from a flight log (.ulg, .bin); default 0, the first IMU",
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
        p = sub.add_parser(
            name,
            help=help_text,
            description=help_text,
            epilog=_EPILOGS[name],
            formatter_class=fmt,
            **kw,
        )
        if name != "bench":  # every argument after 'bench' is the bench runner's
            p.add_argument("--quiet", action="store_true", help="no progress on stderr")
        return p

    p = add("calibrate", "calibrate a session: summary and datasheet comparison")
    p.add_argument(
        "session",
        metavar="SESSION",
        help=_SESSION_HELP,
    )
    p.add_argument("--method", choices=("joint", "paper"), default="joint", help="default: joint")
    p.add_argument("--t-ref", type=_window, default=25.0, metavar="C", help="default: 25 °C")
    p.add_argument(
        "--window",
        nargs=2,
        type=_window,
        default=None,
        metavar=("LO", "HI"),
        help="temperature window of the fit, °C (default: the logged range; the seed "
        "paper used 0 60)",
    )
    p.add_argument("--json", metavar="OUT", help="write the result as JSON ('-': stdout)")
    p.add_argument("--save", metavar="CAL.json", help="save the calibration file")
    _add_instance(p)
    _add_no_cache(p)
    p.set_defaults(func=commands.cmd_calibrate, data_path="session")

    p = add("compensate", "turn a raw log into acceleration in g with a saved calibration")
    p.add_argument("calibration", metavar="CAL.json", help="file written by calibrate --save")
    p.add_argument(
        "input",
        metavar="INPUT",
        help="raw log: delimited text or .parquet (any size: read in chunks), or a flight log "
        "(.ulg, .bin)",
    )
    p.add_argument(
        "-o", "--output", required=True, metavar="OUT", help="output CSV, or .parquet (Parquet)"
    )
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
    _add_instance(p)
    p.add_argument("--chunk-rows", type=int, default=DEFAULT_CHUNK_ROWS, help=argparse.SUPPRESS)
    p.set_defaults(func=commands.cmd_compensate, data_path="input")

    p = add("export", "write a calibration as PX4, ArduPilot or imucal parameters")
    p.add_argument("calibration", metavar="CAL.json", help="file written by calibrate --save")
    p.add_argument("--to", required=True, choices=("px4", "ardupilot", "imucal"), dest="target")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="file to write")
    p.add_argument(
        "--instance",
        type=int,
        metavar="I",
        help="PX4: TC_A<I>_* (default: the ULog's sensor_accel instance, else 0)",
    )
    p.add_argument(
        "--device-id",
        type=int,
        metavar="ID",
        help="PX4: the sensor's TC_A<I>_ID (default: the ULog's device_id, else 0)",
    )
    p.add_argument(
        "--imu",
        type=int,
        metavar="N",
        help="ArduPilot: INS_TCAL<N>_* (default: the DataFlash log's IMU, else 1)",
    )
    p.add_argument(
        "--temperature",
        type=_window,
        metavar="C",
        help="imucal: temperature of the exported calibration (default: T_ref)",
    )
    p.set_defaults(func=commands.cmd_export, data_path="calibration")

    p = add("diagnose", "calibrate and diagnose what the model still gets wrong")
    p.add_argument(
        "session",
        metavar="SESSION",
        help=_SESSION_HELP,
    )
    p.add_argument("--json", metavar="OUT", help="write the result as JSON ('-': stdout)")
    p.add_argument(
        "--save",
        metavar="CAL.json",
        help="save the diagnosed calibration (with the added effects; compensate and "
        "export read it)",
    )
    _add_instance(p)
    _add_no_cache(p)
    p.set_defaults(func=commands.cmd_diagnose, data_path="session")

    p = add("bulk", "calibrate and diagnose every session under an archive folder")
    p.add_argument(
        "archive",
        metavar="ARCHIVE",
        help="folder searched for session folders and flight logs (.ulg, .bin), any depth",
    )
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="output folder")
    p.add_argument("--jobs", type=int, metavar="N", help="worker processes (default: all cores)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="run on a Dask cluster (tcp://HOST:PORT)")
    p.add_argument("--no-diagnose", action="store_true", help="calibrate only")
    p.add_argument("--force", action="store_true", help="redo sessions that are up to date")
    _add_instance(p)
    _add_no_cache(p)
    p.set_defaults(func=commands.cmd_bulk, data_path="archive")

    p = add("report", "write an HTML report of a session or of a bulk output")
    p.add_argument(
        "path",
        metavar="SESSION|OUT",
        help="session folder, log (.csv, .parquet, .tdms ...; .ulg, .bin), or output folder of "
        "accelcore bulk",
    )
    p.add_argument(
        "-o",
        "--output",
        metavar="DIR",
        help="folder for index.html (required for a session; default for a bulk output: OUT)",
    )
    _add_instance(p)
    _add_no_cache(p)
    p.set_defaults(func=commands.cmd_report, data_path="path")

    p = add("init", "write a session.toml for a folder of logs or for one log, guessing its layout")
    p.add_argument(
        "folder",
        metavar="FOLDER|LOG",
        help="folder of logs, one run per file; or one log (.csv, .parquet, .tdms ...) with an "
        "orientation column or groups, its session.toml written beside it (log = ...)",
    )
    p.add_argument("--force", action="store_true", help="write over an existing session.toml")
    p.add_argument("--units", choices=UNITS, help="output units (default: guessed)")
    p.add_argument("--rate-hz", type=_positive, metavar="HZ", help="default: median time step")
    p.add_argument("--delimiter", help="',', '\\t' or ';' (default: guessed from the header)")
    p.add_argument("--sensor", help="part name written to session.toml (datasheet comparison)")
    p.add_argument("--serial", help="serial written to session.toml")
    p.set_defaults(func=commands.cmd_init, data_path="folder")

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
    p.set_defaults(func=commands.cmd_simulate, data_path="out")

    p = add(
        "bench",
        "benchmarks: run the cases of a checkout's benches/ folder (--benches DIR)",
        add_help=False,
    )
    p.add_argument("bench_args", nargs=argparse.REMAINDER, help=argparse.SUPPRESS)
    p.set_defaults(func=commands.cmd_bench, data_path=None)

    p = add("demo", "calibrate and diagnose the bundled example session")
    p.add_argument(
        "--dir",
        metavar="DIR",
        help="folder of the demo session (default: examples/adxl335-demo/generated in the "
        "source tree if writable, else a cache folder); generated there if absent",
    )
    p.add_argument("--regenerate", action="store_true", help="generate the session again")
    _add_no_cache(p)
    p.set_defaults(func=commands.cmd_demo, data_path="dir")
    return parser
