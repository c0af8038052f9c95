"""Text tables of a calibration for the terminal: the per-axis summary and the datasheet section.

Part of the outputs room: it reads a :class:`accelcore.result.Calibration` and
returns text; it imports the result room and the foundation, never the applications.
"""

from __future__ import annotations

import math
from typing import Any

from accelcore import datasheets
from accelcore.result.calibration import Calibration

__all__ = ["datasheet_section", "summary_text"]


def _pm(value: float, se: float, digits: int) -> str:
    if not math.isfinite(value):
        return "n/a"
    if not math.isfinite(se) or se == 0.0:
        return f"{value:.{digits}f} (fixed)" if se == 0.0 else f"{value:.{digits}f}"
    return f"{value:.{digits}f} ± {se:.1g}"


def summary_text(cal: Calibration) -> str:
    """Compact per-axis summary of a calibration for the terminal.

    Parameters
    ----------
    cal : accelcore.Calibration

    Returns
    -------
    str
        A heading, one line per axis (offset and sensitivity at ``t_ref_c``,
        both temperature coefficients, each with its standard error, and the
        fit's RMS residual in mg), then what was not identified and the notes.
    """
    u = cal.units
    lo, hi = cal.temperature_range_c
    serial = f" #{cal.serial}" if cal.serial else ""
    lines = [
        f"Calibration ({cal.method}) of {cal.sensor or 'an unnamed sensor'}{serial}: "
        f"T_ref {cal.t_ref_c:g} °C, fitted over {lo:.1f}…{hi:.1f} °C",
        f"  {'axis':<5}{'offset ' + u:>22}{'sensitivity ' + u + '/g':>24}"
        f"{'offset TC mg/°C':>22}{'sens. TC %/°C':>22}{'rms mg':>9}",
    ]
    digits = 0 if u == "LSB" else 5
    for a in cal.axes:
        s = cal.axis(a)
        m = cal.axes[a]
        rms = 1000.0 * m.rms_residual / s.sensitivity if s.sensitivity else math.nan
        lines.append(
            f"  {a:<5}{_pm(s.zero_g_offset, s.zero_g_offset_se, digits):>22}"
            f"{_pm(s.sensitivity, s.sensitivity_se, digits + 1):>24}"
            f"{_pm(s.offset_tc_mg_per_c, s.offset_tc_mg_per_c_se, 4):>22}"
            f"{_pm(s.sensitivity_tc_pct_per_c, s.sensitivity_tc_pct_per_c_se, 5):>22}"
            f"{rms:>9.3f}"
        )
    if cal.not_identified:
        lines.append(f"  not identified: {', '.join(cal.not_identified)}")
    lines += [f"  note: {n}" for n in cal.notes]
    return "\n".join(lines)


def datasheet_section(cal: Calibration) -> tuple[str, Any]:
    """Text of the datasheet comparison and its records (None when there is no datasheet)."""
    if not cal.sensor:
        return "no datasheet comparison: the session names no sensor", None
    try:
        text = cal.datasheet_text()
        table = cal.compare_datasheet().reset_index()
    except datasheets.DatasheetError as exc:
        return f"no datasheet comparison: {exc}", None
    heading = f"Datasheet comparison, {cal.sensor} (layout of the paper's Tables 3/4 and 5/6)"
    return f"{heading}\n{text}", table.to_dict(orient="records")
