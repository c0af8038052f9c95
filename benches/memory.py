"""Case (f): peak RSS of the fused pipeline over a log streamed in chunks, per subprocess.

Run as ``python -m benches.memory N CHUNK``: generates ``N`` samples chunk by
chunk (never whole), pushes them through ``FusedPipeline`` and prints JSON with
the baseline RSS after imports, the peak RSS (VmHWM) and the elapsed time.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time

from accelcore.bench import REPO, Context, Row, Table

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


def run(ctx: Context) -> list[Table]:
    hour = 72_000  # samples per hour at 20 Hz
    chunk = 72_000  # one hour of log per push
    sizes = [("10 h log", 10 * hour), ("100 h log", 100 * hour)]
    if ctx.quick:
        sizes = [("1 h log", hour)]
    if ctx.large:
        sizes.append(("1e9 samples", 1_000_000_000))
        chunk = 1 << 20
    table = Table("(f) memory: FusedPipeline over a log generated and pushed chunk by chunk")
    for label, n in sizes:
        out = subprocess.run(
            [sys.executable, "-m", "benches.memory", str(n), str(chunk)],
            cwd=REPO,
            capture_output=True,
            text=True,
            check=True,
        )
        r = json.loads(out.stdout)
        row = Row(
            name=f"fused, {label}",
            n=n,
            wall_s=r["push_s"],
            cpu_s=r["cpu_s"],
            unit="samples",
            amount=float(n),
            peak_mb=r["peak_mb"],
            target=f"peak-imports < {PEAK_TARGET_MB:.0f} MB",
            met="yes" if r["peak_mb"] - r["base_mb"] < PEAK_TARGET_MB else "no",
            note=(
                f"RSS after imports {r['base_mb']:.1f} MB, peak {r['peak_mb']:.1f} MB; "
                f"generation + push {r['wall_s']:.2f} s, push alone {r['push_s']:.2f} s"
            ),
        )
        table.rows.append(row)
    table.notes.append(
        "peak MB = whole-process VmHWM (interpreter, NumPy, pandas imported by accelcore, "
        "one generated chunk, pipeline); the target is judged on peak minus the RSS after "
        "imports; median s/rate = time inside push() only (one run); cpu s = the child's "
        "generation + push"
    )
    return [table]


if __name__ == "__main__":
    print(json.dumps(child(int(sys.argv[1]), int(sys.argv[2]))))
