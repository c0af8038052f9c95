"""Case (a): the kernels in memory, accelcore vs ``accelcore.reference`` (NumPy)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from accelcore import core, reference
from accelcore.apps.bench import Context, Table, measure
from benches.data import FloatArray, log

BINS: dict[str, Any] = {"lo_c": -40.0, "hi_c": 85.0, "width_c": 0.5}
T_REF_C = 25.0
#: Issue 18: the kernels at least this many times the reference at TARGET_N samples.
TARGET_RATIO, TARGET_N = 10.0, 1_000_000
TARGET_ROWS = ("decimate: accelcore", "bin: accelcore")


def _decimate(mod: Any, t: FloatArray, temp: FloatArray, ch: FloatArray) -> object:
    d = mod.Decimator()
    d.push(t, temp, ch)
    return d.finish()


def _bin(mod: Any, t: FloatArray, temp: FloatArray, ch: FloatArray) -> object:
    b = mod.TemperatureBinner(**BINS)
    b.push(t, temp, ch)
    return b.finish()


def _lstsq(mod: Any, design: FloatArray, y: FloatArray) -> object:
    ls = mod.LeastSquares(2)
    ls.push(design, y)
    return ls.finish()


def _one_size(table: Table, n: int, repeat: int, ref_repeat: int) -> None:
    t, temp, ch = log(n)
    design = np.column_stack([np.ones(n), temp - T_REF_C])
    y = np.ascontiguousarray(ch[:, 0])
    cases: list[tuple[str, Callable[[], object], Callable[[], object]]] = [
        (
            "decimate",
            lambda: _decimate(core, t, temp, ch),
            lambda: _decimate(reference, t, temp, ch),
        ),
        ("bin", lambda: _bin(core, t, temp, ch), lambda: _bin(reference, t, temp, ch)),
        ("lstsq (p=2)", lambda: _lstsq(core, design, y), lambda: _lstsq(reference, design, y)),
    ]
    for kernel, fast, slow in cases:
        table.rows += [
            measure(f"{kernel}: accelcore", fast, n=n, repeat=repeat),
            measure(f"{kernel}: reference", slow, n=n, repeat=ref_repeat),
        ]


def run(ctx: Context) -> list[Table]:
    sizes = [100_000] if ctx.quick else [1_000_000, 10_000_000]
    if ctx.large:
        sizes.append(100_000_000)
    table = Table("(a) kernels in memory: time, temperature, 3 channels, float64")
    for n in sizes:
        repeat = 1 if ctx.quick else (5 if n <= 1_000_000 else 3 if n <= 10_000_000 else 1)
        # The reference takes seconds per run from 1e7 samples on: one repetition there.
        _one_size(table, n, repeat, 1 if n >= 10_000_000 else repeat)
    table.set_ratios(
        lambda r: r.name.replace("accelcore", "reference") if "accelcore" in r.name else None
    )
    for row in table.rows:
        if row.n == TARGET_N and row.name in TARGET_ROWS and row.ratio is not None:
            row.target = f">={TARGET_RATIO:g}x"
            row.met = "yes" if row.ratio >= TARGET_RATIO else "no"
    table.notes.append(
        "ratio = reference median / accelcore median (same data, same run); "
        "rate/cpu-s uses the thread's CPU time (the machine may be shared)"
    )
    table.notes.append(
        f"target: >={TARGET_RATIO:g}x the reference at 1e6 samples for the kernels calibrate's "
        "path runs on raw samples (decimate; bin, which the paper's method runs on the blocks)"
    )
    return [table]
