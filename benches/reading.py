"""Case (b): one 20 Hz session log (CSV) from disk to decimated arrays."""

from __future__ import annotations

import importlib.util
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from accelcore import reference
from accelcore._accelcore import read_run
from accelcore.apps.bench import Context, Row, Table, measure
from benches.data import FloatArray
from benches.session_data import count_rows, session_dir

COLUMNS = ["time_s", "temp_c", "x", "y", "z"]


def _decimate(t: FloatArray, temp: FloatArray, ch: FloatArray) -> object:
    d = reference.Decimator()
    d.push(t, temp, ch)
    return d.finish()


def with_loadtxt(path: Path) -> object:
    a = np.loadtxt(path, delimiter=",", skiprows=1)
    return _decimate(a[:, 0], a[:, 1], a[:, 2:5])


def with_pandas(path: Path) -> object:
    import pandas as pd

    df = pd.read_csv(path, usecols=COLUMNS)
    return _decimate(
        df["time_s"].to_numpy(), df["temp_c"].to_numpy(), df[["x", "y", "z"]].to_numpy()
    )


def polars_alone(path: Path) -> object:
    import polars as pl

    return pl.read_csv(path)


def with_polars(path: Path) -> object:
    df: Any = polars_alone(path)
    return _decimate(
        df["time_s"].to_numpy(), df["temp_c"].to_numpy(), df.select(["x", "y", "z"]).to_numpy()
    )


def run(ctx: Context) -> list[Table]:
    hours = 0.5 if ctx.quick else 3.5  # 3.5 h at 20 Hz = 252 000 rows
    path = session_dir(ctx.workdir, hours) / "x_pos.csv"
    n_rows = count_rows(path)
    mb = path.stat().st_size / 1e6
    repeat = 1 if ctx.quick else 5
    table = Table(f"(b) reading {path.name}: {n_rows} rows, {mb:.1f} MB -> 2 Hz block means")
    candidates: list[tuple[str, str | None, Callable[[], object]]] = [
        ("accelcore.read_run", None, lambda: read_run(str(path))),
        ("numpy.loadtxt + ref decimate", None, lambda: with_loadtxt(path)),
        ("pandas.read_csv + ref decimate", "pandas", lambda: with_pandas(path)),
        ("polars.read_csv + ref decimate", "polars", lambda: with_polars(path)),
        ("polars.read_csv alone", "polars", lambda: polars_alone(path)),
    ]
    for name, package, fn in candidates:
        if package is not None and importlib.util.find_spec(package) is None:
            table.notes.append(f"skipped {name}: {package} is not installed")
            continue
        table.rows.append(measure(name, fn, n=n_rows, repeat=repeat, unit="MB", amount=mb))
    names = {r.name for r in table.rows}
    ours: Row = table.rows[0]
    if "polars.read_csv alone" in names:
        ours.target = ">= polars.read_csv alone"
        table.set_ratios(lambda r: "polars.read_csv alone")
        ours.met = "yes" if (ours.ratio or 0.0) >= 1.0 else "no"
    else:
        table.set_ratios(lambda r: "numpy.loadtxt + ref decimate")
    table.notes.append(
        "ratio = baseline median / row median; polars runs on one thread "
        "(POLARS_MAX_THREADS=1), as do all the others; polars parses in its own worker "
        "thread, so its rate/cpu-s (calling thread only) is not comparable"
    )
    return [table]
