"""Case (d): the thermal-lag search and the diagnosis of one simulated six-run session.

The session is simulated in memory (ADXL335, six 1 h runs, heat and cool back,
a ``supply_v`` column so the ``extra`` family has a candidate) with an injected
first-order thermal lag, so the lag search finds something. ``diagnose`` is timed
with 1, 2, 4 and all 6 candidate families (each set holds ``thermal_lag``), and
with a narrower ``tau_range_s``. The cost is counted in cross-validated fits
(``Engine.cv``: one per candidate model, each solving once per held-out fold and
once in-sample with the core's QR least squares: a subset query of a
catalogue whose rows were pushed once, or, for a lag-search trial, one push of
its own rows into blocked factors); the counts and the time spent inside the lag
search come from one extra instrumented run per row, never the timed ones. Case
(d2) times the default diagnosis with the time-constant searches of the axes run
together on one thread and on every core (``search_threads``).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from accelcore import diagnosis, simulate
from accelcore.apps.bench import Context, Table, measure
from accelcore.diagnosis import engine as diagnosis_engine
from accelcore.diagnosis import search as diagnosis_search
from accelcore.input.session import Session
from accelcore.simulate import effects as se

LAG_TAU_S = 90.0


def make_session(duration_h: float, seed: int = 1) -> Session:
    """Six runs of ``duration_h`` (20 Hz, decimated to 2 Hz) with a thermal lag."""
    sim = simulate.arrays(
        "ADXL335",
        seed=seed,
        duration_h=duration_h,
        cool_back=True,
        extra_columns=("supply_v",),
        effects=(se.ThermalLag(LAG_TAU_S),),
    )
    return Session.from_arrays(
        [(r.orientation, r.columns) for r in sim.runs],
        units=sim.units,
        rate_hz=sim.rate_hz,
        sensor=sim.sensor,
        decimation_factor=10,
    )


@dataclass
class Counts:
    """What one instrumented ``diagnose`` did."""

    cv_fits: int = 0
    lag_searches: int = 0
    lag_fits: int = 0
    lag_wall_s: float = 0.0
    lag_cpu_s: float = 0.0
    wall_s: float = 0.0


@contextmanager
def instrumented() -> Iterator[Counts]:
    """Count ``Engine.cv`` calls and time the time-constant searches (``search_1d``: a
    lag's, through ``search_tau``, or a warm-up's; and ``search_many``, the axes'
    searches run together: module globals, restored after)."""
    counts = Counts()
    engine: Any = diagnosis_engine.Engine
    cv, search = engine.cv, diagnosis_search.search_1d
    together = diagnosis_search.search_many
    in_search = [False]

    def timed_together(*args: Any, **kwargs: Any) -> Any:
        w0 = time.perf_counter()
        try:
            return together(*args, **kwargs)
        finally:
            counts.lag_wall_s += time.perf_counter() - w0

    def counted_cv(self: Any, *args: Any, **kwargs: Any) -> Any:
        counts.cv_fits += 1
        counts.lag_fits += in_search[0]
        return cv(self, *args, **kwargs)

    def timed_search(*args: Any, **kwargs: Any) -> Any:
        counts.lag_searches += 1
        in_search[0] = True
        c0, w0 = time.thread_time(), time.perf_counter()
        try:
            return search(*args, **kwargs)
        finally:
            counts.lag_wall_s += time.perf_counter() - w0
            counts.lag_cpu_s += time.thread_time() - c0
            in_search[0] = False

    engine.cv = counted_cv
    setattr(diagnosis_search, "search_1d", timed_search)  # noqa: B010 - patched on purpose
    setattr(diagnosis_search, "search_many", timed_together)  # noqa: B010
    try:
        yield counts
    finally:
        engine.cv = cv
        setattr(diagnosis_search, "search_1d", search)  # noqa: B010
        setattr(diagnosis_search, "search_many", together)  # noqa: B010


def _found(d: diagnosis.Diagnosis) -> str:
    steps = []
    for s in d.steps[1:]:
        variants = "; ".join(f"{a}: {v}" for a, v in s.variant.items())
        steps.append(f"{s.effect} ({variants})")
    return ", ".join(steps) or "nothing"


def _caller(
    session: Session, families: Sequence[str], tau_range_s: tuple[float, float]
) -> Callable[[], diagnosis.Diagnosis]:
    return lambda: diagnosis.diagnose(session, families=families, tau_range_s=tau_range_s)


def run(ctx: Context) -> list[Table]:
    hours = 0.5 if ctx.quick else 1.0
    repeat = 1 if ctx.quick else 3
    session = make_session(hours)
    n = sum(len(r) for r in session.runs)
    fam = diagnosis.FAMILIES
    configs: list[tuple[str, Sequence[str], tuple[float, float]]] = [
        ("1 family: thermal_lag", ("thermal_lag",), (5.0, 3600.0)),
        ("2 families: +offset_curvature", ("offset_curvature", "thermal_lag"), (5.0, 3600.0)),
        ("4 families: +sens_curv, misalign", fam[:4], (5.0, 3600.0)),
        (f"all {len(fam)} families (default)", fam, (5.0, 3600.0)),
        (f"all {len(fam)} families, tau 30-300 s", fam, (30.0, 300.0)),
    ]
    table = Table(
        f"(d) diagnosis of one six-run session: ADXL335, {hours:g} h runs, cool back, "
        f"ThermalLag({LAG_TAU_S:g} s) injected, {n} decimated samples"
    )
    first_wall: float | None = None
    lag_share: list[str] = []
    for name, families, tau_range in configs:
        call = _caller(session, families, tau_range)
        with instrumented() as counts:
            w0 = time.perf_counter()
            found = call()
            counts.wall_s = time.perf_counter() - w0
        row = measure(name, call, n=n, repeat=repeat, unit="fits", amount=float(counts.cv_fits))
        first_wall = first_wall if first_wall is not None else row.wall_s
        row.ratio = row.wall_s / first_wall
        row.baseline = configs[0][0]
        row.note = (
            f"{counts.cv_fits} CV fits ({len(found.candidates)} candidates), "
            f"{counts.lag_searches} tau searches (lag, warm-up) = {counts.lag_fits} fits, "
            f"{100 * counts.lag_wall_s / counts.wall_s:.0f}% of the time; "
            f"added {_found(found)}"
        )
        if counts.lag_searches:
            lag_share.append(
                f"{name}: {counts.lag_wall_s / counts.lag_searches:.3f} s and "
                f"{counts.lag_fits / counts.lag_searches:.1f} fits per tau search"
            )
        table.rows.append(row)
    table.notes.append(
        "ratio = growth: row median / median with 1 family (thermal_lag); rate = CV fits "
        "per second (each fit solves once per held-out fold and once in-sample); the tau "
        "search is a fixed 10-point log grid + 8 golden-section steps, each trial on a "
        "stride of ~4,000 rows (not counted as CV fits), "
        "run per axis for the die-lag and rate-term variants; counts from one extra "
        "instrumented run"
    )
    table.notes += lag_share[-2:-1]
    return [table, _threads(session, n, repeat)]


def _threads(session: Session, n: int, repeat: int) -> Table:
    """The default diagnosis, its time-constant searches on one thread and on every core."""
    cores = os.cpu_count() or 1
    table = Table(
        "(d2) the default diagnosis, the axes' time-constant searches run together on "
        f"one thread and on every core ({cores})"
    )
    kept = diagnosis_search.search_threads
    try:
        for threads in (1, None):
            diagnosis_search.search_threads = threads
            name = f"search_threads={threads or cores}"
            table.rows.append(
                measure(name, lambda: diagnosis.diagnose(session), n=n, repeat=repeat)
            )
    finally:
        diagnosis_search.search_threads = kept
    table.set_ratios(lambda r: "search_threads=1" if r.name != "search_threads=1" else None)
    table.notes.append(
        "ratio = median with one thread / median with every core; the results are the "
        "same bit for bit (tests/test_search.py)"
    )
    return table
