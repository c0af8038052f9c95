"""Case (f): peak RSS of a streamed calibration, one subprocess per row.

Two kinds of row:

- ``python -m benches.memory session PATH``: ``load_session`` + ``calibrate`` of a
  session folder on disk (a 10-hour, 20 Hz log: the file is read in 1 MB blocks,
  never whole);
- ``python -m benches.memory read PATH``: the streaming path the library has for
  long logs, ``read_run`` (the Rust reader streams rows into the decimator and
  keeps only the 2 Hz block means), on generated logs of 10 h and 100 h at 20 Hz
  (1 h with ``--quick``; ``--large`` adds 1000 h, 72 M rows, about 4 GB). The logs
  are written chunk by chunk in fixed-width columns with NumPy (``np.savetxt``
  takes about 15 us a row, 18 minutes for 1000 h; this takes seconds) and kept in
  the work folder. A log of 1e9 samples would be about 50 GB of CSV, so the in-memory
  1e9-sample row of earlier records has no file counterpart here.

Each prints JSON with the RSS after imports, the peak RSS (VmHWM) and the times.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from accelcore import simulate
from accelcore.apps.bench import Context, Row, Table
from benches.data import FloatArray, stream
from benches.session_data import count_rows

# The folder holding benches/: the children run ``python -m benches.memory`` there.
ROOT = Path(__file__).resolve().parents[1]

PEAK_TARGET_MB = 100.0


def _kb(key: str) -> int:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1])
    return 0


def _fixed(values: FloatArray, int_digits: int, decimals: int) -> NDArray[np.uint8]:
    """``values`` as fixed-width text, one row each: sign (``-`` or ``0``), digits, point."""
    scaled = np.rint(np.abs(values) * 10.0**decimals).astype(np.int64)
    powers = 10 ** np.arange(int_digits + decimals - 1, -1, -1, dtype=np.int64)
    digits = ((scaled[:, None] // powers) % 10 + ord("0")).astype(np.uint8)
    out = np.empty((len(values), int_digits + decimals + 2), dtype=np.uint8)
    out[:, 0] = np.where(values < 0, ord("-"), ord("0"))
    out[:, 1 : 1 + int_digits] = digits[:, :int_digits]
    out[:, 1 + int_digits] = ord(".")
    out[:, 2 + int_digits :] = digits[:, int_digits:]
    return out


def write_long_log(path: Path, n: int, chunk: int) -> None:
    """Write ``n`` rows of :func:`benches.data.stream` as a CSV log, chunk by chunk.

    Time to 0.01 s, temperature to 0.001 °C and the channels to 1 uV, as
    ``accelcore.simulate`` writes them, in fixed-width columns (``00000012.35``).
    """
    tmp = path.with_suffix(".tmp")
    comma = np.full((chunk, 1), ord(","), dtype=np.uint8)
    newline = np.full((chunk, 1), ord("\n"), dtype=np.uint8)
    with tmp.open("wb") as f:
        f.write(b"time_s,temp_c,x,y,z\n")
        for t, temp, ch in stream(n, chunk):
            m = len(t)
            fields = [_fixed(t, 8, 2), _fixed(temp, 3, 3)]
            fields += [_fixed(ch[:, j], 1, 6) for j in range(ch.shape[1])]
            parts: list[NDArray[np.uint8]] = []
            for field in fields:
                parts += [field, comma[:m]]
            parts[-1] = newline[:m]
            f.write(np.hstack(parts).tobytes())
    tmp.replace(path)


def child_read(path: str) -> dict[str, float]:
    from accelcore._accelcore import read_run

    base_kb = _kb("VmRSS")
    c0, w0 = time.thread_time(), time.perf_counter()
    run = read_run(path)
    return {
        "n": run.n_rows,
        "base_mb": base_kb / 1024,
        "peak_mb": _kb("VmHWM") / 1024,
        "wall_s": time.perf_counter() - w0,
        "cpu_s": time.thread_time() - c0,
        "n_blocks": float(len(run.blocks.count)),
    }


def child_session(path: str) -> dict[str, float]:
    import accelcore

    base_kb = _kb("VmRSS")
    c0, w0 = time.thread_time(), time.perf_counter()
    session = accelcore.load_session(path, cache=False)
    accelcore.calibrate(session)
    return {
        "base_mb": base_kb / 1024,
        "peak_mb": _kb("VmHWM") / 1024,
        "wall_s": time.perf_counter() - w0,
        "cpu_s": time.thread_time() - c0,
    }


def _in_child(*args: str) -> dict[str, float]:
    out = subprocess.run(
        [sys.executable, "-m", "benches.memory", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    )
    result: dict[str, float] = json.loads(out.stdout)
    return result


def _memory_row(name: str, r: dict[str, float], seconds: float, n: float, note: str) -> Row:
    return Row(
        name=name,
        n=int(n),
        wall_s=seconds,
        cpu_s=r["cpu_s"],
        unit="samples",
        amount=float(n),
        peak_mb=r["peak_mb"],
        target=f"peak-imports < {PEAK_TARGET_MB:.0f} MB",
        met="yes" if r["peak_mb"] - r["base_mb"] < PEAK_TARGET_MB else "no",
        note=f"RSS after imports {r['base_mb']:.1f} MB, peak {r['peak_mb']:.1f} MB "
        f"(+{r['peak_mb'] - r['base_mb']:.1f}); {note}",
    )


def run(ctx: Context) -> list[Table]:
    hour = 72_000  # samples per hour at 20 Hz
    # One hour of log per generated chunk; the parent writes, the child only reads.
    chunk = 72_000
    sizes = [("10 h", 10 * hour), ("100 h", 100 * hour)]
    if ctx.quick:
        sizes = [("1 h", hour)]
    if ctx.large:
        sizes.append(("1000 h", 1000 * hour))
    table = Table("(f) memory: a streamed calibration, peak RSS")
    log_h = 1.0 if ctx.quick else 10.0
    folder = ctx.workdir / f"memory-{log_h:g}h"
    if not (folder / "session.toml").is_file():
        simulate.session(folder, duration_h=log_h, seed=3, orientations=("OZ+",), overwrite=True)
    log = folder / "z_pos.csv"
    r = _in_child("session", str(folder))
    table.rows.append(
        _memory_row(
            f"load_session + calibrate, {log_h:g} h log on disk",
            r,
            r["wall_s"],
            count_rows(log),
            f"{log.stat().st_size / 1e6:.0f} MB of CSV read, hashed and calibrated in "
            f"{r['wall_s']:.2f} s",
        )
    )
    for label, n in sizes:
        path = ctx.workdir / f"memory-long-{n}.csv"
        if not path.is_file():
            write_long_log(path, n, chunk)
        r = _in_child("read", str(path))
        table.rows.append(
            _memory_row(
                f"read_run, {label} log on disk",
                r,
                r["wall_s"],
                n,
                f"{path.stat().st_size / 1e6:.0f} MB of CSV read into "
                f"{r['n_blocks']:.0f} block means in {r['wall_s']:.2f} s",
            )
        )
    table.notes.append(
        "peak MB = whole-process VmHWM (interpreter, NumPy, pandas imported by accelcore, "
        "reader buffers, block means); the target is judged on peak minus the RSS after "
        "imports; median s/rate = load_session + calibrate, or read_run (one run); "
        "cpu s = the child's main thread"
    )
    return [table]


if __name__ == "__main__":
    if sys.argv[1] == "session":
        print(json.dumps(child_session(sys.argv[2])))
    else:
        print(json.dumps(child_read(sys.argv[2])))
