"""Plots like the seed paper's Figures 4, 6 and 7 (matplotlib, an optional extra).

- :func:`plot_raw_vs_decimated` (Figure 4): one axis of one run against
  temperature: the raw log, the 2 Hz decimated blocks, the temperature-bin
  means and the fitted line; :func:`plot_averaging` (its lower row in the
  report): the raw and the averaged points about the bin means, with their
  spread, so "before and after averaging" can be seen.
- :func:`plot_sensitivity_vs_temperature` (Figure 6): per temperature bin
  ``S = (V+ - V-)/2`` from the axis' two orientations (equation 9), with the
  calibration's sensitivity line.
- :func:`plot_offset_vs_temperature` (Figure 7): per bin ``V0g = (V+ + V-)/2``
  (equation 8), with the calibration's zero-g offset line.

matplotlib is imported only when a function is called; without it they raise
:class:`ImportError` saying ``pip install accelcore[plot]``. The calibration
lines show the model at steady state: lagged temperature equal to the logged
one, no rate of change, no drift and extra observables at their reference.
A term the data did not identify (:attr:`Calibration.not_identified`, held at
its nominal value) gets no line: its panel says "not identified".

Plotted clouds are thinned to at most :data:`MAX_POINTS` per panel by a fixed
stride (:func:`stride`), so a figure costs the same for a 2 h and a 2-day log
and the same data always draws the same points.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from accelcore import core
from accelcore.constants import AXES
from accelcore.input.session import Run, Session
from accelcore.model import Constant
from accelcore.result.calibration import AxisModel, Calibration

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = [
    "MAX_POINTS",
    "not_identified_terms",
    "plot_averaging",
    "plot_offset_vs_temperature",
    "plot_raw_vs_decimated",
    "plot_sensitivity_vs_temperature",
    "stride",
]

#: Points drawn at most per cloud in a panel (every k-th sample, k from :func:`stride`).
MAX_POINTS = 5000

_DEFAULT_WINDOW_C = (0.0, 60.0)


def stride(n: int, max_points: int = MAX_POINTS) -> int:
    """Return the step k so that every k-th of ``n`` points leaves at most ``max_points``.

    Parameters
    ----------
    n : int
        Number of points.
    max_points : int, default :data:`MAX_POINTS`
        Most points to keep (at least 1).

    Returns
    -------
    int
        ``ceil(n / max_points)``, at least 1.
    """
    return max(1, math.ceil(n / max(1, max_points)))


def not_identified_terms(calibration: Calibration, axis: str, kind: str) -> list[str]:
    """Return the terms of one axis' offset or sensitivity line the data did not identify.

    Parameters
    ----------
    calibration : Calibration
    axis : {"x", "y", "z"}
    kind : {"offset", "gain"}
        The zero-g offset line (offset and its temperature coefficient) or the
        sensitivity line (sensitivity and its coefficient).

    Returns
    -------
    list of str
        Names from :attr:`Calibration.not_identified` (``"z:sensitivity"``, ...).
    """
    base = "sensitivity" if kind == "gain" else "offset"
    wanted = {f"{axis}:{base}", f"{axis}:{base}_tc"}
    return [n for n in calibration.not_identified if n in wanted]


def _pyplot() -> Any:
    try:
        import matplotlib.pyplot as plt
    except ImportError as exc:
        raise ImportError(
            "accelcore's plots need matplotlib, an optional extra: pip install accelcore[plot]"
        ) from exc
    return plt


def _axes_class() -> type[Axes]:
    from matplotlib.axes import Axes

    return Axes


def _steady_state(
    model: AxisModel, kind: str, source: str | None, temp: NDArray[np.float64], t_ref_c: float
) -> NDArray[np.float64]:
    """Sum of one kind of term of a model at steady state, as a function of temperature."""
    out = np.zeros_like(temp)
    for term, c in zip(model.terms, model.coefficients, strict=True):
        if term.kind != kind or (kind == "gain" and term.source != source):
            continue
        if isinstance(term.basis, Constant):
            out = out + c
        elif term.basis.temperature_order is not None:  # lagged or not: equal at steady state
            out = out + c * (temp - t_ref_c) ** term.basis.temperature_order
    return out


def _pick_run(session: Session, run: int | str | None) -> Run:
    if not session.runs:
        raise ValueError("the session has no runs")
    if run is None:
        for r in session.runs:
            if r.orientation == "OZ+":
                return r
        return session.runs[0]
    if isinstance(run, str):
        for r in session.runs:
            if r.orientation == run.strip().upper() or r.label == run:
                return r
        known = ", ".join(f"{r.label} ({r.orientation})" for r in session.runs)
        raise ValueError(f"no run {run!r}; runs: {known}")
    return session.runs[run]


def _read_raw(session: Session, run: Run, axis: str) -> tuple[NDArray[np.float64], ...] | None:
    """Re-read temperature and one axis of a run's raw log; None for in-memory runs."""
    fmt = session.format
    # A run of a single log (fmt.log) is a stretch of it, not a file: not re-read.
    if run.source is None or fmt is None or fmt.log is not None:
        return None
    path = Path(run.source)
    names = (fmt.columns["temperature"], fmt.columns[axis])
    return _read_columns(str(path), path.stat().st_mtime_ns, fmt.separator, names)


