"""Benchmark runner: accelcore vs the NumPy reference, pandas and polars.

``accelcore bench`` (or ``python -m accelcore.apps.bench``) runs the cases in the
repository's ``benches/`` folder and prints one table per case. Every row of a
table is measured in the same run on the same data: after an untimed warm-up,
median of several repetitions (wall clock and the thread's CPU time), throughput, peak memory
and the speed ratio to the case's baseline. Targets are reported, never
asserted. Results are saved as JSON under ``benches/results/``.

Peak memory is the growth of the process's peak resident set during one
extra call after the warm-up (``/proc/self/clear_refs`` resets the peak, then
``VmHWM - VmRSS`` is read), so Rust, NumPy and Python allocations all count;
the memory case measures whole subprocesses instead.
"""

from __future__ import annotations

import argparse
import datetime as dt
import gc
import importlib
import json
import os
import platform
import socket
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

# polars reads with every core by default; the targets are per core.
os.environ.setdefault("POLARS_MAX_THREADS", "1")

REPO = Path(__file__).resolve().parents[2]


@dataclass
class Row:
    """One measured line of a table."""

    name: str
    n: int
    wall_s: float
    cpu_s: float
    unit: str  # "samples", "MB" or a count ("fits", "sess")
    amount: float  # samples, MB or counted items processed per repetition
    peak_mb: float | None = None
    baseline: str | None = None
    ratio: float | None = None
    target: str = ""
    met: str = ""
    note: str = ""

    @property
    def rate(self) -> float:
        """Throughput per wall-clock second (samples/s, MB/s, ...)."""
        return self.amount / self.wall_s if self.wall_s > 0 else float("nan")

    @property
    def cpu_rate(self) -> float:
        """Throughput per second of the thread's CPU time."""
        return self.amount / self.cpu_s if self.cpu_s > 0 else float("nan")


@dataclass
class Table:
    """One case: a title, its rows and free-form notes."""

    title: str
    rows: list[Row] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def set_ratios(self, baseline_of: Callable[[Row], str | None]) -> None:
        """Fill ``ratio`` = baseline time / row time, baselines named per row."""
        by_key = {(r.name, r.n): r for r in self.rows}
        for r in self.rows:
            base_name = baseline_of(r)
            base = by_key.get((base_name, r.n)) if base_name else None
            if base is not None:
                r.baseline = base_name
                r.ratio = base.wall_s / r.wall_s


@dataclass
class Context:
    """Options shared by the cases."""

    large: bool
    quick: bool
    workdir: Path


def _status_kb(key: str) -> int:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1])
    return 0


def reset_peak_rss() -> bool:
    """Reset VmHWM to the current RSS (Linux >= 4.0); False if not possible."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        return False
    return True


def peak_rss_growth_mb(fn: Callable[[], object]) -> float | None:
    """Growth of the peak RSS while ``fn`` runs, MB (None where unsupported)."""
    gc.collect()
    if not reset_peak_rss():
        return None
    before = _status_kb("VmRSS")
    fn()
    return max(_status_kb("VmHWM") - before, 0) / 1024.0


WARMUP_S = 0.25
"""Seconds of untimed calls before a row's timed repetitions (at least one call)."""


def warm_up(fn: Callable[[], object], seconds: float = WARMUP_S) -> int:
    """Call ``fn`` untimed until ``seconds`` have passed (at least once); return the calls.

    Every row, baselines included, is warmed the same way (criterion warms up
    for 3 s, pytest-benchmark and asv have a warm-up too). On the 2-vCPU VM of
    ``benches/results`` a kernel called right after another workload runs up to
    25 % slower for its first ~50 ms (the fused pipeline at 1e6 samples:
    7.9 ms on the first call after the NumPy reference, 6.2-6.5 ms from about
    the tenth); the timed repetitions measure the settled rate.
    """
    start = time.perf_counter()
    calls = 0
    while True:
        fn()
        calls += 1
        if time.perf_counter() - start >= seconds:
            return calls


