"""What a fitted calibration says against the runs' own levels: a sensitivity the data do not show.

The joint fit separates an axis' offset and tempco from its sensitivity by the
orientations: each gravity value seen over the same temperatures. Where each
orientation was logged at its own temperature (a cold hold at -1 g, a hot one at 0 g),
the temperature terms and the gravity terms explain the same difference between the
runs, and only the temperature's drift inside each run (a degree or so) tells them
apart: the fit can then return a sensitivity of any size or sign, with a small
standard error. :func:`implausible_sensitivities` compares each axis' fitted
sensitivity with the slope of the runs' median outputs against their labelled
gravity (which :func:`accelcore.input.consistency.check_labels` has already checked
against the labels and units).

May import: foundation, input, model, result.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from accelcore.input.consistency import level_lines
from accelcore.input.run import Run
from accelcore.result.calibration import AxisModel

__all__ = ["SENSITIVITY_TOLERANCE", "implausible_sensitivities"]

#: Largest relative difference between the fitted sensitivity at T_ref and the slope of
#: the runs' median outputs against gravity that passes without a word. A MEMS
#: sensitivity moves by 0.01-0.05 %/°C: a few percent over a chamber's range; a quarter
#: is far outside anything temperature does to it.
SENSITIVITY_TOLERANCE = 0.25


def implausible_sensitivities(
    runs: Sequence[Run], axes: Mapping[str, AxisModel], units: str
) -> list[str]:
    """Return one line per axis whose fitted sensitivity the runs' levels contradict.

    Only axes whose runs see two gravity values or more; the slope is that of the
    line of the runs' median outputs against their labelled gravity
    (:func:`accelcore.input.consistency.level_lines`, the label check's).
    """
    out: list[str] = []
    for a, (_, slope) in level_lines(runs).items():
        if a not in axes:
            continue
        fitted, _ = axes[a].value("gain", "1", a)
        if not (np.isfinite(fitted) and slope != 0.0):
            continue
        if abs(fitted / slope - 1.0) <= SENSITIVITY_TOLERANCE:
            continue
        out.append(
            f"{a}: the fitted sensitivity at T_ref, {fitted:.4g} {units}/g, is "
            f"{fitted / slope:.3g} times the slope of the runs' median outputs against "
            f"their gravity, {slope:.4g} {units}/g: the temperature terms trade off with "
            "the gravity terms (each orientation logged at its own temperatures, only the "
            "drift inside each run tells them apart); log every orientation over the same "
            "temperatures, or fit without temperature terms (terms=...)"
        )
    return out