@functools.lru_cache(maxsize=4)
def _read_columns(
    path: str, mtime_ns: int, separator: str, names: tuple[str, str]
) -> tuple[NDArray[np.float64], ...]:
    """Read two columns of a log as floats (cached by path and modification time)."""
    del mtime_ns  # part of the cache key only: a rewritten file is read again
    frame = pd.read_csv(path, sep=separator, usecols=list(names))
    frame = frame.apply(pd.to_numeric, errors="coerce")
    out = tuple(frame[n].to_numpy(dtype=np.float64) for n in names)
    for column in out:
        column.flags.writeable = False  # shared between calls
    return out


def _bins(
    runs: Sequence[Run], window_c: tuple[float, float], width_c: float
) -> core.BinnedStats | None:
    binner: core.TemperatureBinner | None = None
    for r in runs:
        b = core.TemperatureBinner(lo_c=window_c[0], hi_c=window_c[1], width_c=width_c)
        b.push(r.time_s, r.temperature_c, r.output)
        if binner is None:
            binner = b
        else:
            binner.merge(b)
    if binner is None:
        return None
    try:
        return binner.finish()
    except ValueError:  # InsufficientDataError: nothing in the window
        return None


def _window(calibration: Calibration | None) -> tuple[float, float]:
    """Return the temperatures binned: the window, else the range the fit used."""
    if calibration is not None and all(math.isfinite(v) for v in calibration.window_c):
        return calibration.window_c
    if calibration is not None and all(math.isfinite(v) for v in calibration.temperature_range_c):
        return calibration.temperature_range_c
    return _DEFAULT_WINDOW_C


