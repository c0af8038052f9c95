"""Residual plots of a diagnosis: base model and diagnosed, against two observables.

- :func:`plot_residuals_per_axis` (the report's figure): one panel per sensor
  axis (x, y, z stacked, sharing the horizontal axis), against temperature and
  against a second observable; the diagnosed model's residual as points (every
  k-th sample, at most :data:`~accelcore.outputs.plots.MAX_POINTS` per panel)
  with the binned mean of the base and of the diagnosed model's residual as
  trend lines.
- :func:`plot_diagnosis`: the compact overview, all axes in one panel per
  model and observable.

matplotlib is an optional extra, so it is imported when a function is called
(not at module level); without it they raise :class:`ImportError` saying
``pip install accelcore[plot]``. Part of the outputs room.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from accelcore.constants import AXES
from accelcore.diagnosis import Diagnosis, residuals
from accelcore.outputs.plots import MAX_POINTS, stride

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["OBSERVABLE_LABELS", "binned_mean", "plot_diagnosis", "plot_residuals_per_axis"]

#: Plain axis labels of the observables of :func:`accelcore.diagnosis.residuals`.
OBSERVABLE_LABELS = {
    "temperature_c": "temperature (°C)",
    "elapsed_s": "elapsed time (s)",
    "time_s": "time (s)",
    "dtemp_dt_c_per_min": "rate of temperature (°C/min)",
    "run_index": "run",
}


def _label(observable: str) -> str:
    return OBSERVABLE_LABELS.get(observable, observable.replace("_", " "))


def _pyplot() -> Any:
    try:
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover - optional dependency
        raise ImportError(
            "the residual plots need matplotlib, an optional extra: pip install accelcore[plot]"
        ) from exc
    return plt


def binned_mean(
    x: NDArray[np.float64], y: NDArray[np.float64], *, width: float | None = None, bins: int = 40
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Return the means of ``y`` in bins of ``x`` (the trend of a residual cloud).

    Parameters
    ----------
    x, y : ndarray
        Points; non-finite pairs are left out.
    width : float, optional
        Bin width in units of ``x`` (edges at multiples of it); default
        ``bins`` equal bins over the range of ``x``. A width that would make
        more than 200 bins falls back to ``bins`` equal bins.
    bins : int, default 40
        Number of equal bins when no usable ``width`` is given.

    Returns
    -------
    centres, means : ndarray
        Of the bins holding at least three points, in increasing ``x``.
    """
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    if x.size == 0:
        return np.empty(0), np.empty(0)
    lo, hi = float(x.min()), float(x.max())
    if width is not None and width > 0 and (hi - lo) / width <= 200:
        edges = np.arange(math.floor(lo / width) * width, hi + width, width)
    else:
        edges = np.linspace(lo, hi if hi > lo else lo + 1.0, bins + 1)
    n = edges.size - 1
    idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, n - 1)
    counts = np.bincount(idx, minlength=n)
    sums = np.bincount(idx, weights=y, minlength=n)
    keep = counts >= 3
    centres = 0.5 * (edges[:-1] + edges[1:])
    return centres[keep], sums[keep] / counts[keep]


