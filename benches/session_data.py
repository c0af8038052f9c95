"""A simulated six-run session on disk, written once per benchmark run."""

from __future__ import annotations

from pathlib import Path

from accelcore import simulate


def session_dir(workdir: Path, hours: float) -> Path:
    """Six runs (OX±, OY±, OZ±) of ``hours`` at 20 Hz each, ADXL335 in volts."""
    path = workdir / f"session-{hours:g}h"
    if not (path / "session.toml").is_file():
        simulate.session(path, duration_h=hours, seed=1, overwrite=True)
    return path


def count_rows(path: Path) -> int:
    """Data rows of a CSV log (lines minus the header)."""
    with path.open() as f:
        return sum(1 for _ in f) - 1
