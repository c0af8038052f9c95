"""The figures of the fleet page: one temperature coefficient across parts, per axis.

:func:`coefficient_figure` draws, per sensor axis, each part as a point with
its standard error and the datasheet limits (a strip plot, one row per part,
labelled by serial) when the fleet is small (fewer than :data:`STRIP_MAX`
sessions), else a histogram with the parts as a rug. Part of the outputs room.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from accelcore import datasheets
from accelcore.constants import AXES
from accelcore.outputs.report.html import figure_html, new_figure

__all__ = ["STRIP_MAX", "coefficient_figure", "limits"]

#: Fleets with fewer sessions than this get a strip plot (every part a labelled
#: point); larger ones a histogram.
STRIP_MAX = 20
#: In-spec flag column of each plotted coefficient.
_FLAGS = {
    "offset_tc_mg_per_c": "offset_tc_in_spec",
    "sensitivity_tc_pct_per_c": "sensitivity_tc_in_spec",
}


def limits(sensor: str, parameter: str, axis: str) -> tuple[float | None, float | None] | None:
    """Return the datasheet limits (min, max) of a parameter, None when there are none.

    Parameters
    ----------
    sensor : str
        Datasheet name.
    parameter : str
        Fleet column (``offset_tc_mg_per_c``, ...).
    axis : str

    Returns
    -------
    tuple or None
    """
    try:
        lim = datasheets.load(sensor).limits(parameter, axis)
    except (KeyError, ValueError):
        return None
    return None if lim is None else (lim.min, lim.max)


def _numbers(part: pd.DataFrame, column: str) -> np.ndarray:
    if column not in part.columns:
        return np.full(len(part), np.nan)
    return pd.to_numeric(part[column], errors="coerce").to_numpy(dtype=np.float64)


def _names(part: pd.DataFrame) -> list[str]:
    serial = part["serial"] if "serial" in part.columns else pd.Series([""] * len(part))
    return [
        str(s) if str(s) else str(sess) for s, sess in zip(serial, part["session"], strict=True)
    ]


def coefficient_figure(
    sensor: str, part: pd.DataFrame, column: str, label: str, unit: str, *, strip: bool
) -> str:
    """Return one coefficient of one sensor type across parts, per axis, as a figure.

    Parameters
    ----------
    sensor : str
        Sensor type (datasheet name) shown and used for limits.
    part : pandas.DataFrame
        Its rows of the fleet table (text cells, as read from ``fleet.csv``).
    column, label, unit : str
        The coefficient's column, its name and unit.
    strip : bool
        A strip plot (every part a labelled point) instead of a histogram.

    Returns
    -------
    str
        The figure's HTML.
    """
    from matplotlib.ticker import MaxNLocator  # optional: the [plot] extra

    n_parts = part["session"].nunique()
    height = 1.3 + 0.3 * n_parts if strip else 3.4
    fig = new_figure(13.0, max(height, 2.6), columns=len(AXES), left=1.4 if strip else 0.95)
    axs = fig.subplots(1, len(AXES), squeeze=False, sharey=strip)[0]
    for ax, a in zip(axs, AXES, strict=True):
        rows = part[part["axis"] == a]
        values = _numbers(rows, column)
        lim = limits(sensor, column, a)
        bounds = [v for v in (lim or (None, None)) if v is not None]
        for k, v in enumerate(bounds):
            label_lim = "datasheet limit" if k == 0 else None
            ax.axvline(v, color="tab:red", ls="--", lw=1.2, label=label_lim)
        if not np.isfinite(values).any():
            ax.text(0.5, 0.5, "no values", transform=ax.transAxes, ha="center")
        elif strip:
            se = _numbers(rows, f"{column}_se")
            flags = rows.get(_FLAGS.get(column, ""), pd.Series([""] * len(rows)))
            out = np.array([str(f).strip().lower() == "false" for f in flags])
            y = np.arange(len(rows))
            for mask, colour, name in (
                (~out, "tab:blue", "in spec / no limit"),
                (out, "tab:red", "out of spec"),
            ):
                if mask.any():
                    ax.errorbar(
                        values[mask],
                        y[mask],
                        xerr=np.nan_to_num(se[mask]),
                        fmt="o",
                        ms=5,
                        color=colour,
                        capsize=2,
                        label=name,
                    )
            ax.set_yticks(y, _names(rows))
            ax.set_ylim(len(rows) - 0.5, -0.5)
            ax.grid(True, axis="x", alpha=0.3)
        else:
            finite = values[np.isfinite(values)]
            lo = min([float(finite.min()), *bounds])
            hi = max([float(finite.max()), *bounds])
            pad = 0.05 * (hi - lo) if hi > lo else max(abs(hi), 1e-6) * 0.1
            ax.hist(
                finite,
                bins=np.linspace(lo - pad, hi + pad, 41),
                color="tab:blue",
                alpha=0.6,
                label=f"{finite.size} parts",
            )
            ax.plot(finite, np.zeros_like(finite), "|", ms=12, color="black", label="each part")
            ax.yaxis.set_major_locator(MaxNLocator(integer=True))
            ax.set_ylabel("parts")
        ax.xaxis.set_major_locator(MaxNLocator(5))
        ax.set_title(f"{sensor} {a.upper()}")
        ax.set_xlabel(f"{label} ({unit})")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="best", fontsize="small")
    lim_text = (
        "datasheet limits dashed red"
        if any(limits(sensor, column, a) for a in AXES)
        else "the datasheet gives no limit"
    )
    how = "each part with its standard error, out of spec in red" if strip else "histogram"
    return figure_html(
        fig,
        f"{sensor}: {label} across parts per axis ({how}; {lim_text}).",
        f"{sensor} {label} across parts",
    )
