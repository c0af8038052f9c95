"""A run logged in °F or kelvin among runs in °C is said, and other ranges are not."""

from __future__ import annotations

import numpy as np
import pytest

from accelcore.input.run import Run
from accelcore.input.temperature_units import other_unit_runs

SIX = ("OX+", "OX-", "OY+", "OY-", "OZ+", "OZ-")


def _run(label: str, lo: float, hi: float, n: int = 7200) -> Run:
    """A run whose temperature climbs lo -> hi and back (only what the check reads)."""
    t = np.concatenate([np.linspace(lo, hi, n // 2), np.linspace(hi, lo, n - n // 2)])
    return Run(
        orientation=label,
        gravity_g=np.zeros(3),
        time_s=np.arange(n, dtype=np.float64) * 0.5,
        temperature_c=t,
        output=np.zeros((n, 3)),
        count=np.full(n, 10),
        extras={},
        source=f"{label}.csv",
        stats=None,  # type: ignore[arg-type]
    )


@pytest.mark.parametrize(
    ("unit", "convert"), [("°F", lambda c: c * 1.8 + 32.0), ("K", lambda c: c + 273.15)]
)
def test_a_run_in_another_unit_is_named(unit: str, convert: object) -> None:
    runs = [_run(o, -2.0, 65.0) for o in SIX]
    runs[4] = _run("OZ+", convert(-2.0), convert(65.0))  # type: ignore[operator]
    found = other_unit_runs(runs)
    assert [r.orientation for r, _ in found] == ["OZ+"]
    assert f"is this run logged in {unit}?" in found[0][1]


def test_other_ranges_and_short_runs_are_not_taken_for_another_unit() -> None:
    """Blind round 5's overlapping ranges, a run cut short, a clean session: nothing."""
    ranges = ((-2, 35), (25, 65), (10, 50), (-2, 40), (20, 65), (-2, 45))
    assert other_unit_runs([_run(o, lo, hi) for o, (lo, hi) in zip(SIX, ranges, strict=True)]) == []
    cut = [_run(o, -2.0, 65.0) for o in SIX]
    cut[2] = _run("OY+", -2.0, 20.0)
    assert other_unit_runs(cut) == []
    assert other_unit_runs([_run(o, -2.0, 65.0) for o in SIX]) == []
    # Two runs are no reference for each other.
    assert other_unit_runs([_run("OX+", -2.0, 65.0), _run("OX-", 28.4, 149.0)]) == []
