"""The report of a diagnosis as tables and text blocks: added effects, held-out error, leftovers.

:func:`effects_table` lists every parameter an added effect brought, per axis, with
its standard error and unit, as :func:`~accelcore.diagnosis.parameters.added_parameters`
read it off the final fit (nothing is recomputed here); :func:`heldout_by_axis` sets
the held-out RMS error of the base model beside the diagnosed model's, per axis and
pooled. :func:`effects_lines`, :func:`heldout_lines` and :func:`unexplained_lines`
render them as aligned terminal text, :func:`value_se_text` writes a value with its
standard error to the precision the error supports. Used by
:class:`~accelcore.diagnosis.result.Diagnosis` and the HTML session report.

May import: foundation, model, and :mod:`~accelcore.diagnosis.steps`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from accelcore.model import AXES
from accelcore.result.calibration import Calibration

from .steps import Step, Structure

__all__ = [
    "EFFECT_COLUMNS",
    "HELDOUT_COLUMNS",
    "effects_lines",
    "effects_table",
    "heldout_by_axis",
    "heldout_lines",
    "not_identified_lines",
    "unexplained_lines",
    "value_se_text",
]

EFFECT_COLUMNS = ("step", "effect", "axis", "variant", "parameter", "value", "se", "unit")
"""Columns of :func:`effects_table`."""

HELDOUT_COLUMNS = ("axis", "base_mg", "diagnosed_mg", "ratio", "cut_pct")
"""Columns of :func:`heldout_by_axis`."""

POOLED = "pooled"
"""Row of :func:`heldout_by_axis` with the RMS over the three axes."""


def _axis_order(axis: str) -> int:
    return AXES.index(axis) if axis in AXES else len(AXES)


def _float(value: Any) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def effects_table(steps: Sequence[Step]) -> pd.DataFrame:
    """One row per parameter of every added effect, per axis.

    Parameters
    ----------
    steps : sequence of Step
        The diagnosis' steps; step 0 (the base model) adds nothing.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`EFFECT_COLUMNS`: ``step`` (int), ``effect`` (family name),
        ``axis``, ``variant`` (of that axis, e.g. ``order 2``), ``parameter``
        (its name), ``value``, ``se`` (standard error; NaN when the parameter was
        held fixed) and ``unit``, as fitted at the step that added the effect
        (the final coefficients are in the diagnosed calibration; a later step
        may refine them). An axis the effect was added to that has no
        readable parameter gets one row with an empty ``parameter`` and NaN
        value. Empty (with these columns) when nothing was added.
    """
    rows: list[dict[str, Any]] = []
    for s in steps[1:]:
        by_axis: dict[str, list[dict[str, Any]]] = {a: [] for a in s.axes}
        for p in s.parameters:
            by_axis.setdefault(str(p.get("axis", "")), []).append(p)
        for a in sorted(by_axis, key=_axis_order):
            base = {"step": s.index, "effect": s.effect, "axis": a, "variant": s.variant.get(a, "")}
            params = by_axis[a] or [{}]
            for p in params:
                rows.append(
                    {
                        **base,
                        "parameter": str(p.get("name", "")),
                        "value": _float(p.get("value")),
                        "se": _float(p.get("se")),
                        "unit": str(p.get("unit", "")),
                    }
                )
    df = pd.DataFrame(rows, columns=list(EFFECT_COLUMNS))
    df["step"] = df["step"].astype(np.int64)
    for c in ("value", "se"):
        df[c] = df[c].astype(np.float64)
    return df


def heldout_by_axis(steps: Sequence[Step]) -> pd.DataFrame:
    """Held-out RMS error of the base and the diagnosed model, per axis and pooled.

    Parameters
    ----------
    steps : sequence of Step
        The diagnosis' steps: the first is the base model, the last the diagnosed one.

    Returns
    -------
    pandas.DataFrame
        Rows ``x``, ``y``, ``z`` and ``pooled`` (RMS over the three axes), columns
        :data:`HELDOUT_COLUMNS`: ``base_mg``, ``diagnosed_mg`` (held-out RMS error
        on the diagnosis' folds, mg), ``ratio`` (diagnosed / base) and ``cut_pct``
        (``100 (1 - ratio)``; negative when the error grew). ``ratio`` is NaN
        when the base error is 0.
    """
    first, last = steps[0], steps[-1]
    rows = []
    pairs = [(a, first.rms_out_axis_mg[a], last.rms_out_axis_mg[a]) for a in AXES]
    pairs.append((POOLED, first.rms_out_mg, last.rms_out_mg))
    for axis, before, after in pairs:
        ratio = after / before if before > 0 else math.nan
        rows.append(
            {
                "axis": axis,
                "base_mg": float(before),
                "diagnosed_mg": float(after),
                "ratio": ratio,
                "cut_pct": 100.0 * (1.0 - ratio) if math.isfinite(ratio) else math.nan,
            }
        )
    return pd.DataFrame(rows, columns=list(HELDOUT_COLUMNS))


def value_se_text(value: float, se: float) -> tuple[str, str]:
    """Return ``value`` and ``se`` as text, the value rounded where the error's second digit is.

    Parameters
    ----------
    value, se : float
        A parameter and its standard error (NaN or 0 when there is none).

    Returns
    -------
    tuple of str
        E.g. ``("0.60011", "0.00038")`` for 0.6001102 ± 0.0003827; without a
        usable error, the value to 4 significant digits and an empty error.
    """
    if not math.isfinite(value):
        return "–", ""
    if not (math.isfinite(se) and se > 0):
        return f"{value:.4g}", ""
    decimals = 1 - math.floor(math.log10(se))
    if decimals < 0:  # an error of 100 or more: whole numbers
        return f"{value:.0f}", f"{se:.0f}"
    if decimals <= 8:
        return f"{value:.{decimals}f}", f"{se:.{decimals}f}"
    # Tiny figures: scientific, the value to the error's second digit.
    magnitude = math.floor(math.log10(abs(value))) if value != 0 else 1 - decimals
    return f"{value:.{max(decimals + magnitude, 1)}e}", f"{se:.1e}"


def _aligned(rows: Sequence[Sequence[str]], right: Sequence[int], indent: str) -> list[str]:
    if not rows:
        return []
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = []
    for r in rows:
        cells = [
            c.rjust(w) if i in right else c.ljust(w)
            for i, (c, w) in enumerate(zip(r, widths, strict=True))
        ]
        lines.append((indent + "  ".join(cells)).rstrip())
    return lines


def effects_lines(table: pd.DataFrame, events: bool = False) -> list[str]:
    """Render the "Added effects" block: per effect, one aligned line per axis and parameter.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`effects_table`.
    events : bool
        Session events were fitted beside the model (with no effect added, the
        calibration is then not the base's: its terms were refitted beside them).

    Returns
    -------
    list of str
        A heading, then per effect its step and name, then ``axis  variant
        parameter  value ± se unit`` (the variant only on an axis' first line);
        one line saying no effect was added when the table is empty.
    """
    if table.empty and events:
        return [
            "Added effects: none (no effect added; the base model's terms, refitted beside "
            "the session events below, which change their values)"
        ]
    if table.empty:
        return ["Added effects: none (no effect added; the base model is kept)"]
    lines = ["Added effects (parameter = value ± standard error):"]
    for (step, effect), part in table.groupby(["step", "effect"], sort=False):
        lines.append(f"  {step}. {effect} (axes {', '.join(dict.fromkeys(part['axis']))})")
        rows = []
        prev_axis = None
        for r in part.to_dict(orient="records"):
            v, e = value_se_text(r["value"], r["se"])
            rows.append(
                [
                    str(r["axis"]),
                    str(r["variant"]) if r["axis"] != prev_axis else "",
                    str(r["parameter"]),
                    v,
                    f"± {e}" if e else "",
                    str(r["unit"]),
                ]
            )
            prev_axis = r["axis"]
        lines += _aligned(rows, right=(3,), indent="     ")
    return lines


def heldout_lines(table: pd.DataFrame, events: bool = False) -> list[str]:
    """Render the "Held-out error per axis" block: base → diagnosed, ratio and cut.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`heldout_by_axis`.
    events : bool
        Session events were found: both errors are of the output less them.

    Returns
    -------
    list of str
        A heading and one aligned line per axis and ``pooled``.
    """
    less = ", on the output less the session events" if events else ""
    lines = [f"Held-out error per axis (RMS, mg{less}): base → diagnosed"]
    rows = []
    for r in table.to_dict(orient="records"):
        ratio, cut = r["ratio"], r["cut_pct"]
        known = math.isfinite(ratio)
        rows.append(
            [
                str(r["axis"]),
                f"{r['base_mg']:.3f}",
                "→",
                f"{r['diagnosed_mg']:.3f}",
                f"×{ratio:.3f}" if known else "",
                f"(cut {cut:.1f} %)" if known else "",
            ]
        )
    return lines + _aligned(rows, right=(1, 3, 4, 5), indent="  ")


def unexplained_lines(structures: Sequence[Structure]) -> list[str]:
    """Render the "Unexplained" block: structure no added term explains, strongest first.

    Parameters
    ----------
    structures : sequence of Structure
        The significant structures (:attr:`Diagnosis.unexplained`).

    Returns
    -------
    list of str
        A heading and one aligned line per structure (axis, observable, RMS,
        noise, chi-square, p-value, note); one line when there is none.
    """
    if not structures:
        return ["Unexplained: none (no structure left against any observable)"]
    lines = ["Unexplained (structure left in the residual, no added term explains it):"]
    rows = [
        [
            f"{s.axis} vs {s.observable}",
            f"{s.structure_rms_mg:.3f} mg rms",
            f"(noise {s.noise_mg:.3f} mg, chi2 {s.chi2:.0f}/{s.dof}, p {s.p_value:.1e})",
            s.note,
        ]
        for s in structures
    ]
    return lines + _aligned(rows, right=(1,), indent="  ")


def not_identified_lines(calibration: Calibration) -> list[str]:
    """Render the "Not identified" block: what the session's orientations cannot tell.

    A sensitivity held at nominal, an offset identified only with its sensitivity:
    every held-out error of the diagnosis is on this session's orientations, where
    they do not show; on another orientation they do. None when everything is
    identified.
    """
    if not calibration.not_identified:
        return []
    told = [
        n for n in calibration.notes if "not identified" in n or "identified only combined" in n
    ]
    return [
        "",
        "Not identified by this session's orientations (held at nominal or combined; "
        "no held-out error above measures them):",
        "  " + ", ".join(calibration.not_identified),
        *(f"  {n}" for n in told),
    ]
