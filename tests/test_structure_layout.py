"""The structure check of a short static hold does not depend on how the log was cut.

A hold of a few minutes gives the engine few windows: binned by windows, every bin of
every observable was one window, so every observable "showed" the same structure (the
windows' scatter): an MPU-6050's 7.5 min hold (tomisuarez2/ImuCalibration) reported a
slow rise of z against three gyro columns, identically, when stored as two files, and
against time when stored as one. The samples are now binned where windows are few.
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pytest

from accelcore.diagnosis import diagnose, windows
from accelcore.input.session import Session

RATE_HZ = 100.0
HOLD_S = 450.0


def _hold() -> dict[str, np.ndarray]:
    """One 7.5 min static hold at 100 Hz, in g: z rises 1 mg over it; three gyro columns."""
    rng = np.random.default_rng(11)
    n = int(HOLD_S * RATE_HZ)
    t = np.arange(n) / RATE_HZ
    noise = 4e-3  # 4 mg rms per raw sample, an MPU-6050's at 100 Hz
    cols = {
        "time_s": t,
        "x": 0.17 + rng.normal(0, noise, n),
        "y": -0.04 + rng.normal(0, noise, n),
        "z": 0.98 + 1.0e-3 * t / HOLD_S + rng.normal(0, noise, n),
    }
    for g in ("gx", "gy", "gz"):
        cols[g] = np.round(rng.normal(0.0, 3.0, n))  # coarse integer counts, pure noise
    return cols


def _session(cut: list[int]) -> Session:
    cols = _hold()
    edges = [0, *cut, cols["time_s"].size]
    runs = [("OZ+", {k: v[a:b] for k, v in cols.items()}) for a, b in pairwise(edges)]
    return Session.from_arrays(
        runs, units="g", rate_hz=RATE_HZ, columns={"temperature": ""}, decimation_factor=50
    )


def test_the_same_hold_cut_into_files_reports_the_same_structure() -> None:
    found = []
    for cut in ([], [22_465], [9_000, 30_001]):
        d = diagnose(_session(cut))
        assert d.effects == (), d.effects
        # Said as it is: nothing logged, not "spans 0.00 °C".
        assert "no temperature was logged: no temperature-driven effect is tried or reported" in (
            d.warnings
        ), d.warnings
        assert not any("spans" in w for w in d.warnings), d.warnings
        found.append({(s.axis, s.observable) for s in d.unexplained})
    # The rise of z against time, whatever the cut; no gyro column (they are noise).
    assert found[0] == found[1] == found[2] == {("z", "elapsed_s")}, found


def test_long_windows_do_not_lend_their_scatter_to_every_observable(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Windows kept at their longest (32 samples, as the two-file MPU-6050 hold got):
    28 windows for 30 bins. Binned by windows, gx, gy and gz each showed z's rise, with
    the same chi-square; binned by samples only time does."""
    monkeypatch.setattr(windows, "_explains_nothing", lambda *args: True)
    d = diagnose(_session([]))
    assert d.effects == (), d.effects
    assert {(s.axis, s.observable) for s in d.unexplained} == {("z", "elapsed_s")}


def test_levels_that_differ_between_runs_are_said_to_be_between_runs() -> None:
    """The same hold, cut in two, the second half re-placed with 40 mg more on x (a
    real MPU6050 session had two placements of one orientation 48/67 mg apart, reported
    as structure "vs elapsed_s" alone). The structure in time says it is between the
    runs, and by how much (40 mg, to the noise of two half-hold means: ~0.03 mg); the
    uncut hold's rise of z is not."""
    cols = _hold()
    half = cols["time_s"].size // 2
    runs = [("OZ+", {k: v[:half] for k, v in cols.items()})]
    second = {k: v[half:].copy() for k, v in cols.items()}
    second["x"] = second["x"] + 0.040
    second["time_s"] = second["time_s"] - second["time_s"][0]  # its own clock: placed anew
    runs.append(("OZ+", second))
    d = diagnose(
        Session.from_arrays(
            runs, units="g", rate_hz=RATE_HZ, columns={"temperature": ""}, decimation_factor=50
        )
    )
    x = [s for s in d.unexplained if (s.axis, s.observable) == ("x", "elapsed_s")]
    assert len(x) == 1 and x[0].note.startswith("mostly between runs"), d.text()
    apart = float(x[0].note.split("up to ")[1].split(" mg")[0])
    assert abs(apart - 40.0) < 0.5, x[0].note
    z = [s for s in diagnose(_session([])).unexplained if s.axis == "z"]
    assert z and "between runs" not in z[0].note, z
