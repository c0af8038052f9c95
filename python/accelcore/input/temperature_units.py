"""Temperatures that are not °C: a value no thermometer reads, a run in °F or kelvin.

:func:`impossible_temperature` finds a value below absolute zero or above 1000 °C (a
corrupt cell or message): the readers refuse it where it is.
:func:`other_unit_runs` finds a run whose temperature reads in another unit than the
others' (°F, kelvin).

The format's temperatures are °C. One run logged by another logger in °F reads 28…149
where the others read −2…65: every fit takes it as a part hotter than any chamber got,
and the tempcos move in silence (an adversarial case of session 20: the x offset's
tempco 0.185 → 0.117 mg/°C, z's sensitivity tempco −0.012 → +0.158 %/°C, no warning).

A run is flagged when its temperature span (5th to 95th percentile) lies more than
:data:`OFF_C` from the other runs' median span at either end, *and* reading it in one of
:data:`UNITS` puts both ends within :data:`MATCH_C` of the others'. A run that covers
another part of the range (overlapping sweeps, a run cut short) does not convert onto
the others' span, and is not flagged.

Imports: NumPy, the core's temperature bounds and the run.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from accelcore._accelcore import MAX_TEMPERATURE_C, MIN_TEMPERATURE_C
from accelcore.input.run import Run

__all__ = [
    "MATCH_C",
    "MIN_RUNS",
    "OFF_C",
    "UNITS",
    "impossible_temperature",
    "not_a_temperature",
    "other_unit_runs",
]

#: The units a temperature column is logged in by mistake, with their conversion to °C.
UNITS: tuple[tuple[str, Callable[[float], float]], ...] = (
    ("°F", lambda t: (t - 32.0) / 1.8),
    ("K", lambda t: t - 273.15),
)

#: Fewest runs with temperatures for the others' span to be a reference.
MIN_RUNS = 3

#: A run's span this far from the others' at either end is checked, °C.
OFF_C = 15.0

#: Converted, both ends of its span within this of the others', °C.
MATCH_C = 5.0


def impossible_temperature(temperature_c: NDArray[np.float64]) -> int | None:
    """Return the index of the first finite value no thermometer reads, or None.

    Logs hold °C: a value below absolute zero or above ``MAX_TEMPERATURE_C`` (1000 °C)
    is a corrupt value (a flight log's garbage message decodes as -6e26 °C) or another
    unit, never a temperature. The Rust reader refuses such a cell at its line and
    column; the other readers and :meth:`Session.from_arrays` use this.
    """
    t = np.asarray(temperature_c, dtype=np.float64)
    bad = np.isfinite(t) & ((t < MIN_TEMPERATURE_C) | (t > MAX_TEMPERATURE_C))
    return int(np.argmax(bad)) if bad.any() else None


def not_a_temperature(value: float) -> str:
    """Return the message of a value :func:`impossible_temperature` found."""
    shown = f"{value:e}" if abs(value) >= 1e6 else f"{value:g}"
    return (
        f"temperature {shown} is not one in °C (below absolute zero or above "
        f"{MAX_TEMPERATURE_C:g} °C): a corrupt value, or another unit"
    )


def _span(run: Run) -> tuple[float, float] | None:
    t = run.temperature_c[np.isfinite(run.temperature_c)]
    if t.size < 2:
        return None
    lo, hi = np.percentile(t, [5.0, 95.0])
    return float(lo), float(hi)


def other_unit_runs(runs: Sequence[Run]) -> list[tuple[Run, str]]:
    """Return each run whose temperatures read in another unit, with its finding's text."""
    spans = [(r, s) for r in runs if (s := _span(r)) is not None]
    if len(spans) < MIN_RUNS:
        return []
    out = []
    for i, (run, (lo, hi)) in enumerate(spans):
        others = np.array([s for j, (_, s) in enumerate(spans) if j != i])
        olo, ohi = float(np.median(others[:, 0])), float(np.median(others[:, 1]))
        if max(abs(lo - olo), abs(hi - ohi)) <= OFF_C:
            continue
        for unit, to_c in UNITS:
            clo, chi = to_c(lo), to_c(hi)
            if max(abs(clo - olo), abs(chi - ohi)) <= MATCH_C:
                out.append(
                    (
                        run,
                        f"its temperatures read {lo:.1f}…{hi:.1f} where the other runs read "
                        f"{olo:.1f}…{ohi:.1f} °C; read in {unit} they would be "
                        f"{clo:.1f}…{chi:.1f} °C: is this run logged in {unit}? Every fit "
                        "takes it as °C: convert it",
                    )
                )
                break
    return out
