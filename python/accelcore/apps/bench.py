"""Benchmark harness: measures cases, prints their tables and saves the results as JSON.

The cases (accelcore vs the NumPy reference, pandas and polars) live in the
repository's ``benches/`` folder, not in the package; they import this harness
(:class:`Context`, :class:`Table`, :class:`Row`, :func:`measure`), never the reverse.
``make bench`` runs them as ``python -m benches``, which calls :func:`run`.
Installed, ``accelcore bench`` (:func:`main`) runs the cases of a ``benches``
folder named by ``--benches DIR`` (default: ``./benches`` in the current
directory); it never looks for the source tree by itself and never touches
``sys.path``.

Every row of a table is measured in the same run on the same data: after an
untimed warm-up, median of several repetitions (wall clock and the thread's CPU
time), throughput, peak memory and the speed ratio to the case's baseline.
Targets are reported, never asserted. Results are saved as JSON under the
cases' ``results/`` folder (``benches/results/``).

Peak memory is the growth of the process's peak resident set during one
extra call after the warm-up (``/proc/self/clear_refs`` resets the peak, then
``VmHWM - VmRSS`` is read), so Rust, NumPy and Python allocations all count;
the memory case measures whole subprocesses instead.
"""

from __future__ import annotations

import argparse
import datetime as dt
import gc
import importlib.util
import json
import os
import platform
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

import accelcore
from accelcore.files import atomic_write

__all__ = [
    "Case",
    "Context",
    "Row",
    "Table",
    "format_table",
    "load_cases",
    "machine",
    "main",
    "measure",
    "run",
    "warm_up",
]

# polars reads with every core by default; the targets are per core.
os.environ.setdefault("POLARS_MAX_THREADS", "1")


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
    25 % slower for its first ~50 ms (a fused decimate-bin-fit kernel, since
    removed, at 1e6 samples: 7.9 ms on the first call after the NumPy reference,
    6.2-6.5 ms from about the tenth); the timed repetitions measure the settled rate.
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


def git_state(folder: Path) -> dict[str, Any] | None:
    """Commit of the checkout holding ``folder`` and its uncommitted files (None outside git)."""
    try:
        head = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=folder, capture_output=True, text=True, check=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=folder,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.split("\n")
    except (OSError, subprocess.CalledProcessError):
        return None
    return {"commit": head, "modified": [line[3:] for line in dirty if line.strip()]}


def machine(folder: Path) -> dict[str, Any]:
    """CPU model, core count, load, library versions and the git state of ``folder``."""
    cpu = platform.processor() or "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
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
        "git": git_state(folder),
        **versions,
    }


Case = Callable[[Context], list[Table]]
"""A benchmark case: takes the shared options, returns its measured tables."""


def build_parser(
    prog: str = "accelcore bench", *, benches_option: bool = True
) -> argparse.ArgumentParser:
    """Return the options of a benchmark run (``--benches DIR`` only for ``accelcore bench``).

    Parameters
    ----------
    prog : str
        Program name shown in the help.
    benches_option : bool, default True
        Offer ``--benches DIR`` (the installed command); ``python -m benches``
        knows its own folder.

    Returns
    -------
    argparse.ArgumentParser
    """
    if benches_option:
        description = (
            "Run the benchmark cases (accelcore vs NumPy reference, pandas and polars) of a "
            "source checkout's benches/ folder with the installed harness. The cases are not "
            "installed with the package: pass --benches DIR, or run from the checkout's root "
            "(default ./benches). 'make bench' is the same as 'python -m benches'."
        )
    else:
        description = "accelcore vs NumPy reference, pandas and polars"
    p = argparse.ArgumentParser(prog=prog, description=description)
    if benches_option:
        p.add_argument(
            "--benches",
            type=Path,
            default=Path("benches"),
            metavar="DIR",
            help="the folder of benchmark cases, named benches and holding cases.py "
            "(default: ./benches)",
        )
    p.add_argument("--large", action="store_true", help="add 1e8-sample kernels, 1000 h memory log")
    p.add_argument("--quick", action="store_true", help="small sizes, one repetition (smoke)")
    p.add_argument(
        "--cases",
        default=None,
        help="comma-separated subset of the cases (default: all, in order; "
        "in a checkout: kernels, reading, end_to_end, diagnosis, bulk, memory)",
    )
    p.add_argument(
        "--output",
        type=Path,
        default=None,
        help="JSON file (default <benches>/results/<date>-<host>.json; '-' for none)",
    )
    p.add_argument("--workdir", type=Path, default=None, help="where to write generated logs")
    return p


