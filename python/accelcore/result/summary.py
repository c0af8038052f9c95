"""The seed paper's four parameters of one axis, with their standard errors."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["AxisSummary"]


@dataclass(frozen=True)
class AxisSummary:
    """The seed paper's four parameters of one axis at ``t_ref_c``, with standard errors."""

    axis: str
    zero_g_offset: float
    zero_g_offset_se: float
    sensitivity: float
    sensitivity_se: float
    offset_tc_mg_per_c: float
    offset_tc_mg_per_c_se: float
    sensitivity_tc_pct_per_c: float
    sensitivity_tc_pct_per_c_se: float
