"""Session consistency before any fit: labels, units and rate against the data.

A calibration fits the output of each run against the gravity its orientation
label says it saw, in the declared units, on blocks the declared rate cut. If
any of the three is wrong the fit still returns numbers, wrong ones; these
checks refuse such a session first.

:func:`check_labels`
    Per axis, every run's median output must lie on one rising straight line
    against the gravity its label gives that axis (every pair of runs, not only
    the ``+`` and ``-`` runs of one axis): two ``OX+`` runs of which one was
    really ``OX-``, a run labelled ``OX+`` that lay on its side, swapped files.
    The line's slope must match the units: about 1 per g in ``g``, 9.81 in
    ``m/s2``, and for ``V`` or ``LSB`` the datasheet of a known sensor, whose
    own units must be the declared ones.
:func:`check_rate`
    No decimated block may hold far more raw samples than the decimation factor:
    that happens only when ``rate_hz`` (or ``time_unit``) understates the logs'
    real rate, and the blocks then average whole sweeps into a few points.

May import: the foundation (:mod:`accelcore.datasheets` among it).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from accelcore import datasheets
from accelcore.constants import AXES, STANDARD_GRAVITY, UNITS_PER_G
from accelcore.errors import DataQualityWarning, SessionFormatError
from accelcore.input.run import Run

__all__ = [
    "LABEL_TOLERANCE_G",
    "RATE_SLACK",
    "SCALE_TOLERANCE",
    "check_labels",
    "check_rate",
]

#: Largest distance, in g, of a run's median output from the line through all
#: runs. A mislabelled run is off by 1 g or more; offset drift over a sweep,
#: cross-axis sensitivity and a fixture a few degrees off stay well below 0.1 g.
LABEL_TOLERANCE_G = 0.3

#: Largest ratio between the fitted scale (output per g) and the expected one
#: before the units are called wrong: V and LSB, g and m/s2 differ by far more.
SCALE_TOLERANCE = 3.0

#: A block holding more than this many times the decimation factor of raw
#: samples means the time stamps are denser than ``rate_hz`` says (and ``compensate
#: --session`` allows a log's time step this far from ``1 / rate_hz``).
RATE_SLACK = 1.5


def check_rate(runs: Sequence[Run], rate_hz: float, factor: int, where: str) -> None:
    """Refuse runs whose blocks hold far more raw samples than ``factor``.

    Parameters
    ----------
    runs : sequence of Run
    rate_hz : float
        The declared raw rate.
    factor : int
        Raw samples per block.
    where : str
        What messages name (the session folder).

    Raises
    ------
    accelcore.SessionFormatError
        A run's median block holds more than 1.5 x ``factor`` samples.
    """
    for run in runs:
        if not len(run) or run.count.max() <= RATE_SLACK * factor:
            continue  # no block holds too many, so neither does the median one
        typical = float(np.median(run.count))
        if typical > RATE_SLACK * factor:
            seen = run.stats.mean_rate_hz
            hint = f"; its time stamps say about {seen:.6g} Hz" if np.isfinite(seen) else ""
            raise SessionFormatError(
                f"{where}: run {run.label} ({run.orientation}) puts a median {typical:.0f} raw "
                f"samples in each block of {factor} at rate_hz = {rate_hz:g} Hz{hint}; rate_hz "
                "or time_unit is wrong, and the blocks would average whole sweeps into a few "
                "points"
            )


def check_labels(
    runs: Sequence[Run],
    units: str,
    sensor: str | None,
    where: str,
    gravity_m_s2: float = STANDARD_GRAVITY,
) -> None:
    """Refuse runs whose output contradicts their orientation labels or the units.

    Parameters
    ----------
    runs : sequence of Run
    units : str
        The declared units.
    sensor : str or None
        Datasheet name, when known.
    where : str
        What messages name (the session folder).
    gravity_m_s2 : float, default standard gravity
        The local gravity: output per g of a session in ``m/s2``.

    Raises
    ------
    accelcore.SessionFormatError
        A run's labels do not match the gravity it saw (the message says which
        run, what it reads and where its label puts it), or the units contradict
        the data or the sensor's datasheet.

    Warns
    -----
    accelcore.DataQualityWarning
        ``V`` or ``LSB`` data whose scale is far from the datasheet's.
    """
    expected = _expected_scale(units, sensor, where, gravity_m_s2)
    live = [r for r in runs if len(r) and np.isfinite(r.output).any()]
    if not live:
        return
    levels = np.array([r.levels for r in live])
    if not np.isfinite(levels).all():  # finite cells whose block means overflow (1e308)
        i, a = (int(k) for k in np.argwhere(~np.isfinite(levels))[0])
        raise SessionFormatError(
            f"{where}: run {_name(live[i])}: the {AXES[a]} output has no finite level (its "
            "values are so large that their block means overflow): not a sensor output; "
            "check that column of the log"
        )
    lines = level_lines(live)
    for a, axis in enumerate(AXES):
        m = levels[:, a]
        nominal = None if expected is None else expected[a]
        if axis in lines:
            offset, scale = lines[axis]
            _check_line(live, a, axis, offset, scale, nominal, m, where)
            _check_scale(axis, scale, nominal, units, sensor, where)
        elif nominal is not None and len(live) > 1 and np.ptp(m) > LABEL_TOLERANCE_G * nominal:
            hi, lo = int(np.argmax(m)), int(np.argmin(m))
            raise SessionFormatError(
                f"{where}: runs {_name(live[hi])} and {_name(live[lo])} are labelled with the "
                f"same gravity on {axis} but read {axis} = {m[hi]:.6g} and {m[lo]:.6g} "
                f"({(m[hi] - m[lo]) / nominal:.2f} g apart): the runs look swapped or mislabelled"
            )


def level_lines(runs: Sequence[Run]) -> dict[str, tuple[float, float]]:
    """Return each axis' line of the runs' median outputs against their labelled gravity.

    (offset, output per g) by least squares over the runs with a finite output; only
    the axes whose runs see two gravity values or more.
    """
    live = [r for r in runs if len(r) and np.isfinite(r.output).any()]
    if len(live) < 2:
        return {}
    levels = np.array([r.levels for r in live])
    grav = np.array([r.gravity_g for r in live])
    lines: dict[str, tuple[float, float]] = {}
    for a, axis in enumerate(AXES):
        g = grav[:, a]
        if np.ptp(g) > 0:
            design = np.column_stack([np.ones_like(g), g])
            (offset, scale), *_ = np.linalg.lstsq(design, levels[:, a], rcond=None)
            lines[axis] = (float(offset), float(scale))
    return lines


def _name(run: Run) -> str:
    return f"{run.label} ({run.orientation})"


def _check_line(
    live: Sequence[Run],
    a: int,
    axis: str,
    offset: float,
    scale: float,
    nominal: float | None,
    m: NDArray[np.float64],
    where: str,
) -> None:
    """Refuse levels on one axis that do not rise with gravity along one line.

    Distances from the line are measured in g with the nominal scale when there
    is one (a fit of mislabelled runs can give a slope near zero), else the fit's.
    """
    labelled = [r for r in live if r.gravity_g[a] != 0]
    if not scale > 0:
        names = ", ".join(
            f"{_name(r)} reads {float(np.nanmedian(r.output[:, a])):.6g}" for r in labelled
        )
        raise SessionFormatError(
            f"{where}: the {axis} output does not rise with the gravity the labels give {axis} "
            f"(fitted {scale:.6g} per g): {names}; the runs look swapped or mislabelled (their "
            "orientation labels do not match the gravity they saw)"
        )
    resid = m - (offset + scale * np.array([r.gravity_g[a] for r in live]))
    per_g = nominal if nominal is not None and nominal > 0 else scale
    worst = int(np.argmax(np.abs(resid)))
    if abs(resid[worst]) > LABEL_TOLERANCE_G * per_g:
        run = live[worst]
        others = ", ".join(_name(r) for r in live if r is not run)
        raise SessionFormatError(
            f"{where}: run {_name(run)} reads {axis} = {m[worst]:.6g}, "
            f"{resid[worst] / per_g:+.2f} g from where its label puts it against the other "
            f"runs ({others}; {per_g:.6g} per g): the runs look swapped or mislabelled (the "
            "orientation label does not match the gravity the run saw)"
        )


def _check_scale(
    axis: str, scale: float, nominal: float | None, units: str, sensor: str | None, where: str
) -> None:
    """Refuse (or warn about) an output per g far from what the units and datasheet imply."""
    if nominal is None or not nominal > 0:
        return
    ratio = scale / nominal
    if 1 / SCALE_TOLERANCE <= ratio <= SCALE_TOLERANCE:
        return
    source = f"the {sensor} datasheet" if units in ("V", "LSB") else f"units = {units!r}"
    text = (
        f"{where}: the {axis} output changes by {scale:.6g} {units} per g, but {source} "
        f"says about {nominal:.6g} {units} per g ({ratio:.3g} times as much)"
    )
    if units in ("V", "LSB"):
        # A range setting or supply the datasheet does not cover: the fit holds,
        # the datasheet comparison does not.
        warnings.warn(
            text + "; the datasheet comparison will not apply", DataQualityWarning, stacklevel=4
        )
        return
    raise SessionFormatError(text + "; are the units in session.toml right?")


def _expected_scale(
    units: str, sensor: str | None, where: str, gravity_m_s2: float = STANDARD_GRAVITY
) -> tuple[float, float, float] | None:
    """Output per g the units imply: 1, 1000, the local gravity, or the datasheet's typical."""
    if units in UNITS_PER_G:
        return (UNITS_PER_G[units],) * 3
    if units == "m/s2":
        return (gravity_m_s2,) * 3
    if not sensor:
        return None
    try:
        sheet = datasheets.load(sensor)
    except (KeyError, ValueError):
        return None
    if sheet.units in ("V", "LSB") and sheet.units != units:
        raise SessionFormatError(
            f"{where}: units = {units!r}, but the {sheet.name} datasheet gives its output in "
            f"{sheet.units}; declare units = {sheet.units!r}, or the output in g, mg or m/s2"
        )
    typ = sheet.typical("sensitivity")
    if any(t is None for t in typ):
        return None
    return (float(typ[0]), float(typ[1]), float(typ[2]))  # type: ignore[arg-type]
