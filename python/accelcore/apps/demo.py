"""``accelcore demo`` (what ``make demo`` runs): calibrate a bundled example session.

The example is a simulated ADXL335 session with the paper's measured
parameters as truth (six orientations, 2 h sweeps from -2 °C to 65 °C at
20 Hz), generated reproducibly (fixed seed) on first use into
``examples/adxl335-demo/generated`` of the source tree, or into a cache
folder when the package is installed elsewhere. The demo calibrates it with
both methods and prints the summary, the datasheet comparison laid out like
the paper's Tables 3/4 and 5/6, the recovered against the true temperature
coefficients and, when :mod:`accelcore.diagnosis` is available, the diagnosis.
"""

from __future__ import annotations

import importlib
import json
import math
import os
import shutil
import sys
import time
import tomllib
from pathlib import Path
from typing import Any, Final, TextIO

from accelcore import simulate
from accelcore._accelcore import __version__
from accelcore.files import atomic_write
from accelcore.fitting.calibrate import calibrate
from accelcore.input.session import load_session
from accelcore.outputs.tables import datasheet_section, summary_text
from accelcore.result.calibration import Calibration

__all__ = ["DEMO_PARAMETERS", "default_directory", "ensure_session", "run"]

#: Everything that determines the demo session's files.
DEMO_PARAMETERS: Final[dict[str, Any]] = {
    "demo_version": 1,
    "sensor": "ADXL335",
    "seed": 335,
    "duration_h": 2.0,
    "cool_back": False,
    "orientations": ["OX+", "OX-", "OY+", "OY-", "OZ+", "OZ-"],
    "serial": "DEMO-0001",
}
_STAMP: Final = "demo.json"


def default_directory() -> Path:
    """Where the demo session lives by default.

    Returns
    -------
    pathlib.Path
        ``examples/adxl335-demo/generated`` of the source tree when the package
        runs from a writable checkout, else ``$XDG_CACHE_HOME/accelcore/adxl335-demo``
        (``~/.cache`` when unset).
    """
    root = Path(__file__).resolve().parents[2]
    in_checkout = (root / "pyproject.toml").is_file() and (root / "python" / "accelcore").is_dir()
    examples = root / "examples"
    writable = os.access(examples if examples.is_dir() else root, os.W_OK)
    if in_checkout and writable:
        return examples / "adxl335-demo" / "generated"
    cache = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(cache) / "accelcore" / "adxl335-demo"


def _stamp_matches(folder: Path) -> bool:
    try:
        stamp = json.loads((folder / _STAMP).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return bool(stamp == DEMO_PARAMETERS and (folder / "session.toml").is_file())


def ensure_session(
    directory: str | Path | None = None, *, regenerate: bool = False
) -> tuple[Path, float | None]:
    """Generate the demo session unless an identical one is already there.

    The session is written to a temporary sibling folder and renamed into
    place, so an interrupted run never leaves a half-written session behind (a
    folder: :func:`accelcore.files.atomic_write` is for single files; the stamp
    ``demo.json`` inside it, which marks the session complete, is written with it).

    Parameters
    ----------
    directory : str or Path, optional
        The session folder; default :func:`default_directory`.
    regenerate : bool, default False
        Generate it again even when present.

    Returns
    -------
    (pathlib.Path, float or None)
        The folder and the generation time in seconds (None when reused).

    Raises
    ------
    FileExistsError
        The folder exists, is not empty and is not a demo session.
    """
    folder = Path(directory) if directory is not None else default_directory()
    if not regenerate and _stamp_matches(folder):
        return folder, None
    if folder.exists():
        if not folder.is_dir():
            raise FileExistsError(f"{folder}: exists and is not a folder")
        if any(folder.iterdir()) and not (folder / _STAMP).is_file():
            raise FileExistsError(
                f"{folder}: not empty and not an accelcore demo session; choose another --dir"
            )
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = folder.with_name(f".{folder.name}.{os.getpid()}.tmp")
    start = time.perf_counter()
    try:
        p = DEMO_PARAMETERS
        simulate.session(
            tmp,
            str(p["sensor"]),
            seed=int(p["seed"]),
            duration_h=float(p["duration_h"]),
            cool_back=bool(p["cool_back"]),
            orientations=list(p["orientations"]),
            serial=str(p["serial"]),
            overwrite=True,
        )
        atomic_write(tmp / _STAMP, json.dumps(DEMO_PARAMETERS, indent=1) + "\n")
        if folder.exists():
            shutil.rmtree(folder)
        os.replace(tmp, folder)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp)
    return folder, time.perf_counter() - start


