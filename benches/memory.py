"""Case (f): peak RSS of a streamed calibration, one subprocess per row.

Two kinds of row:

- ``python -m benches.memory session PATH``: ``load_session`` + ``calibrate`` of a
  session folder on disk (a 10-hour, 20 Hz log: the file is read in 1 MB blocks,
  never whole);
- ``python -m benches.memory N CHUNK``: generates ``N`` samples chunk by chunk
  (never whole) and pushes them through ``FusedPipeline``, up to 1e9 samples.

Each prints JSON with the RSS after imports, the peak RSS (VmHWM) and the times.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

from accelcore import simulate
from accelcore.apps.bench import Context, Row, Table
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


def child(n: int, chunk: int) -> dict[str, float]:
    from accelcore.core import FusedPipeline
    from benches.data import stream

    base_kb = _kb("VmRSS")
    p = FusedPipeline(lo_c=-40.0, hi_c=85.0, width_c=0.5)
    c0, w0 = time.thread_time(), time.perf_counter()
    push_s = 0.0
    for t, temp, ch in stream(n, chunk):
        s = time.perf_counter()
        p.push(t, temp, ch)
        push_s += time.perf_counter() - s
    result = p.finish()
    return {
        "n": n,
        "base_mb": base_kb / 1024,
        "peak_mb": _kb("VmHWM") / 1024,
        "wall_s": time.perf_counter() - w0,
        "cpu_s": time.thread_time() - c0,
        "push_s": push_s,
        "n_blocks": float(result.n_blocks),
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
    # One hour of log per push, whatever the length: the generator's chunk (and its
    # temporaries) is part of the peak, so a larger chunk would measure the harness.
    chunk = 72_000
    sizes = [("10 h log", 10 * hour), ("100 h log", 100 * hour)]
    if ctx.quick:
        sizes = [("1 h log", hour)]
    if ctx.large:
        sizes.append(("1e9 samples", 1_000_000_000))
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
        r = _in_child(str(n), str(chunk))
        table.rows.append(
            _memory_row(
                f"fused, {label}",
                r,
                r["push_s"],
                n,
                f"generation + push {r['wall_s']:.2f} s, push alone {r['push_s']:.2f} s",
            )
        )
    table.notes.append(
        "peak MB = whole-process VmHWM (interpreter, NumPy, pandas imported by accelcore, "
        "reader buffers or one generated chunk, pipeline); the target is judged on peak minus "
        "the RSS after imports; median s/rate = load_session + calibrate, or time inside "
        "push() only (one run); cpu s = the child's main thread"
    )
    return [table]


if __name__ == "__main__":
    if sys.argv[1] == "session":
        print(json.dumps(child_session(sys.argv[2])))
    else:
        print(json.dumps(child(int(sys.argv[1]), int(sys.argv[2]))))
