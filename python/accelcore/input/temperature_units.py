"""A run whose temperature reads in another unit than the others' (°F, kelvin).

The format's temperatures are °C. One run logged by another logger in °F reads 28…149
where the others read −2…65: every fit takes it as a part hotter than any chamber got,
and the tempcos move in silence (an adversarial case of session 20: the x offset's
tempco 0.185 → 0.117 mg/°C, z's sensitivity tempco −0.012 → +0.158 %/°C, no warning).

A run is flagged when its temperature span (5th to 95th percentile) lies more than
:data:`OFF_C` from the other runs' median span at either end, *and* reading it in one of
:data:`UNITS` puts both ends within :data:`MATCH_C` of the others'. A run that covers
another part of the range (overlapping sweeps, a run cut short) does not convert onto
the others' span, and is not flagged.

Imports: NumPy.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from accelcore.input.run import Run

__all__ = ["MATCH_C", "MIN_RUNS", "OFF_C", "UNITS", "other_unit_runs"]

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
