"""The HTML report of a bulk output (a fleet): :func:`fleet_report`, and the fleet table's columns.

:func:`fleet_report` writes ``index.html`` for a folder written by
:func:`accelcore.apps.bulk.bulk` (recognised by its ``fleet.csv``): per sensor type
and temperature coefficient, the distribution across parts per axis against
the datasheet limits, then the fleet table (the sessions with data-quality
warnings named above it) and the failures. The columns of
``fleet.csv`` and ``failures.csv`` are defined here, where they are read; the
bulk application writes them. Part of the outputs room.
"""

from __future__ import annotations

import functools
import hashlib
import os
from pathlib import Path

import numpy as np
import pandas as pd

from accelcore import datasheets
from accelcore._accelcore import __version__
from accelcore.constants import AXES
from accelcore.outputs.report.html import (
    escape,
    figure_html,
    guarded,
    new_figure,
    note,
    page,
    table,
    write_page,
)

__all__ = [
    "FAILURE_COLUMNS",
    "FLEET_COLUMNS",
    "FLEET_PARAMETERS",
    "NO_WARNINGS",
    "fleet_report",
    "is_bulk_output",
]

#: Columns of ``fleet.csv`` / ``fleet.parquet``: one row per session and axis.
FLEET_COLUMNS = (
    "session",
    "serial",
    "sensor",
    "units",
    "axis",
    "zero_g_offset",
    "zero_g_offset_se",
    "sensitivity",
    "sensitivity_se",
    "offset_tc_mg_per_c",
    "offset_tc_mg_per_c_se",
    "sensitivity_tc_pct_per_c",
    "sensitivity_tc_pct_per_c_se",
    "zero_g_offset_in_spec",
    "sensitivity_in_spec",
    "offset_tc_in_spec",
    "sensitivity_tc_in_spec",
    "not_identified",
    "effects",
    "heldout_rms_mg_before",
    "heldout_rms_mg_after",
    "warnings",
)
#: The ``warnings`` cell of a session without data-quality findings (an empty
#: cell would read back as missing, as if the session had not been checked).
NO_WARNINGS = "none"
#: Columns of ``failures.csv``: one row per failed session.
FAILURE_COLUMNS = ("session", "stage", "reason")

#: Temperature coefficients plotted by :func:`fleet_report`: column, label, unit.
FLEET_PARAMETERS: tuple[tuple[str, str, str], ...] = (
    ("offset_tc_mg_per_c", "zero-g offset temperature coefficient", "mg/°C"),
    ("sensitivity_tc_pct_per_c", "sensitivity temperature coefficient", "%/°C"),
)


def is_bulk_output(path: str | os.PathLike[str]) -> bool:
    """Tell whether ``path`` is a folder written by ``accelcore bulk`` (has fleet.csv)."""
    return (Path(path) / "fleet.csv").is_file()


def _limits(sensor: str, parameter: str, axis: str) -> tuple[float | None, float | None] | None:
    try:
        lim = datasheets.load(sensor).limits(parameter, axis)
    except (KeyError, ValueError):
        return None
    return None if lim is None else (lim.min, lim.max)


def _distribution_figure(
    sensor: str, part: pd.DataFrame, column: str, label: str, unit: str
) -> str:
    from matplotlib.ticker import MaxNLocator  # optional: the [plot] extra

    fig = new_figure(13.0, 3.4)
    axs = fig.subplots(1, len(AXES), squeeze=False)[0]
    rng = np.random.default_rng(0)  # fixed jitter: the page is reproducible
    for ax, a in zip(axs, AXES, strict=True):
        values = pd.to_numeric(part.loc[part["axis"] == a, column], errors="coerce").to_numpy(
            dtype=np.float64
        )
        values = values[np.isfinite(values)]
        lim = _limits(sensor, column, a)
        bounds = [v for v in (lim or (None, None)) if v is not None]
        if values.size:
            lo = min([float(values.min()), *bounds])
            hi = max([float(values.max()), *bounds])
            pad = 0.05 * (hi - lo) if hi > lo else max(abs(hi), 1e-6) * 0.1
            bins = np.linspace(lo - pad, hi + pad, 41)
            ax.hist(values, bins=bins, color="tab:blue", alpha=0.6, label=f"{values.size} parts")
            top = ax.get_ylim()[1]
            jitter = rng.uniform(0.05, 0.25, values.size) * top
            ax.plot(values, jitter, "o", ms=4, mfc="none", color="black", label="each part")
            ax.yaxis.set_major_locator(MaxNLocator(integer=True))
            ax.set_xlim(lo - pad, hi + pad)
        else:
            ax.text(0.5, 0.5, "no values", transform=ax.transAxes, ha="center")
        if lim is not None:
            for k, v in enumerate(bounds):
                ax.axvline(
                    v, color="tab:red", ls="--", lw=1.2, label="datasheet limit" if k == 0 else None
                )
        ax.xaxis.set_major_locator(MaxNLocator(5))
        ax.set_title(f"{sensor} {a.upper()}")
        ax.set_xlabel(f"{label} ({unit})")
        ax.set_ylabel("parts")
        ax.legend(loc="best", fontsize="small")
    lim_text = (
        "datasheet limits dashed red"
        if any(_limits(sensor, column, a) for a in AXES)
        else "the datasheet gives no limit"
    )
    return figure_html(
        fig,
        f"{sensor}: {label} across parts per axis ({lim_text}).",
        f"{sensor} {label} distribution",
    )


def _read_csv(path: Path) -> pd.DataFrame:
    try:
        return pd.read_csv(path, dtype=str, keep_default_na=False)
    except pd.errors.EmptyDataError:
        return pd.DataFrame()


