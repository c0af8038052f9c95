"""Case (c): calibrate a six-run session from disk, accelcore vs pandas + NumPy.

accelcore is measured twice: cold (``cache=False``: every log parsed and hashed)
and with a warm run cache (``accelcore.input.cache``), as when an archived session is
loaded again to calibrate, diagnose and report.
"""

from __future__ import annotations

import importlib.util
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

import accelcore
from accelcore.apps.bench import Context, Table, measure
from accelcore.input import cache
from benches.session_data import count_rows, session_dir

RUNS = {
    "x": ("x_pos.csv", "x_neg.csv"),
    "y": ("y_pos.csv", "y_neg.csv"),
    "z": ("z_pos.csv", "z_neg.csv"),
}
AXIS = {"x": 0, "y": 1, "z": 2}
PANDAS = "pandas read_csv+groupby+polyfit"
TARGET = 10.0


def with_accelcore(path: Path, run_cache: cache.CacheSetting = False) -> object:
    """What the CLI's ``calibrate`` does: load (streaming read + decimate) and fit."""
    return accelcore.calibrate(accelcore.load_session(path, cache=run_cache), method="paper")


def prime_cache(path: Path, folder: Path) -> int:
    """Fill ``folder`` with the session's entries (untimed); return how many were written.

    The cache writes no entry for a file changed (mtime or ctime) less than
    ``cache.RACY_WINDOW_NS`` ago. Setting the mtime back would not help (it makes
    the ctime new), so wait for whatever is left of that window: usually nothing,
    as the cold and pandas rows ran since the session was written.
    """
    cache.clear(folder)
    newest = max(
        max(f.stat().st_mtime_ns, f.stat().st_ctime_ns) for f in path.iterdir() if f.is_file()
    )
    wait_ns = newest + cache.RACY_WINDOW_NS + 10_000_000 - time.time_ns()
    if wait_ns > 0:
        time.sleep(wait_ns / 1e9)
    with_accelcore(path, folder)
    return sum(1 for f in os.scandir(folder) if f.name.endswith(cache.SUFFIX))


def with_pandas(path: Path) -> dict[str, Any]:
    """The paper's method as a user would write it with pandas and NumPy."""
    import pandas as pd

    def binned(file: str) -> Any:
        df = pd.read_csv(path / file)
        blocks = df.groupby(np.arange(len(df)) // 10).mean()  # 20 Hz -> 2 Hz
        blocks = blocks[(blocks["temp_c"] >= 0.0) & (blocks["temp_c"] < 60.0)]
        key = np.floor(blocks["temp_c"] / 0.5).astype(int)
        return blocks.groupby(key).mean()

    out: dict[str, Any] = {}
    for axis, (plus_file, minus_file) in RUNS.items():
        plus, minus = binned(plus_file), binned(minus_file)
        both = plus.add_suffix("_p").join(minus.add_suffix("_m"), how="inner")
        temp = 0.5 * (both["temp_c_p"] + both["temp_c_m"]).to_numpy()
        v_p, v_m = both[f"{axis}_p"].to_numpy(), both[f"{axis}_m"].to_numpy()
        offset = np.polyfit(temp - 25.0, 0.5 * (v_p + v_m), 1)
        sensitivity = np.polyfit(temp - 25.0, 0.5 * (v_p - v_m), 1)
        out[axis] = (offset, sensitivity)
    return out


def run(ctx: Context) -> list[Table]:
    hours = 0.5 if ctx.quick else 3.5
    path = session_dir(ctx.workdir, hours)
    files = sorted(path.glob("*.csv"))
    n_rows = sum(count_rows(f) for f in files)
    mb = sum(f.stat().st_size for f in files) / 1e6
    repeat = 1 if ctx.quick else 3
    table = Table(
        f"(c) end to end: calibrate(method='paper') of six runs, {n_rows} rows, {mb:.0f} MB"
    )
    cold = measure(
        "accelcore load_session+calibrate, cold",
        lambda: with_accelcore(path, False),
        n=n_rows,
        repeat=repeat,
        unit="MB",
        amount=mb,
        note="cache=False: every log parsed, decimated and hashed",
    )
    table.rows.append(cold)
    if importlib.util.find_spec("pandas") is None:
        table.notes.append("skipped pandas + NumPy: pandas is not installed")
    else:
        table.rows.append(
            measure(
                PANDAS,
                lambda: with_pandas(path),
                n=n_rows,
                repeat=repeat,
                unit="MB",
                amount=mb,
            )
        )
    folder = ctx.workdir / "run-cache"
    written = prime_cache(path, folder)
    warm = measure(
        "accelcore load_session+calibrate, warm cache",
        lambda: with_accelcore(path, folder),
        n=n_rows,
        repeat=max(repeat, 3),
        unit="MB",
        amount=mb,
        note=f"cache primed by one untimed call ({written} entries, "
        f"{sum(f.stat().st_size for f in folder.glob('*' + cache.SUFFIX)) / 1e6:.1f} MB); "
        "session.toml still read and hashed",
    )
    table.rows.insert(1, warm)
    if written != len(files):
        table.notes.append(f"warning: the primed cache holds {written} of {len(files)} runs")
    table.set_ratios(lambda r: PANDAS)
    for row in (cold, warm):
        row.target = f">={TARGET:g}x"
        row.met = "-" if row.ratio is None else ("yes" if row.ratio >= TARGET else "no")
    table.notes.append("ratio = pandas + NumPy median / row median")
    return [table]
