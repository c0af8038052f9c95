"""A calibration against its datasheet (the paper's Tables 3/4, 5/6); nominal sensitivity."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd

from accelcore import datasheets
from accelcore.constants import STANDARD_GRAVITY, UNITS_PER_G
from accelcore.errors import ParameterError
from accelcore.result.summary import AxisSummary

__all__ = ["compare", "nominal_sensitivity", "text"]


def compare(
    summaries: Mapping[str, AxisSummary],
    units: str,
    not_identified: Sequence[str],
    sensor: str | None,
    sheet: Any = None,
) -> pd.DataFrame:
    """Compare with the datasheet, laid out like the paper's Tables 3/4 and 5/6.

    Parameters
    ----------
    summaries : mapping of str to AxisSummary
        Each axis' offset, sensitivity and temperature coefficients at T_ref.
    units : str
        Session units of the output.
    not_identified : sequence of str
        ``axis:parameter`` names the fit could not identify (their value is not compared).
    sensor : str or None
        The calibrated sensor's name (the default datasheet).
    sheet : accelcore.datasheets.Datasheet or str, optional
        Default: ``sensor``'s datasheet.

    Returns
    -------
    pandas.DataFrame
        Index (table, parameter, axis); columns ``min``, ``typ``, ``max``
        (datasheet, NaN where it gives none), ``measured``, ``measured_se``,
        ``unit`` and ``in_spec`` (True/False, or None without limits).
        ``table`` is ``"at T_ref"`` (Tables 3/4) or ``"temperature coefficients"``
        (Tables 5/6).
    """
    if sheet is None or isinstance(sheet, str):
        name = sheet or sensor
        if not name:
            raise ParameterError("no sensor named: pass sheet= or set sensor in session.toml")
        sheet = datasheets.load(name)
    u = units
    rows = []
    for a, s in summaries.items():
        unknown = {n.split(":", 1)[1] for n in not_identified if n.startswith(f"{a}:")}
        needs = {
            "sensitivity": {"sensitivity"},
            "zero_g_offset": {"offset"},
            "output_at_plus_1g": {"offset", "sensitivity"},
            "output_at_minus_1g": {"offset", "sensitivity"},
            "sensitivity_tc_pct_per_c": {"sensitivity", "sensitivity_tc"},
            "offset_tc_mg_per_c": {"offset_tc"},
        }
        params: list[tuple[str, str, str, float, float, str]] = [
            (
                "at T_ref",
                "sensitivity",
                "sensitivity",
                s.sensitivity,
                s.sensitivity_se,
                f"{u}/g",
            ),
            (
                "at T_ref",
                "zero_g_offset",
                "zero_g_offset",
                s.zero_g_offset,
                s.zero_g_offset_se,
                u,
            ),
            (
                "at T_ref",
                "+1 g",
                "output_at_plus_1g",
                s.zero_g_offset + s.sensitivity,
                math.hypot(s.zero_g_offset_se, s.sensitivity_se),
                u,
            ),
            (
                "at T_ref",
                "-1 g",
                "output_at_minus_1g",
                s.zero_g_offset - s.sensitivity,
                math.hypot(s.zero_g_offset_se, s.sensitivity_se),
                u,
            ),
            (
                "temperature coefficients",
                "sensitivity_tc",
                "sensitivity_tc_pct_per_c",
                s.sensitivity_tc_pct_per_c,
                s.sensitivity_tc_pct_per_c_se,
                "%/°C",
            ),
            (
                "temperature coefficients",
                "offset_tc",
                "offset_tc_mg_per_c",
                s.offset_tc_mg_per_c,
                s.offset_tc_mg_per_c_se,
                "mg/°C",
            ),
        ]
        for table, label, parameter, value, se, unit in params:
            lim = sheet.limits(parameter, a)
            if needs[parameter] & unknown:
                value, se = math.nan, math.nan
            in_spec = None if lim is None or math.isnan(value) else lim.contains(value)
            rows.append(
                {
                    "table": table,
                    "parameter": label,
                    "axis": a,
                    "min": _lim(lim, "min"),
                    "typ": _lim(lim, "typ"),
                    "max": _lim(lim, "max"),
                    "measured": value,
                    "measured_se": se,
                    "unit": unit,
                    "in_spec": in_spec,
                }
            )
    return pd.DataFrame(rows).set_index(["table", "parameter", "axis"])


def text(comparison: pd.DataFrame) -> str:
    """Plain-text rendering of :func:`compare`'s table for the terminal."""
    df = comparison.reset_index()
    out = []
    for table, part in df.groupby("table", sort=False):
        out.append(f"{table}:")
        lines = [
            f"  {'parameter':<15}{'axis':<5}{'min':>10}{'typ':>10}{'max':>10}"
            f"{'measured':>12}{'± se':>10}  {'unit':<6}{'spec':<5}"
        ]
        for r in part.to_dict(orient="records"):
            spec = {True: "ok", False: "OUT"}.get(r["in_spec"], "-")
            lines.append(
                f"  {r['parameter']:<15}{r['axis']:<5}{_fmt(r['min']):>10}"
                f"{_fmt(r['typ']):>10}{_fmt(r['max']):>10}{_fmt(r['measured'], 5):>12}"
                f"{_fmt(r['measured_se'], 2):>10}  {r['unit']:<6}{spec:<5}"
            )
        out += lines
    return "\n".join(out)


def _lim(lim: Any, which: str) -> float:
    v = None if lim is None else getattr(lim, which)
    return math.nan if v is None else float(v)


def _fmt(v: object, digits: int = 4) -> str:
    if not isinstance(v, (int, float)) or math.isnan(v):
        return ""
    return f"{v:.{digits}g}"


def nominal_sensitivity(
    units: str, sensor: str | None, gravity_m_s2: float = STANDARD_GRAVITY
) -> tuple[float, float, float] | None:
    """Nominal sensitivity per axis in ``units``/g, or None when unknown.

    ``g`` gives 1, ``mg`` 1000, ``m/s2`` the local gravity ``gravity_m_s2``
    (default standard gravity, 9.80665); ``V`` and ``LSB`` take the datasheet
    typical of ``sensor``.
    """
    if units in UNITS_PER_G:
        return (UNITS_PER_G[units],) * 3
    if units == "m/s2":
        return (gravity_m_s2,) * 3
    if sensor:
        try:
            sheet = datasheets.load(sensor)
        except (KeyError, ValueError):
            return None
        typ = sheet.typical("sensitivity")
        if all(t is not None for t in typ):
            return (float(typ[0]), float(typ[1]), float(typ[2]))  # type: ignore[arg-type]
    return None