def fleet_report(
    bulk_out_dir: str | os.PathLike[str], out_dir: str | os.PathLike[str] | None = None
) -> Path:
    """Write a self-contained HTML report of a bulk output to ``out_dir/index.html``.

    Parameters
    ----------
    bulk_out_dir : path
        A folder written by :func:`accelcore.apps.bulk.bulk` (holding ``fleet.csv``;
        ``failures.csv`` is shown when present).
    out_dir : path, optional
        Where to write ``index.html``; default ``bulk_out_dir`` itself.

    Returns
    -------
    pathlib.Path
        The page written.

    Raises
    ------
    FileNotFoundError
        ``bulk_out_dir`` holds no ``fleet.csv``.
    ValueError
        ``fleet.csv`` lacks the columns of a fleet table.
    ImportError
        matplotlib is not installed.
    """
    src = Path(bulk_out_dir)
    fleet_csv = src / "fleet.csv"
    if not fleet_csv.is_file():
        raise FileNotFoundError(f"{src}: not a bulk output (no fleet.csv)")
    new_figure(1, 1)
    fleet = _read_csv(fleet_csv)
    needed = ["session", "sensor", "axis"] + [c for c, _, _ in FLEET_PARAMETERS]
    missing = [c for c in needed if c not in fleet.columns]
    if missing:
        raise ValueError(f"{fleet_csv}: not a fleet table, missing column(s) {', '.join(missing)}")
    failures = _read_csv(src / "failures.csv") if (src / "failures.csv").is_file() else None
    n_sessions = fleet["session"].nunique()
    n_failed = 0 if failures is None or failures.empty else len(failures)
    sections = [
        f"<h1>Fleet report — {escape(src.resolve().name)}</h1>",
        f"<p>{n_sessions} session(s) calibrated, {len(fleet)} axis row(s), "
        f"{n_failed} failed session(s). Folder: <code>{escape(src.resolve())}</code></p>",
        '<section id="fleet-plots"><h2>Temperature coefficients across parts</h2>',
    ]
    sensors = sorted({s for s in fleet["sensor"] if s}) if len(fleet) else []
    if not sensors and len(fleet):
        sensors = [""]
    for sensor in sensors:
        part = fleet[fleet["sensor"] == sensor]
        shown = sensor or "unnamed sensor"
        for column, label, unit in FLEET_PARAMETERS:
            sections.append(
                guarded(
                    f"{shown} {label} plot",
                    functools.partial(_distribution_figure, shown, part, column, label, unit),
                )
            )
    if not len(fleet):
        sections.append(note("The fleet table is empty: no session was calibrated."))
    sections.append("</section>")
    # In/out of spec counts per sensor and parameter.
    spec_cols = [c for c in FLEET_COLUMNS if c.endswith("_in_spec") and c in fleet.columns]
    counts = []
    for sensor in sensors:
        part = fleet[fleet["sensor"] == sensor]
        for c in spec_cols:
            v = part[c].str.lower()
            counts.append(
                {
                    "sensor": sensor or "unnamed",
                    "parameter": c.removesuffix("_in_spec"),
                    "in spec": int((v == "true").sum()),
                    "out of spec": int((v == "false").sum()),
                    "no limit / n.i.": int(((v != "true") & (v != "false")).sum()),
                }
            )
    sections += [
        '<section id="spec-counts"><h2>In and out of datasheet spec (axis rows)</h2>',
        table(["sensor", "parameter", "in spec", "out of spec", "no limit / n.i."], counts)
        if counts
        else note("No rows."),
        "</section>",
        '<section id="fleet-table"><h2>Fleet table</h2>',
    ]
    cols = [str(c) for c in fleet.columns]
    text = ("session", "serial", "sensor", "units", "axis", "not_identified", "effects", "warnings")
    numeric = [c for c in cols if c not in text and c not in spec_cols]
    if "warnings" in fleet.columns:
        pairs = zip(fleet["session"], fleet["warnings"], strict=True)
        flagged = sorted({s for s, w in pairs if _flagged(w)})
        sections.append(
            "<p>"
            + (
                f"{len(flagged)} session(s) with data-quality warnings (column "
                f"<code>warnings</code>): {escape(', '.join(flagged))}"
                if flagged
                else "No session has a data-quality warning."
            )
            + "</p>"
        )
    sections += [
        table(cols, fleet.to_dict(orient="records"), numeric=numeric, spec=spec_cols, cls="fleet"),
        "</section>",
        '<section id="failures"><h2>Failures</h2>',
    ]
    if failures is None:
        sections.append(note("No failures.csv in this folder."))
    elif failures.empty:
        sections.append("<p>No session failed.</p>")
    else:
        sections.append(
            table([str(c) for c in failures.columns], failures.to_dict(orient="records"))
        )
    sections += [
        "</section>",
        '<section id="provenance"><h2>Provenance</h2>',
        f"<p>accelcore {escape(__version__)}; read {escape(fleet_csv.name)} "
        f"({escape(_sha256(fleet_csv))})</p>",
        "</section>",
    ]
    target = Path(out_dir) if out_dir is not None else src
    return write_page(target, page(f"accelcore fleet report: {src.resolve().name}", sections))


def _flagged(cell: str) -> bool:
    """Whether a ``warnings`` cell holds findings (not empty, not "none")."""
    return bool(cell) and cell != NO_WARNINGS


def _sha256(path: Path) -> str:
    return f"sha256 {hashlib.sha256(path.read_bytes()).hexdigest()}"
