"""The rows of the bulk fleet table: one per session and axis, built from a calibration.

:func:`fleet_rows` turns a session's :class:`~accelcore.result.calibration.Calibration`,
its :class:`~accelcore.diagnosis.Diagnosis` and its data-quality findings
(:func:`accelcore.input.quality.check_session`) into the rows of ``fleet.csv``
(columns :data:`accelcore.outputs.report.fleet.FLEET_COLUMNS`), the lab's
record (the ``[lab]`` table of ``session.toml``) in the ``lab_*`` columns.
:func:`warnings_cell` is the short form of the findings shown in the ``warnings``
column, so a suspect session stands out in the table. Part of the apps room.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from accelcore import datasheets
from accelcore.diagnosis import Diagnosis
from accelcore.input.format import LAB_KEYS
from accelcore.input.quality import QualityIssue
from accelcore.outputs.report.fleet import NO_WARNINGS
from accelcore.result.calibration import Calibration

__all__ = ["fleet_rows", "warnings_cell"]

#: Short name of each kind of quality finding, in the order shown in the ``warnings``
#: column: what most undermines a calibration first.
_SHORT_NAMES = {
    "short": "short run",
    "temperature": "sweep not covering the window",
    "rate": "sample rate off",
    "gaps": "gaps",
    "step": "step",
    "clipping": "clipping",
    "truncated": "truncated last line",
    "nonfinite": "non-finite rows skipped",
    "outliers": "spikes left out",
}


def _name(issue: QualityIssue) -> str:
    if issue.kind == "temperature" and issue.channel:
        return f"axis {issue.channel}: few bins with both orientations"
    return _SHORT_NAMES.get(issue.kind, issue.kind)


def warnings_cell(issues: Sequence[QualityIssue]) -> str:
    """Join the short form of the findings into one table cell.

    Parameters
    ----------
    issues : sequence of QualityIssue
        From :func:`accelcore.input.quality.check_session`.

    Returns
    -------
    str
        One entry per kind of finding, ``"; "``-separated, the runs concerned in
        brackets: e.g. ``"short run (x_pos.csv); spikes left out (y_neg.csv, z_pos.csv)"``.
        Kinds come in a fixed order (a short run or a sweep not covering the
        window first, spikes last), so the cell does not depend on how the
        sessions were scheduled; ``"none"`` when there is no finding (an empty
        cell would read back as missing, as if the session had not been checked).
    """
    order = list(_SHORT_NAMES)
    found: dict[str, tuple[int, dict[str, None]]] = {}
    for issue in issues:
        rank = order.index(issue.kind) if issue.kind in order else len(order)
        _, runs = found.setdefault(_name(issue), (rank, {}))
        if issue.run:
            runs.setdefault(issue.run, None)
    parts = [
        f"{name} ({', '.join(runs)})" if runs else name
        for name, (_, runs) in sorted(found.items(), key=lambda item: (item[1][0], item[0]))
    ]
    return "; ".join(parts) or NO_WARNINGS


def fleet_rows(
    rel: str,
    cal: Calibration,
    diag: Diagnosis | None,
    issues: Sequence[QualityIssue] = (),
) -> list[dict[str, Any]]:
    """Return the fleet-table rows of one session, one per axis.

    Parameters
    ----------
    rel : str
        The session folder relative to the archive.
    cal : Calibration
        Its calibration.
    diag : Diagnosis or None
        Its diagnosis, if one was run (else the effects and held-out columns are empty).
    issues : sequence of QualityIssue, default ()
        Its data-quality findings, shown in the ``warnings`` column.

    Returns
    -------
    list of dict
        Keyed by :data:`accelcore.outputs.report.fleet.FLEET_COLUMNS`; a
        ``lab_*`` field the session's ``[lab]`` table does not give is NaN
        (missing, as an empty CSV cell reads back).
    """
    sheet = None
    if cal.sensor:
        try:
            sheet = datasheets.load(cal.sensor)
        except (KeyError, ValueError):
            sheet = None
    effects = ";".join(diag.effects) if diag is not None else ""
    warnings = warnings_cell(issues)
    given = cal.provenance.get("lab") or {}
    lab = {f"lab_{k}": (str(given[k]) if given.get(k) else math.nan) for k in LAB_KEYS}
    rows = []
    for axis in cal.axes:
        s = cal.axis(axis)

        def spec(parameter: str, value: float, axis: str = axis) -> bool | None:
            if sheet is None or math.isnan(value):
                return None
            ok = sheet.in_spec(parameter, axis, value)
            return None if ok is None else bool(ok)

        not_identified = [n for n in cal.not_identified if n.startswith(f"{axis}:")]
        rows.append(
            {
                "session": rel,
                "serial": cal.serial or "",
                "sensor": cal.sensor or "",
                "units": cal.units,
                "axis": axis,
                "zero_g_offset": s.zero_g_offset,
                "zero_g_offset_se": s.zero_g_offset_se,
                "sensitivity": s.sensitivity,
                "sensitivity_se": s.sensitivity_se,
                "offset_tc_mg_per_c": s.offset_tc_mg_per_c,
                "offset_tc_mg_per_c_se": s.offset_tc_mg_per_c_se,
                "sensitivity_tc_pct_per_c": s.sensitivity_tc_pct_per_c,
                "sensitivity_tc_pct_per_c_se": s.sensitivity_tc_pct_per_c_se,
                "zero_g_offset_in_spec": spec("zero_g_offset", s.zero_g_offset),
                "sensitivity_in_spec": spec("sensitivity", s.sensitivity),
                "offset_tc_in_spec": spec("offset_tc_mg_per_c", s.offset_tc_mg_per_c),
                "sensitivity_tc_in_spec": spec(
                    "sensitivity_tc_pct_per_c", s.sensitivity_tc_pct_per_c
                ),
                "not_identified": ";".join(not_identified),
                "effects": effects,
                "heldout_rms_mg_before": (
                    diag.steps[0].rms_out_axis_mg[axis] if diag is not None else math.nan
                ),
                "heldout_rms_mg_after": (
                    diag.steps[-1].rms_out_axis_mg[axis] if diag is not None else math.nan
                ),
                "warnings": warnings,
                **lab,
            }
        )
    return rows
