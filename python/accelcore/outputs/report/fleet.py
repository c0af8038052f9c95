"""The HTML report of a bulk output (a fleet): :func:`fleet_report`, and the fleet table's columns.

:func:`fleet_report` writes ``index.html`` for a folder written by
:func:`accelcore.apps.bulk.bulk` (recognised by its ``fleet.csv``): every part
with pass or fail against the datasheet (and which checks failed) and its lab
record, per sensor type and temperature coefficient the parts per axis against
the datasheet limits (a strip plot of every part for small fleets, else a
histogram; :mod:`~accelcore.outputs.report.fleet_plots`), then the per-axis
values (the sessions with data-quality warnings named above them) and the
failures. The columns of
``fleet.csv`` and ``failures.csv`` are defined here, where they are read; the
bulk application writes them. Part of the outputs room.
"""

from __future__ import annotations

import functools
import hashlib
import os
from pathlib import Path
from typing import Any

import pandas as pd

from accelcore._accelcore import __version__
from accelcore.input.format import LAB_KEYS
from accelcore.outputs.report.fleet_plots import STRIP_MAX, coefficient_figure
from accelcore.outputs.report.html import (
    escape,
    guarded,
    new_figure,
    note,
    page,
    spec_class,
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
    *(f"lab_{k}" for k in LAB_KEYS),
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
    lead = (
        f"<p>{n_sessions} session(s) calibrated, {len(fleet)} axis row(s), "
        f"{n_failed} failed session(s). Folder: <code>{escape(src.resolve())}</code></p>"
    )
    sections = [
        '<section id="parts"><h2>Parts: pass or fail</h2>',
        guarded("Parts table", lambda: _parts_section(fleet, failures)),
        "</section>",
        '<section id="lab"><h2>Lab record</h2>',
        _lab_section(fleet),
        "</section>",
        '<section id="fleet-plots"><h2>Temperature coefficients across parts</h2>',
    ]
    sensors = sorted({s for s in fleet["sensor"] if s}) if len(fleet) else []
    if not sensors and len(fleet):
        sensors = [""]
    for sensor in sensors:
        part = fleet[fleet["sensor"] == sensor]
        shown = sensor or "unnamed sensor"
        strip = part["session"].nunique() < STRIP_MAX
        for column, label, unit in FLEET_PARAMETERS:
            draw = functools.partial(
                coefficient_figure, shown, part, column, label, unit, strip=strip
            )
            sections.append(guarded(f"{shown} {label} plot", draw))
    if not len(fleet):
        sections.append(note("The fleet table is empty: no session was calibrated."))
    sections.append("</section>")
    spec_cols = [c for c in FLEET_COLUMNS if c.endswith("_in_spec") and c in fleet.columns]
    counts = []
    for sensor in sensors:
        part = fleet[fleet["sensor"] == sensor]
        for c in spec_cols:
            v = part[c].str.lower()
            counts.append(
                {
                    "sensor": sensor or "unnamed",
                    "parameter": _CHECKS.get(c, c),
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
        '<section id="fleet-table"><h2>Values per part and axis</h2>',
    ]
    if "warnings" in fleet.columns:
        pairs = zip(fleet["session"], fleet["warnings"], strict=True)
        flagged = sorted({s for s, w in pairs if _flagged(w)})
        sections.append(
            "<p>"
            + (
                f"{len(flagged)} session(s) with data-quality warnings (listed under Parts): "
                f"{escape(', '.join(flagged))}"
                if flagged
                else "No session has a data-quality warning."
            )
            + "</p>"
        )
    sections += [
        guarded("Fleet table", lambda: _values_table(fleet)),
        "</section>",
        '<section id="failures"><h2>Failures</h2>',
    ]
    if failures is None:
        sections.append(note("No failures.csv in this folder."))
    elif failures.empty:
        sections.append("<p>No session failed.</p>")
    else:
        sections.append(
            table(
                [str(c) for c in failures.columns],
                failures.to_dict(orient="records"),
                wide=["reason"],
            )
        )
    sections += [
        "</section>",
        '<section id="provenance"><h2>Provenance</h2>',
        f"<p>accelcore {escape(__version__)}; read {escape(fleet_csv.name)} "
        f"({escape(_sha256(fleet_csv))})</p>",
        "</section>",
    ]
    target = Path(out_dir) if out_dir is not None else src
    name = src.resolve().name
    return write_page(
        target,
        page(
            f"accelcore fleet report: {name}",
            sections,
            heading=f"Fleet report — {name}",
            lead=lead,
            nav=_NAV,
        ),
    )


#: The navigation bar: section id and link text.
_NAV = (
    ("parts", "Parts"),
    ("lab", "Lab record"),
    ("fleet-plots", "Coefficients"),
    ("spec-counts", "Spec counts"),
    ("fleet-table", "Values"),
    ("failures", "Failures"),
    ("provenance", "Provenance"),
)
#: Plain name of each datasheet check (in-spec flag column).
_CHECKS = {
    "zero_g_offset_in_spec": "zero-g offset",
    "sensitivity_in_spec": "sensitivity",
    "offset_tc_in_spec": "offset TC",
    "sensitivity_tc_in_spec": "sensitivity TC",
}


def _parts_section(fleet: pd.DataFrame, failures: pd.DataFrame | None) -> str:
    """Every session, one row: pass / fail against the datasheet and the checks that failed."""
    spec_cols = [c for c in _CHECKS if c in fleet.columns]
    rows: list[dict[str, Any]] = []
    for session, part in fleet.groupby("session", sort=True):
        failed = [
            f"{axis} {_CHECKS[c]}"
            for axis, flags in zip(
                part["axis"], part[spec_cols].to_dict(orient="records"), strict=True
            )
            for c in spec_cols
            if spec_class(flags[c]) == "out"
        ]
        checked = any(spec_class(v) for c in spec_cols for v in part[c])
        first = part.iloc[0]
        rows.append(
            {
                "serial": first.get("serial", ""),
                "session": session,
                "sensor": first.get("sensor", ""),
                "result": "fail" if failed else ("pass" if checked else "no limits"),
                "flag": "false" if failed else ("true" if checked else ""),
                "failed": ", ".join(failed) or ("–" if checked else "no datasheet limits"),
                "warnings": first.get("warnings", ""),
            }
        )
    for r in [] if failures is None or failures.empty else failures.to_dict(orient="records"):
        rows.append(
            {
                "serial": "",
                "session": r.get("session", ""),
                "sensor": "",
                "result": "not calibrated",
                "flag": "false",
                "failed": f"{r.get('stage', '')}: {r.get('reason', '')}",
                "warnings": "",
            }
        )
    n_fail = sum(r["result"] != "pass" for r in rows)
    head = (
        f"<p>{len(rows) - n_fail} of {len(rows)} session(s) pass every datasheet check "
        "(offset, sensitivity and their temperature coefficients, per axis).</p>"
    )
    return head + table(
        ["serial", "session", "sensor", "result", "failed", "warnings"],
        rows,
        rename={"failed": "failed checks", "warnings": "data-quality warnings"},
        flags={"result": "flag"},
        wide=["failed", "warnings"],
        cls="parts",
    )


def _lab_section(fleet: pd.DataFrame) -> str:
    """Render the ``[lab]`` record of every session that has one (the ``lab_*`` columns)."""
    cols = [f"lab_{k}" for k in LAB_KEYS if f"lab_{k}" in fleet.columns]
    if not cols or not (fleet[cols] != "").to_numpy().any():
        return (
            '<p class="muted">No session has a <code>[lab]</code> table in its '
            "<code>session.toml</code>.</p>"
        )
    firsts = fleet.groupby("session", sort=True).first().reset_index()
    return table(
        ["serial", "session", *cols],
        firsts.to_dict(orient="records"),
        rename={c: c.removeprefix("lab_").replace("_", " ") for c in cols},
        wide=["lab_notes"],
        cls="lab",
    )


def _values_table(fleet: pd.DataFrame) -> str:
    """Per session and axis: the four parameters ± se, coloured by the datasheet check."""
    units = fleet["units"].iloc[0] if "units" in fleet.columns and len(fleet) else ""
    values = {
        "zero_g_offset": (f"zero-g offset ({units})", "zero_g_offset_in_spec"),
        "sensitivity": (f"sensitivity ({units}/g)", "sensitivity_in_spec"),
        "offset_tc_mg_per_c": ("offset TC (mg/°C)", "offset_tc_in_spec"),
        "sensitivity_tc_pct_per_c": ("sensitivity TC (%/°C)", "sensitivity_tc_in_spec"),
    }
    values = {c: v for c, v in values.items() if c in fleet.columns}
    cols = [
        c
        for c in (
            "session",
            "axis",
            *values,
            "heldout_rms_mg_before",
            "heldout_rms_mg_after",
            "not_identified",
            "effects",
        )
        if c in fleet.columns
    ]
    text = {"session", "axis", "not_identified", "effects"}
    rows = []
    for r in fleet.to_dict(orient="records"):
        r["not_identified"] = str(r.get("not_identified", "")).replace(";", ", ")
        r["effects"] = str(r.get("effects", "")).replace(";", ", ")
        rows.append(r)
    return (
        '<p class="muted">Standard errors under each value; green in spec, red out of spec '
        "(the failed checks are named under Parts). TC: temperature coefficient; held-out: "
        "RMS error (mg) on held-out runs before and after the diagnosis.</p>"
        + table(
            cols,
            rows,
            numeric=[c for c in cols if c not in text],
            rename={c: h for c, (h, _) in values.items()}
            | {
                "heldout_rms_mg_before": "held-out before",
                "heldout_rms_mg_after": "held-out after",
            },
            se={c: f"{c}_se" for c in values if f"{c}_se" in fleet.columns},
            flags={c: f for c, (_, f) in values.items() if f in fleet.columns},
            wide=["not_identified"],
            cls="fleet",
        )
    )


def _flagged(cell: str) -> bool:
    """Whether a ``warnings`` cell holds findings (not empty, not "none")."""
    return bool(cell) and cell != NO_WARNINGS


def _sha256(path: Path) -> str:
    return f"sha256 {hashlib.sha256(path.read_bytes()).hexdigest()}"