def measure(
    name: str,
    fn: Callable[[], object],
    *,
    n: int,
    repeat: int,
    unit: str = "samples",
    amount: float | None = None,
    memory: bool = True,
    note: str = "",
    warmup_s: float = WARMUP_S,
) -> Row:
    """Peak-RSS growth of one call, then the median of ``repeat`` timed calls after a warm-up.

    With ``memory``, one untimed call comes first, so one-off costs (imports,
    first allocations) are not in the memory figure. Then, as in
    :mod:`timeit`, the garbage collector is run once and disabled; the
    warm-up (:func:`warm_up`, ``warmup_s`` seconds, at least one call) and the
    timed repetitions follow back to back. A collection walks the whole Python
    heap: between repetitions it evicts the inputs from the processor's cache
    and, on the machine of ``benches/results``, adds 1-1.5 ms to a 6 ms call
    (``docs/benchmarks.md``); inside one it would time the collector.
    """
    peak = None
    if memory:
        fn()
        peak = peak_rss_growth_mb(fn)
    walls, cpus = [], []
    gc.collect()
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        warm_up(fn, warmup_s)
        for _ in range(repeat):
            c0, w0 = time.thread_time(), time.perf_counter()
            fn()
            w1, c1 = time.perf_counter(), time.thread_time()
            walls.append(w1 - w0)
            cpus.append(c1 - c0)
    finally:
        if was_enabled:
            gc.enable()
    return Row(
        name=name,
        n=n,
        wall_s=statistics.median(walls),
        cpu_s=statistics.median(cpus),
        unit=unit,
        amount=float(n if amount is None else amount),
        peak_mb=peak,
        note=note,
    )


def _si(value: float) -> str:
    for scale, suffix in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if abs(value) >= scale:
            return f"{value / scale:.3g}{suffix}"
    return f"{value:.3g}"


def format_table(table: Table) -> str:
    """Plain-text table, one line per row."""
    head = (
        "name",
        "n",
        "median s",
        "cpu s",
        "rate/s",
        "rate/cpu-s",
        "peak MB",
        "ratio",
        "target",
        "met",
    )
    lines = []
    for r in table.rows:
        unit = "samp" if r.unit == "samples" else r.unit
        lines.append(
            (
                r.name,
                _si(r.n),
                f"{r.wall_s:.4f}",
                f"{r.cpu_s:.4f}",
                f"{_si(r.rate)} {unit}",
                f"{_si(r.cpu_rate)} {unit}",
                "-" if r.peak_mb is None else f"{r.peak_mb:.1f}",
                "-" if r.ratio is None else f"{r.ratio:.2f}x",
                r.target,
                r.met,
            )
        )
    widths = [max(len(h), *(len(x[i]) for x in lines)) for i, h in enumerate(head)]
    out = [f"== {table.title}"]
    out.append("  ".join(h.ljust(w) for h, w in zip(head, widths, strict=True)))
    out.append("  ".join("-" * w for w in widths))
    out += ["  ".join(c.ljust(w) for c, w in zip(x, widths, strict=True)) for x in lines]
    for r in table.rows:
        if r.note:
            out.append(f"   * {r.name}: {r.note}")
    out += [f"   {note}" for note in table.notes]
    return "\n".join(out)


def proc_loadavg() -> str | None:
    """Return the raw line of ``/proc/loadavg`` (1, 5, 15 min, running/total tasks, last pid)."""
    try:
        with open("/proc/loadavg") as f:
            return f.read().strip()
    except OSError:
        return None


def git_state() -> dict[str, Any] | None:
    """Commit of the source tree and whether it had uncommitted changes (None outside git)."""
    import subprocess

    try:
        head = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=REPO, capture_output=True, text=True, check=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=REPO,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.split("\n")
    except (OSError, subprocess.CalledProcessError):
        return None
    return {"commit": head, "modified": [line[3:] for line in dirty if line.strip()]}


def machine() -> dict[str, Any]:
    """CPU model, core count, load and library versions."""
    cpu = platform.processor() or "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    import numpy as np

    import accelcore

    versions: dict[str, str | None] = {
        "python": platform.python_version(),
        "numpy": np.__version__,
    }
    for mod in ("pandas", "polars"):
        try:
            versions[mod] = __import__(mod).__version__
        except ImportError:
            versions[mod] = None
    return {
        "cpu_model": cpu,
        "cores": os.cpu_count(),
        "load_average": list(os.getloadavg()),
        "proc_loadavg": proc_loadavg(),
        "platform": platform.platform(),
        "accelcore": accelcore.__version__,
        "git": git_state(),
        **versions,
    }


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="accelcore bench", description="accelcore vs NumPy reference, pandas and polars"
    )
    p.add_argument("--large", action="store_true", help="add 1e8-sample kernels, 1e9 memory run")
    p.add_argument("--quick", action="store_true", help="small sizes, one repetition (smoke)")
    p.add_argument(
        "--cases",
        default="kernels,reading,end_to_end,diagnosis,bulk,memory",
        help="comma-separated subset of: kernels, reading, end_to_end, diagnosis, bulk, memory",
    )
    p.add_argument(
        "--output",
        type=Path,
        default=None,
        help="JSON file (default benches/results/<date>-<host>.json; '-' for none)",
    )
    p.add_argument("--workdir", type=Path, default=None, help="where to write generated logs")
    return p


