"""Held-out error of a six-position recording of static holds (imucal's kind of data).

``python -m benches.static_holds FILE`` reads a CSV of static holds with one row per
sample: a column naming the hold (imucal's ``part``: ``x_p``, ``x_a``, ``y_p``, ...,
rotations and other parts ignored) and the accelerometer's ``acc_x``, ``acc_y``,
``acc_z``. It is the layout of imucal's example recordings
(``example_data/annotated_session.csv`` in https://github.com/mad-lab-fau/imucal, raw
counts at 204.8 Hz): the file is not shipped here, pass your copy.

The first half of every hold is the calibration session; the second half of every hold
is data the fit did not see. Printed: the RMS over x, y and z of the compensated error
against the nominal gravity vector of each hold, mg, in and out of sample, for
``calibrate`` and for ``diagnose`` with every default.
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Final

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from accelcore.constants import ORIENTATIONS
from accelcore.diagnosis import diagnose
from accelcore.fitting.calibrate import calibrate
from accelcore.input.session import Session
from accelcore.result.calibration import Calibration

#: imucal's names of the six holds: the axis pointing up (``_p``) or down (``_a``).
HOLDS: Final[Mapping[str, str]] = {
    "x_p": "OX+",
    "x_a": "OX-",
    "y_p": "OY+",
    "y_a": "OY-",
    "z_p": "OZ+",
    "z_a": "OZ-",
}

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Scores:
    """RMS error against nominal gravity, mg, of one calibration.

    Attributes
    ----------
    in_sample_mg, held_out_mg : float
        On the first halves (the fitted data) and on the second halves.
    """

    in_sample_mg: float
    held_out_mg: float


def halves(holds: Mapping[str, FloatArray]) -> tuple[dict[str, FloatArray], dict[str, FloatArray]]:
    """Split each hold's (n, 3) samples into its first and second half (by time)."""
    first = {o: a[: a.shape[0] // 2] for o, a in holds.items()}
    second = {o: a[a.shape[0] // 2 :] for o, a in holds.items()}
    return first, second


def session_of(holds: Mapping[str, FloatArray], *, units: str, rate_hz: float) -> Session:
    """A session of one run per hold (no time or temperature logged)."""
    return Session.from_arrays(
        [(o, {"x": a[:, 0], "y": a[:, 1], "z": a[:, 2]}) for o, a in holds.items()],
        units=units,
        rate_hz=rate_hz,
    )


def error_mg(calibration: Calibration, holds: Mapping[str, FloatArray]) -> float:
    """RMS over x, y, z of compensated output less each hold's nominal gravity, mg."""
    errors = [
        (calibration.compensate(a, None) - np.asarray(ORIENTATIONS[o])) * 1000.0
        for o, a in holds.items()
    ]
    e = np.vstack(errors)
    return float(np.sqrt(np.mean(e * e)))


def score(
    holds: Mapping[str, FloatArray], *, units: str, rate_hz: float
) -> tuple[Scores, Scores, tuple[str, ...]]:
    """Return the scores of ``calibrate`` and of ``diagnose``, and the effects it added."""
    first, second = halves(holds)
    session = session_of(first, units=units, rate_hz=rate_hz)
    base = calibrate(session)
    found = diagnose(session)
    out = [Scores(error_mg(c, first), error_mg(c, second)) for c in (base, found.calibration)]
    return out[0], out[1], found.effects


def read_holds(path: Path) -> dict[str, FloatArray]:
    """Read imucal's layout: the ``part`` column and ``acc_x``, ``acc_y``, ``acc_z``."""
    frame = pd.read_csv(path)
    holds: dict[str, FloatArray] = {}
    for name, orientation in HOLDS.items():
        rows = frame[frame["part"] == name]
        if rows.empty:
            raise SystemExit(f"{path}: no rows of hold {name!r} in column 'part'")
        holds[orientation] = rows[["acc_x", "acc_y", "acc_z"]].to_numpy(np.float64)
    return holds


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m benches.static_holds FILE [--units LSB] [--rate-hz 204.8]``."""
    p = argparse.ArgumentParser(prog="python -m benches.static_holds", description=__doc__)
    p.add_argument("file", type=Path, help="CSV of static holds in imucal's layout")
    p.add_argument("--units", default="LSB", help="output units (default LSB: raw counts)")
    p.add_argument("--rate-hz", type=float, default=204.8, help="sample rate (default 204.8)")
    args = p.parse_args(argv)
    holds = read_holds(args.file)
    base, found, effects = score(holds, units=args.units, rate_hz=args.rate_hz)
    sizes = ", ".join(f"{o} {a.shape[0]}" for o, a in holds.items())
    print(f"{args.file}: samples per hold {sizes}; first halves fitted, second halves held out")
    print(f"calibrate: in-sample {base.in_sample_mg:.2f} mg, held-out {base.held_out_mg:.2f} mg")
    print(
        f"diagnose (added {', '.join(effects) or 'nothing'}): in-sample "
        f"{found.in_sample_mg:.2f} mg, held-out {found.held_out_mg:.2f} mg"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