def _default_output(folder: Path) -> Path:
    """``folder/<date>-<host>.json``; ``<date>-<host>-<HHMMSS>.json`` if taken."""
    now = dt.datetime.now()
    out = folder / f"{now.date().isoformat()}-{socket.gethostname()}.json"
    return out if not out.exists() else out.with_name(f"{out.stem}-{now:%H%M%S}.json")


def _record(
    argv: Sequence[str],
    info: dict[str, Any],
    elapsed: float,
    case_elapsed: Mapping[str, float],
    tables: Sequence[Table],
) -> dict[str, Any]:
    return {
        "date": dt.datetime.now().isoformat(timespec="seconds"),
        "argv": list(argv),
        "warmup_s": WARMUP_S,
        "machine": info,
        "elapsed_s": elapsed,
        "case_elapsed_s": dict(case_elapsed),
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


def run(
    cases: Mapping[str, Case],
    args: argparse.Namespace,
    *,
    folder: Path,
    argv: Sequence[str] = (),
) -> int:
    """Run the chosen cases, print one table per case and save the JSON results.

    Parameters
    ----------
    cases : mapping of str to callable
        The cases by name, in the order they run by default.
    args : argparse.Namespace
        Options parsed by :func:`build_parser`.
    folder : pathlib.Path
        The cases' folder: results go to ``folder/results/`` by default and the
        git state of its checkout is recorded.
    argv : sequence of str
        The arguments, recorded in the JSON.

    Returns
    -------
    int
        0, or 2 when a case named in ``--cases`` does not exist.
    """
    wanted = list(cases) if args.cases is None else [c.strip() for c in args.cases.split(",")]
    wanted = [c for c in wanted if c]
    unknown = [c for c in wanted if c not in cases]
    if unknown:
        print(f"accelcore bench: unknown case(s) {unknown}; have {list(cases)}", file=sys.stderr)
        return 2
    info = machine(folder)
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
            for table in cases[case](ctx):
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
        out = args.output or _default_output(folder / "results")
        record = _record(argv, info, elapsed, case_elapsed, tables)
        atomic_write(out, json.dumps(record, indent=1) + "\n")
        print(f"results: {out}")
    return 0


def load_cases(folder: Path) -> Mapping[str, Case]:
    """Import the ``benches`` package at ``folder`` by its path and return its ``CASES``.

    The folder is named explicitly (nothing is searched and ``sys.path`` is not
    changed); it is registered as the package ``benches``, since the cases
    import each other as ``benches.*`` (and the memory case starts
    ``python -m benches.memory`` in the folder's parent).

    Parameters
    ----------
    folder : pathlib.Path
        A folder named ``benches`` holding ``__init__.py`` and ``cases.py``.

    Returns
    -------
    mapping of str to callable
        ``benches.cases.CASES``.

    Raises
    ------
    FileNotFoundError
        ``folder`` is not such a folder.
    ImportError
        Another ``benches`` package is already imported, or the cases fail to import.
    """
    folder = folder.resolve()
    init = folder / "__init__.py"
    if folder.name != "benches" or not init.is_file() or not (folder / "cases.py").is_file():
        raise FileNotFoundError(
            f"{folder}: not a benches folder (a package named benches holding cases.py); "
            "run from a source checkout's root or pass --benches DIR"
        )
    package = folder.name  # the cases' package is the folder named on the command line
    loaded = sys.modules.get(package)
    if loaded is None:
        spec = importlib.util.spec_from_file_location(
            package, init, submodule_search_locations=[str(folder)]
        )
        if spec is None or spec.loader is None:  # pragma: no cover - a .py file always has one
            raise ImportError(f"{init}: cannot be imported")
        module = importlib.util.module_from_spec(spec)
        sys.modules[package] = module
        try:
            spec.loader.exec_module(module)
        except BaseException:
            del sys.modules[package]
            raise
    elif [str(Path(p).resolve()) for p in getattr(loaded, "__path__", [])] != [str(folder)]:
        raise ImportError(f"another benches package is already imported: {loaded!r}")
    cases: Mapping[str, Case] = importlib.import_module(f"{package}.cases").CASES
    return cases


def main(argv: Sequence[str] | None = None) -> int:
    """``accelcore bench``: run the cases of the ``benches`` folder given by ``--benches``.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success, 2 when the folder holds no cases or a case is unknown.
    """
    arguments = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(arguments)
    try:
        cases = load_cases(args.benches)
    except (FileNotFoundError, ImportError) as exc:
        print(f"accelcore bench: {exc}", file=sys.stderr)
        return 2
    return run(cases, args, folder=args.benches.resolve(), argv=arguments)


if __name__ == "__main__":
    raise SystemExit(main())