def _default_output() -> Path:
    """``benches/results/<date>-<host>.json``; ``<date>-<host>-<HHMMSS>.json`` if taken."""
    now = dt.datetime.now()
    folder, host = REPO / "benches" / "results", socket.gethostname()
    out = folder / f"{now.date().isoformat()}-{host}.json"
    return out if not out.exists() else out.with_name(f"{out.stem}-{now:%H%M%S}.json")


def _load_cases() -> Any:
    folder = REPO / "benches"
    if not (folder / "cases.py").is_file():
        raise FileNotFoundError(
            f"{folder} not found: the benchmark cases live in the source repository"
        )
    if str(REPO) not in sys.path:
        sys.path.insert(0, str(REPO))
    return importlib.import_module("benches.cases")


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark cases, print the tables and save the JSON results."""
    args = _parser().parse_args(list(argv) if argv is not None else None)
    try:
        cases = _load_cases()
    except (FileNotFoundError, ImportError) as exc:
        print(f"accelcore bench: {exc}", file=sys.stderr)
        return 2
    import tempfile

    wanted = [c.strip() for c in args.cases.split(",") if c.strip()]
    unknown = [c for c in wanted if c not in cases.CASES]
    if unknown:
        print(f"accelcore bench: unknown case(s) {unknown}; have {list(cases.CASES)}")
        return 2
    info = machine()
    print(
        f"accelcore {info['accelcore']} | {info['cpu_model']} | {info['cores']} cores | "
        f"load {info['load_average'][0]:.2f} | python {info['python']} numpy {info['numpy']} "
        f"pandas {info['pandas']} polars {info['polars']} (POLARS_MAX_THREADS="
        f"{os.environ.get('POLARS_MAX_THREADS')})"
    )
    started = time.perf_counter()
    tables: list[Table] = []
    case_elapsed: dict[str, float] = {}
    with tempfile.TemporaryDirectory(prefix="accelcore-bench-") as tmp:
        ctx = Context(large=args.large, quick=args.quick, workdir=args.workdir or Path(tmp))
        for case in wanted:
            t0 = time.perf_counter()
            for table in cases.CASES[case](ctx):
                tables.append(table)
                print()
                print(format_table(table), flush=True)
            case_elapsed[case] = time.perf_counter() - t0
            print(f"   ({case}: {case_elapsed[case]:.1f} s, load {os.getloadavg()[0]:.2f})")
    elapsed = time.perf_counter() - started
    info["load_average_end"] = list(os.getloadavg())
    info["proc_loadavg_end"] = proc_loadavg()
    print(
        f"\ntotal {elapsed:.1f} s | load average at start {info['load_average'][0]:.2f}, "
        f"at end {info['load_average_end'][0]:.2f} (1 min) on {info['cores']} cores"
    )
    if args.output is None or str(args.output) != "-":
        out = args.output or _default_output()
        out.parent.mkdir(parents=True, exist_ok=True)
        record = {
            "date": dt.datetime.now().isoformat(timespec="seconds"),
            "argv": list(argv) if argv is not None else sys.argv[1:],
            "warmup_s": WARMUP_S,
            "machine": info,
            "elapsed_s": elapsed,
            "case_elapsed_s": case_elapsed,
            "tables": [
                {
                    "title": t.title,
                    "notes": t.notes,
                    "rows": [
                        {**asdict(r), "rate_per_s": r.rate, "rate_per_cpu_s": r.cpu_rate}
                        for r in t.rows
                    ],
                }
                for t in tables
            ],
        }
        out.write_text(json.dumps(record, indent=1) + "\n")
        print(f"results: {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
