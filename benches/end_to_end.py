"""Case (c): calibrate a six-run session from disk, accelcore vs pandas + NumPy."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Any

import numpy as np

import accelcore
from accelcore.bench import Context, Table, measure
from benches.session_data import count_rows, session_dir

RUNS = {
    "x": ("x_pos.csv", "x_neg.csv"),
    "y": ("y_pos.csv", "y_neg.csv"),
    "z": ("z_pos.csv", "z_neg.csv"),
}
AXIS = {"x": 0, "y": 1, "z": 2}


def with_accelcore(path: Path) -> object:
    """What the CLI's ``calibrate`` does: load (streaming read + decimate) and fit."""
    return accelcore.calibrate(accelcore.load_session(path), method="paper")


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
    ours = measure(
        "accelcore load_session+calibrate",
        lambda: with_accelcore(path),
        n=n_rows,
        repeat=repeat,
        unit="MB",
        amount=mb,
    )
    table.rows.append(ours)
    if importlib.util.find_spec("pandas") is None:
        table.notes.append("skipped pandas + NumPy: pandas is not installed")
        return [table]
    table.rows.append(
        measure(
            "pandas read_csv+groupby+polyfit",
            lambda: with_pandas(path),
            n=n_rows,
            repeat=repeat,
            unit="MB",
            amount=mb,
        )
    )
    table.set_ratios(lambda r: "pandas read_csv+groupby+polyfit")
    ours.target = ">=10x"
    ours.met = "yes" if (ours.ratio or 0.0) >= 10.0 else "no"
    table.notes.append("ratio = pandas + NumPy median / row median")
    return [table]