def _truth(folder: Path) -> dict[str, Any] | None:
    try:
        with open(folder / "truth.toml", "rb") as fh:
            return tomllib.load(fh)
    except (OSError, tomllib.TOMLDecodeError):
        return None


def _tc_table(joint: Calibration, paper: Calibration, truth: dict[str, Any] | None) -> str:
    lines = [
        "Temperature coefficients: recovered vs true (± one standard error)",
        f"  {'axis':<5}{'parameter':<17}{'true':>9}{'joint':>22}{'paper':>22}",
    ]
    rows = (
        ("offset TC mg/°C", "offset_tc_mg_per_c", 4),
        ("sens. TC %/°C", "sensitivity_tc_pct_per_c", 5),
    )
    for i, a in enumerate(joint.axes):
        for label, key, digits in rows:
            true = math.nan if truth is None else float(truth[key][i])
            cells = []
            for cal in (joint, paper):
                s = cal.axis(a)
                v, se = getattr(s, key), getattr(s, key + "_se")
                cells.append(f"{v:+.{digits}f} ± {se:.{digits}f}" if math.isfinite(v) else "n/a")
            lines.append(f"  {a:<5}{label:<17}{true:>+9.{digits - 1}f}{cells[0]:>22}{cells[1]:>22}")
    return "\n".join(lines)


def run(
    directory: str | Path | None = None,
    *,
    regenerate: bool = False,
    out: TextIO | None = None,
    cache: bool = True,
) -> int:
    """Generate (if needed), calibrate and print the demo session.

    Parameters
    ----------
    directory : str or Path, optional
        The demo session folder; default :func:`default_directory`.
    regenerate : bool, default False
        Generate the session again even when present.
    out : text stream, optional
        Where to print (default ``sys.stdout``).
    cache : bool, default True
        Use the run cache (``load_session(..., cache=)``).

    Returns
    -------
    int
        0.
    """
    stream = out or sys.stdout
    folder, took = ensure_session(directory, regenerate=regenerate)
    p = DEMO_PARAMETERS
    how = "reused" if took is None else f"generated in {took:.1f} s"
    try:
        shown = folder.resolve().relative_to(Path.cwd().resolve())
    except ValueError:
        shown = folder
    print(
        f"accelcore {__version__} demo: thermal calibration of a simulated {p['sensor']}",
        file=stream,
    )
    print(
        f"session {shown} ({how}; seed {p['seed']}, {len(p['orientations'])} orientations, "
        f"{p['duration_h']:g} h sweeps -2→65 °C at 20 Hz, the paper's measured part as truth)",
        file=stream,
    )
    session = load_session(folder, cache=cache)
    joint = calibrate(session, "joint")
    paper = calibrate(session, "paper")
    print(f"\n{summary_text(joint)}", file=stream)
    text, _ = datasheet_section(joint)
    print(f"\n{text}", file=stream)
    print(f"\n{_tc_table(joint, paper, _truth(folder))}", file=stream)
    # Looked up when the demo runs, so an installation without the diagnosis
    # still prints the calibration.
    try:
        diagnosis = importlib.import_module("accelcore.diagnosis")
    except ImportError:
        print("\n(diagnosis not available in this installation)", file=stream)
        return 0
    result = diagnosis.diagnose(session, calibration=joint)
    print(f"\n{result.text()}", file=stream)
    return 0