def _deviation(
    temp: NDArray[np.float64],
    value: NDArray[np.float64],
    stats: core.BinnedStats | None,
    a: int,
    width_c: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Return the points inside the binned range and their deviation from the bin means."""
    if stats is None or not np.any(stats.count > 0):
        return np.empty(0), np.empty(0)
    keep = stats.count > 0
    t_bins = stats.temperature_c[keep]
    inside = (
        (temp >= t_bins.min() - width_c / 2)
        & (temp <= t_bins.max() + width_c / 2)
        & np.isfinite(value)
    )
    trend = np.interp(temp[inside], t_bins, stats.mean[keep, a])
    return temp[inside], value[inside] - trend


def _sigma(dev: NDArray[np.float64], scale: float, unit: str) -> str:
    return f", σ {float(np.std(dev)) * scale:.2g} {unit}" if dev.size > 1 else ""


def _run_axis(session: Session, run: int | str | None, axis: str | None) -> tuple[Run, str, int]:
    r = _pick_run(session, run)
    if axis is None:
        axis = AXES[int(np.argmax(np.abs(r.gravity_g)))]
    if axis not in AXES:
        raise ValueError(f"axis must be one of {', '.join(AXES)}, got {axis!r}")
    return r, axis, AXES.index(axis)


def plot_averaging(
    session: Session,
    run: int | str | None = None,
    axis: str | None = None,
    *,
    ax: Axes | None = None,
    calibration: Calibration | None = None,
    bin_width_c: float = 0.5,
    max_points: int = MAX_POINTS,
) -> Axes:
    """Plot what averaging does to the scatter: raw and averaged points about the bin means.

    The lower row of the report's Figure 4: for the run and axis of
    :func:`plot_raw_vs_decimated`, the raw log and the decimated block
    averages minus the temperature-bin means, in mg when ``calibration``
    gives the axis' sensitivity (else in the session's units), each with its
    standard deviation σ in the legend. Every k-th point is drawn, at most
    ``max_points`` per cloud.

    Parameters
    ----------
    session : Session
    run : int or str, optional
        As for :func:`plot_raw_vs_decimated`.
    axis : {"x", "y", "z"}, optional
        Default: the axis gravity acts on in that run.
    ax : matplotlib.axes.Axes, optional
        Where to draw; default a new figure.
    calibration : Calibration, optional
        Gives the window, the bin width's context and the sensitivity for mg.
    bin_width_c : float, default 0.5
        Temperature bin width, °C.
    max_points : int, default :data:`MAX_POINTS`
        Points drawn at most per cloud.

    Returns
    -------
    matplotlib.axes.Axes
    """
    plt = _pyplot()
    r, axis, a = _run_axis(session, run, axis)
    if ax is None:
        _, ax = plt.subplots(figsize=(7.0, 3.0), layout="constrained")
    assert ax is not None
    stats = _bins([r], _window(calibration), bin_width_c)
    scale, unit = 1.0, session.units
    if calibration is not None and axis in calibration.axes:
        sens = calibration.axis(axis).sensitivity
        if math.isfinite(sens) and sens != 0.0:
            scale, unit = 1000.0 / abs(sens), "mg"
    data = _read_raw(session, r, axis)
    if data is not None:
        t, dev = _deviation(data[0], data[1], stats, a, bin_width_c)
        k = stride(t.size, max_points)
        label = f"raw, {session.rate_hz:g} Hz{_sigma(dev, scale, unit)}"
        ax.plot(t[::k], scale * dev[::k], ".", ms=2.0, color="0.62", zorder=1, label=label)
    t, dev = _deviation(r.temperature_c, r.output[:, a], stats, a, bin_width_c)
    k = stride(t.size, max_points)
    block_hz = session.rate_hz / session.decimation_factor
    label = f"{block_hz:g} Hz averages{_sigma(dev, scale, unit)}"
    ax.plot(t[::k], scale * dev[::k], ".", ms=2.5, color="tab:blue", zorder=2, label=label)
    ax.axhline(0.0, color="black", lw=0.8, zorder=3)
    ax.set_xlabel("temperature (°C)")
    ax.set_ylabel(f"minus bin means ({unit})")
    ax.legend(loc="upper right", fontsize="small", markerscale=3.0)
    return ax


def plot_raw_vs_decimated(
    session: Session,
    run: int | str | None = None,
    axis: str | None = None,
    *,
    ax: Axes | None = None,
    calibration: Calibration | None = None,
    raw: bool = True,
    bin_width_c: float = 0.5,
    max_raw_points: int = 20_000,
) -> Axes:
    """Plot one axis of one run against temperature before and after averaging (Figure 4).

    Layers, bottom to top: the raw log (re-read from the run's file, every k-th
    sample so at most ``max_raw_points`` are drawn), the decimated 2 Hz block
    averages (thinned the same way), the means of ``bin_width_c`` temperature
    bins over the calibration window, and a line: the calibration's model of
    this run when ``calibration`` is given, else a least-squares line through
    the bin means. :func:`plot_averaging` shows the same points about the bin
    means, where the narrowing by averaging can be seen and measured.

    Parameters
    ----------
    session : Session
    run : int or str, optional
        Run index, orientation (``"OZ+"``) or file name; default the ``OZ+``
        run (the paper's Figure 4), else the first.
    axis : {"x", "y", "z"}, optional
        Default: the axis gravity acts on in that run.
    ax : matplotlib.axes.Axes, optional
        Where to draw; default a new figure.
    calibration : Calibration, optional
        Draws its model and takes its temperature window.
    raw : bool, default True
        Draw the raw samples (in-memory sessions have none to re-read).
    bin_width_c : float, default 0.5
        Temperature bin width, °C.
    max_raw_points : int, default 20000
        Raw samples drawn at most (every k-th sample); the decimated points
        are thinned to the same number. The report passes :data:`MAX_POINTS`.

    Returns
    -------
    matplotlib.axes.Axes
    """
    plt = _pyplot()
    r, axis, a = _run_axis(session, run, axis)
    if ax is None:
        _, ax = plt.subplots(figsize=(7.0, 4.5), layout="constrained")
    assert ax is not None
    units = session.units
    window = _window(calibration)
    stats = _bins([r], window, bin_width_c)
    data = _read_raw(session, r, axis) if raw else None
    if data is not None:
        k = stride(data[0].shape[0], max_raw_points)
        rate = f"{session.rate_hz:g} Hz" + (f", every {k}th sample" if k > 1 else "")
        ax.plot(
            data[0][::k],
            data[1][::k],
            ".",
            ms=2.0,
            color="0.62",
            zorder=1,
            label=f"raw ({rate})",
        )
    block_hz = session.rate_hz / session.decimation_factor
    k = stride(r.temperature_c.shape[0], max_raw_points)
    ax.plot(
        r.temperature_c[::k],
        r.output[::k, a],
        ".",
        ms=2.5,
        color="tab:blue",
        zorder=2,
        label=f"decimated ({block_hz:g} Hz)",
    )
    if stats is not None:
        keep = stats.count > 0
        ax.plot(
            stats.temperature_c[keep],
            stats.mean[keep, a],
            "o",
            ms=3.0,
            mew=0.8,
            mfc="none",
            color="tab:orange",
            zorder=3,
            label=f"{bin_width_c:g} °C bin means",
        )
    if calibration is not None and axis in calibration.axes:
        m = calibration.axes[axis]
        lo, hi = calibration.temperature_range_c
        t = np.linspace(lo, hi, 200)
        y = _steady_state(m, "offset", None, t, calibration.t_ref_c)
        for b, g in zip(AXES, r.gravity_g, strict=True):
            if g != 0.0:
                y = y + g * _steady_state(m, "gain", b, t, calibration.t_ref_c)
        if np.all(np.isfinite(y)):
            ax.plot(
                t,
                y,
                "-",
                color="black",
                lw=1.2,
                zorder=4,
                label=f"calibration ({calibration.method})",
            )
    elif stats is not None and np.count_nonzero(stats.count > 0) >= 2:
        keep = stats.count > 0
        slope, intercept = np.polyfit(stats.temperature_c[keep], stats.mean[keep, a], 1)
        t = np.array([stats.temperature_c[keep].min(), stats.temperature_c[keep].max()])
        ax.plot(
            t,
            intercept + slope * t,
            "-",
            color="black",
            lw=1.2,
            zorder=4,
            label="linear fit of bins",
        )
    ax.set_xlabel("temperature (°C)")
    ax.set_ylabel(f"{axis} output ({units})")
    ax.set_title(f"{session.sensor or 'sensor'} {axis.upper()}, run {r.label} ({r.orientation})")
    ax.legend(loc="best", fontsize="small", markerscale=3.0)
    return ax


def _paired(
    session: Session,
    calibration: Calibration,
    kind: str,
    ax: Axes | Sequence[Axes] | None,
    sensor_axes: Sequence[str] | None,
) -> list[Axes]:
    plt = _pyplot()
    names = [a for a in (sensor_axes or AXES) if a in calibration.axes]
    if not names:
        raise ValueError("nothing to plot: none of the requested axes is calibrated")
    if ax is None:
        _, made = plt.subplots(
            1, len(names), figsize=(4.2 * len(names), 3.8), layout="constrained", squeeze=False
        )
        targets: list[Axes] = list(made[0])
    elif isinstance(ax, _axes_class()):
        targets = [ax] * len(names)
    else:  # a sequence (or array) of Axes
        targets = list(cast("Sequence[Axes]", ax))
        if len(targets) != len(names):
            raise ValueError(f"ax holds {len(targets)} Axes for {len(names)} sensor axes")
    window = _window(calibration)
    width = float(calibration.options.get("bin_width_c", 0.5))
    units = calibration.units
    shared = len(set(map(id, targets))) == 1
    for target, a in zip(targets, names, strict=True):
        i = AXES.index(a)
        plus = _bins([r for r in session.runs if r.orientation == f"O{a.upper()}+"], window, width)
        minus = _bins([r for r in session.runs if r.orientation == f"O{a.upper()}-"], window, width)
        prefix = f"{a}: " if shared else ""
        if plus is not None and minus is not None:
            both = (plus.count > 0) & (minus.count > 0)
            temp = 0.5 * (plus.temperature_c[both] + minus.temperature_c[both])
            v_pos, v_neg = plus.mean[both, i], minus.mean[both, i]
            value = 0.5 * (v_pos - v_neg) if kind == "gain" else 0.5 * (v_pos + v_neg)
            formula = "(V₊−V₋)/2" if kind == "gain" else "(V₊+V₋)/2"
            target.plot(temp, value, "o", ms=3.0, mfc="none", label=f"{prefix}bins {formula}")
        else:
            target.text(
                0.5,
                0.5,
                f"no O{a.upper()}+ / O{a.upper()}- pair",
                transform=target.transAxes,
                ha="center",
            )
        lo, hi = calibration.temperature_range_c
        t = np.linspace(lo, hi, 200)
        line = _steady_state(
            calibration.axes[a], kind, a if kind == "gain" else None, t, calibration.t_ref_c
        )
        s = calibration.axis(a)
        held = not_identified_terms(calibration, a, kind)
        if held:
            target.text(
                0.5,
                0.12,
                f"{prefix}not identified: {', '.join(held)}\n(held, not fitted: no line drawn)",
                transform=target.transAxes,
                ha="center",
                va="bottom",
                fontsize="small",
                color="tab:red",
            )
        elif np.all(np.isfinite(line)):
            tc = (
                f"{s.sensitivity_tc_pct_per_c:+.4f} %/°C"
                if kind == "gain"
                else f"{s.offset_tc_mg_per_c:+.3f} mg/°C"
            )
            target.plot(t, line, "-", color="black", lw=1.2, label=f"{prefix}fit {tc}")
        target.set_xlabel("temperature (°C)")
        quantity = "sensitivity" if kind == "gain" else "zero-g offset"
        unit = f"{units}/g" if kind == "gain" else units
        target.set_ylabel(f"{quantity} ({unit})")
        if not shared:
            target.set_title(f"{calibration.sensor or 'sensor'} {a.upper()}")
        if target.get_lines():
            target.legend(loc="best", fontsize="small")
        elif not shared:  # nothing to read off the axes: no made-up 0…1 scale
            target.set_xticks([])
            target.set_yticks([])
    return targets


def plot_sensitivity_vs_temperature(
    session: Session,
    calibration: Calibration,
    *,
    ax: Axes | Sequence[Axes] | None = None,
    sensor_axes: Sequence[str] | None = None,
) -> list[Axes]:
    """Plot sensitivity against temperature per axis (the paper's Figure 6).

    Points: per temperature bin (the calibration's window and bin width),
    ``S = (V+ - V-)/2`` from the axis' two orientations (equation 9; repeat
    sweeps of one orientation are merged). Line: the calibration's sensitivity
    over the temperature range it was fitted on.

    Parameters
    ----------
    session : Session
        The session the calibration was fitted on.
    calibration : Calibration
    ax : matplotlib.axes.Axes or sequence of Axes, optional
        One Axes for all axes, or one per axis; default a new figure with one
        panel per axis.
    sensor_axes : sequence of str, optional
        Axes to plot; default every calibrated axis.

    Returns
    -------
    list of matplotlib.axes.Axes
        One per plotted axis (the same object repeated when one was given).
    """
    return _paired(session, calibration, "gain", ax, sensor_axes)


def plot_offset_vs_temperature(
    session: Session,
    calibration: Calibration,
    *,
    ax: Axes | Sequence[Axes] | None = None,
    sensor_axes: Sequence[str] | None = None,
) -> list[Axes]:
    """Plot zero-g offset against temperature per axis (the paper's Figure 7).

    Points: per temperature bin, ``V0g = (V+ + V-)/2`` from the axis' two
    orientations (equation 8). Line: the calibration's zero-g offset.

    Parameters
    ----------
    session : Session
        The session the calibration was fitted on.
    calibration : Calibration
    ax : matplotlib.axes.Axes or sequence of Axes, optional
        One Axes for all axes, or one per axis; default a new figure with one
        panel per axis.
    sensor_axes : sequence of str, optional
        Axes to plot; default every calibrated axis.

    Returns
    -------
    list of matplotlib.axes.Axes
        One per plotted axis (the same object repeated when one was given).
    """
    return _paired(session, calibration, "offset", ax, sensor_axes)