def plot_residuals_per_axis(
    diagnosis: Diagnosis, observable: str | None = None, *, max_points: int = MAX_POINTS
) -> Figure:
    """Residual per sensor axis against temperature and an observable, with binned trends.

    Rows are the axes x, y and z (panels of a column share their horizontal
    axis); the left column is against temperature, the right against
    ``observable`` (left out when it is temperature or not numeric). Points:
    the diagnosed model's residual, every k-th sample so a panel draws at
    most ``max_points``. Lines: the mean of the residual in 1 °C bins (40
    equal bins for the observable) for the base model (dashed) and the
    diagnosed model (solid); one line when the diagnosis added nothing.

    Parameters
    ----------
    diagnosis : Diagnosis
        A result of :func:`accelcore.diagnose` that still holds its data.
    observable : str, optional
        Column of :func:`accelcore.diagnosis.residuals`; default
        :attr:`Diagnosis.default_observable`.
    max_points : int, default :data:`~accelcore.outputs.plots.MAX_POINTS`
        Points drawn at most per panel.

    Returns
    -------
    matplotlib.figure.Figure
        Three rows (x, y, z) by one or two columns.

    Raises
    ------
    ImportError
        Without matplotlib.
    accelcore.ParameterError
        If the diagnosis was restored without its data.
    """
    plt = _pyplot()
    session = diagnosis.session
    after = residuals(diagnosis.calibration, session)
    same = not diagnosis.effects
    before = after if same else residuals(diagnosis.base, session)
    obs = observable or diagnosis.default_observable
    xs = ["temperature_c"]
    if obs != "temperature_c" and obs in after and pd.api.types.is_numeric_dtype(after[obs]):
        xs.append(obs)
    fig, axs = plt.subplots(
        len(AXES),
        len(xs),
        figsize=(5.6 * len(xs), 6.6),
        sharex="col",
        sharey="row",
        squeeze=False,
    )
    # Fixed margins in inches (a layout engine would draw the figure twice).
    w, h = fig.get_size_inches()
    fig.subplots_adjust(
        left=0.75 / w, right=1 - 0.15 / w, bottom=0.55 / h, top=1 - 0.35 / h, hspace=0.12
    )
    fig.subplots_adjust(wspace=0.5 / ((w - 0.9 - 0.5 * (len(xs) - 1)) / len(xs)))
    k = stride(len(after), max_points)
    for col, x in enumerate(xs):
        width = 1.0 if x == "temperature_c" else None
        for row, a in enumerate(AXES):
            ax = axs[row][col]
            err = f"err_{a}_mg"
            xv = after[x].to_numpy(dtype=np.float64)
            yv = after[err].to_numpy(dtype=np.float64)
            ax.plot(xv[::k], yv[::k], ".", ms=1.5, color="tab:blue", alpha=0.35, zorder=1)
            if not same:
                cx, my = binned_mean(
                    before[x].to_numpy(dtype=np.float64),
                    before[err].to_numpy(dtype=np.float64),
                    width=width,
                )
                ax.plot(cx, my, "--", color="tab:orange", lw=1.6, zorder=3, label="base model")
            cx, my = binned_mean(xv, yv, width=width)
            label = "binned mean" if same else "diagnosed"
            ax.plot(cx, my, "-", color="black", lw=1.4, zorder=4, label=label)
            ax.axhline(0.0, color="0.5", lw=0.6, zorder=2)
            ax.grid(True, alpha=0.3)
            if col == 0:
                ax.set_ylabel(f"{a} error (mg)")
            if row == len(AXES) - 1:
                ax.set_xlabel(_label(x))
        axs[0][col].set_title(f"against {_label(x)}", fontsize="medium")
    axs[0][0].legend(loc="upper right", fontsize="small")
    return fig  # type: ignore[no-any-return]


def plot_diagnosis(diagnosis: Diagnosis, observable: str | None = None) -> Figure:
    """Residual vs temperature and vs a chosen observable, base model and diagnosed.

    Parameters
    ----------
    diagnosis : Diagnosis
        A result of :func:`accelcore.diagnose` that still holds its data.
    observable : str, optional
        Column of :func:`accelcore.diagnosis.residuals` for the second row; default
        :attr:`Diagnosis.default_observable` (the observable of the strongest
        unexplained structure, else the one the last added effect depends on).

    Returns
    -------
    matplotlib.figure.Figure
        Two rows (temperature, ``observable``) by two columns (base, diagnosed),
        the three axes in each panel (every k-th sample, at most
        :data:`~accelcore.outputs.plots.MAX_POINTS` per axis); see
        :func:`plot_residuals_per_axis` for one panel per axis.

    Raises
    ------
    ImportError
        Without matplotlib.
    accelcore.ParameterError
        If the diagnosis was restored without its data.
    """
    plt = _pyplot()
    session = diagnosis.session
    before = residuals(diagnosis.base, session)
    after = residuals(diagnosis.calibration, session)
    obs = observable or diagnosis.default_observable
    k = stride(len(after))
    fig, axs = plt.subplots(2, 2, figsize=(11, 7), sharey="row", squeeze=False)
    for col, (title, df) in enumerate((("base model", before), ("diagnosed", after))):
        for row, x in enumerate(("temperature_c", obs)):
            ax = axs[row][col]
            for a in AXES:
                ax.plot(df[x][::k], df[f"err_{a}_mg"][::k], ".", ms=1.5, label=a, alpha=0.6)
            ax.set_xlabel(_label(x))
            ax.set_ylabel("error (mg)")
            ax.set_title(title)
            ax.grid(True, alpha=0.3)
    axs[0][0].legend(markerscale=6)
    fig.tight_layout()
    return fig  # type: ignore[no-any-return]
