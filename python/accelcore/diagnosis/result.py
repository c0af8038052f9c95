"""Results of the diagnosis: :class:`Diagnosis` with its :class:`Step` and :class:`Structure`.

A :class:`Diagnosis` holds the base and the improved calibration, every step of the
greedy selection with its in-sample and held-out figures, every candidate tried, the
structure check and the caveats; it renders itself as tables (:meth:`Diagnosis.report`,
:meth:`Diagnosis.heldout_table`, and the report's :meth:`Diagnosis.effects_table` and
:meth:`Diagnosis.heldout_by_axis`, built in :mod:`~accelcore.diagnosis.tables`), text
and plain data for JSON. It keeps the
cross-validation engine, so any other model can be scored on the same folds
(:meth:`Diagnosis.evaluate`). Plots are outputs: see
:func:`accelcore.outputs.diagnosis_plot.plot_diagnosis`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from accelcore.errors import ParameterError
from accelcore.input.session import Session
from accelcore.model import AXES, Term
from accelcore.result.calibration import Calibration

from .engine import Engine
from .stats import wrms
from .steps import Step, Structure
from .tables import (
    effects_lines,
    effects_table,
    heldout_by_axis,
    heldout_lines,
    not_identified_lines,
    unexplained_lines,
)

__all__ = ["Diagnosis", "Step", "Structure"]


@dataclass(frozen=True)
class Diagnosis:
    """Result of :func:`diagnose`.

    Attributes
    ----------
    base : Calibration
        The model diagnosed.
    calibration : Calibration
        The improved calibration (method ``"diagnosed"``); it is ``base``
        refitted when nothing was added.
    steps : tuple of Step
        Step 0 is the base model, then one per added effect.
    candidates : pandas.DataFrame
        Every family tried at every step, per axis: best variant, held-out
        RMS before and after, cut, p-value, accepted.
    structures : tuple of Structure
        Generic check of the final residual against every observable.
    warnings : tuple of str
        Effects that cannot be told apart on this data, and other caveats.
    folds : tuple of str
        The held-out folds (``scheme`` says how they were formed).
    scheme : str
        ``runs``, ``legs`` or ``blocks``.
    options : dict
        Every option used.
    session_events : tuple of dict
        Things that happened in one run of this session (an output step, a run
        whose gravity was tilted), found on the residual after the selection:
        one row per parameter (``event``, ``axis``, ``parameter``, ``value``,
        ``se``, ``unit``). They were fitted beside the model, so that they do not
        bias it, and are not in :attr:`calibration`.
    """

    base: Calibration
    calibration: Calibration
    steps: tuple[Step, ...]
    candidates: pd.DataFrame
    structures: tuple[Structure, ...]
    warnings: tuple[str, ...]
    folds: tuple[str, ...]
    scheme: str
    options: dict[str, Any]
    session_events: tuple[dict[str, Any], ...] = ()
    _engine: Engine | None = field(default=None, repr=False, compare=False)

    def _data(self) -> Engine:
        if self._engine is None:
            raise ParameterError("this Diagnosis was restored without its data")
        return self._engine

    @property
    def effects(self) -> tuple[str, ...]:
        """Families added, in order."""
        return tuple(s.effect for s in self.steps[1:])

    @property
    def unexplained(self) -> tuple[Structure, ...]:
        """Significant structures, strongest first."""
        sig = [s for s in self.structures if s.significant]
        return tuple(sorted(sig, key=lambda s: -s.structure_rms_mg))

    # -------------------------------------------------------------- tables
    def report(self) -> pd.DataFrame:
        """One row per step: effect, parameters, in-sample and held-out error before and after.

        Returns
        -------
        pandas.DataFrame
            Columns ``step``, ``effect``, ``axes``, ``parameters`` (text with
            standard errors), ``rms_in_before_mg``, ``rms_in_after_mg``,
            ``max_in_before_mg``, ``max_in_after_mg``, ``rms_out_before_mg``,
            ``rms_out_after_mg``, ``max_out_before_mg``, ``max_out_after_mg``
            (all axes pooled), ``cut_pct`` (held-out RMS), then
            ``rms_out_{axis}_before_mg`` / ``_after_mg`` per axis.
        """
        rows = []
        prev = self.steps[0]
        for s in self.steps:
            row: dict[str, Any] = {
                "step": s.index,
                "effect": s.effect,
                "axes": ",".join(s.axes),
                "variant": "; ".join(f"{a}: {v}" for a, v in s.variant.items()),
                "parameters": "; ".join(_fmt_param(p) for p in s.parameters),
                "rms_in_before_mg": prev.rms_in_mg,
                "rms_in_after_mg": s.rms_in_mg,
                "max_in_before_mg": prev.max_in_mg,
                "max_in_after_mg": s.max_in_mg,
                "rms_out_before_mg": prev.rms_out_mg,
                "rms_out_after_mg": s.rms_out_mg,
                "max_out_before_mg": prev.max_out_mg,
                "max_out_after_mg": s.max_out_mg,
                "cut_pct": 100.0 * (1.0 - s.rms_out_mg / prev.rms_out_mg)
                if prev.rms_out_mg > 0
                else 0.0,
            }
            for a in AXES:
                row[f"rms_out_{a}_before_mg"] = prev.rms_out_axis_mg[a]
                row[f"rms_out_{a}_after_mg"] = s.rms_out_axis_mg[a]
            rows.append(row)
            prev = s
        return pd.DataFrame(rows)

    def heldout_table(self) -> pd.DataFrame:
        """Held-out RMS error per step, fold and axis (mg), one row each."""
        rows = []
        for s in self.steps:
            for fold, per_axis in s.rms_out_fold_axis_mg.items():
                for a, v in per_axis.items():
                    rows.append(
                        {"step": s.index, "effect": s.effect, "fold": fold, "axis": a, "rms_mg": v}
                    )
        return pd.DataFrame(rows)

    def effects_table(self) -> pd.DataFrame:
        """Return the added effects: one row per parameter and axis, with se and unit.

        Returns
        -------
        pandas.DataFrame
            Columns ``step``, ``effect``, ``axis``, ``variant``, ``parameter``,
            ``value``, ``se``, ``unit`` (see
            :func:`accelcore.diagnosis.tables.effects_table`); empty when nothing
            was added. Filter it like any frame, e.g.
            ``t[(t.effect == "misalignment") & (t.axis == "z")]``.
        """
        return effects_table(self.steps)

    def heldout_by_axis(self) -> pd.DataFrame:
        """Held-out RMS error per axis and pooled, base model against diagnosed model.

        Returns
        -------
        pandas.DataFrame
            Rows ``x``, ``y``, ``z``, ``pooled``; columns ``axis``, ``base_mg``,
            ``diagnosed_mg``, ``ratio`` (diagnosed / base) and ``cut_pct`` (see
            :func:`accelcore.diagnosis.tables.heldout_by_axis`).
        """
        return heldout_by_axis(self.steps)

    def evaluate(self, terms: Mapping[str, Sequence[Term]]) -> pd.DataFrame:
        """Held-out and in-sample error of any model on this diagnosis' folds.

        Parameters
        ----------
        terms : mapping of axis to sequence of Term
            E.g. the fixed cubic offset model of PX4/ArduPilot.

        Returns
        -------
        pandas.DataFrame
            One row per fold and ``all``, per axis: ``rms_out_mg``, ``max_out_mg``;
            the ``all`` row also ``rms_in_mg``.
        """
        eng = self._data()
        rows = []
        for a in AXES:
            ts = tuple(terms[a])
            r_in, r_out = eng.residuals(a, ts)
            for k, name in enumerate(eng.fold_names):
                sel = eng.sample_fold == k
                if not sel.any():
                    continue
                rows.append(
                    {
                        "fold": name,
                        "axis": a,
                        "rms_out_mg": wrms(r_out[sel], eng.w[sel]),
                        "max_out_mg": float(np.abs(r_out[sel]).max()),
                        "rms_in_mg": math.nan,
                    }
                )
            rows.append(
                {
                    "fold": "all",
                    "axis": a,
                    "rms_out_mg": wrms(r_out, eng.w),
                    "max_out_mg": float(np.abs(r_out).max()),
                    "rms_in_mg": wrms(r_in, eng.w),
                }
            )
        return pd.DataFrame(rows)

    def text(self) -> str:
        """Plain-text rendering: the steps, the added effects, held-out error, leftovers.

        The step table (pooled errors), then the blocks "Added effects" (each
        parameter ± standard error with its unit, per axis), "Held-out error per
        axis" (base → diagnosed), "Unexplained" (structure left against an
        observable) and "Not identified" (what this session's orientations cannot
        tell, which no held-out error here measures), then the warnings.
        """
        rep = self.report()
        # The effect column as wide as its longest name (generic names are long).
        wide = max([22, *(len(str(e)) + 2 for e in rep["effect"])])
        lines = [
            f"Diagnosis: {len(self.steps) - 1} effect(s) added; held-out folds: "
            f"{self.scheme} ({', '.join(self.folds)})",
            f"{'step':>4}  {'effect':<{wide}}{'axes':<7}{'RMS in':>9}{'RMS out':>9}"
            f"{'max out':>9}{'cut':>7}   (mg, all axes; before → after)",
        ]
        for r in rep.to_dict(orient="records"):
            lines.append(
                f"{r['step']:>4}  {r['effect']:<{wide}}{r['axes']:<7}{r['rms_in_after_mg']:>9.3f}"
                f"{r['rms_out_after_mg']:>9.3f}{r['max_out_after_mg']:>9.2f}{r['cut_pct']:>6.1f}%"
            )
        events = bool(self.session_events)
        lines += ["", *effects_lines(self.effects_table(), events)]
        lines += ["", *heldout_lines(self.heldout_by_axis(), events)]
        if self.session_events:
            lines += ["", "Session events (this session only, fitted beside the model, not in it):"]
            lines += [
                f"  {e['event']}: {e['axis']} {e['value']:.3g}"
                + (f" ± {e['se']:.2g}" if math.isfinite(e["se"]) else "")
                + f" {e['unit']}"
                for e in self.session_events
            ]
        lines += ["", *unexplained_lines(self.unexplained)]
        lines += not_identified_lines(self.calibration)
        if self.warnings:
            lines.append("")
            lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.text()

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form for JSON (every step, every figure, warnings, structures).

        Besides ``effects`` (the family names, in order), ``steps``, ``report``,
        ``candidates``, ``structures`` and ``unexplained``: ``added_effects``, the
        rows of :meth:`effects_table` (``value``, ``se`` and ``unit`` per
        parameter; None where a figure is not finite), and ``heldout_rms_mg``,
        ``{"base": {"x", "y", "z", "pooled"}, "diagnosed": {...}, "ratio": {...},
        "cut_pct": {...}}`` from :meth:`heldout_by_axis`.
        """
        return {
            "scheme": self.scheme,
            "folds": list(self.folds),
            "effects": list(self.effects),
            "steps": [s.to_dict() for s in self.steps],
            "report": _records(self.report()),
            "candidates": _records(self.candidates),
            "structures": [s.to_dict() for s in self.structures],
            "unexplained": [s.to_dict() for s in self.unexplained],
            "added_effects": [_finite(r) for r in _records(self.effects_table())],
            "heldout_rms_mg": _heldout_dict(self.heldout_by_axis()),
            "session_events": [_finite(e) for e in self.session_events],
            "warnings": list(self.warnings),
            "options": dict(self.options),
            "calibration": self.calibration.to_dict(),
        }

    # -------------------------------------------------------------- data
    @property
    def session(self) -> Session:
        """The session diagnosed.

        Raises
        ------
        accelcore.ParameterError
            If this Diagnosis was restored without its data.
        """
        return self._data().session

    @property
    def default_observable(self) -> str:
        """The observable most worth plotting the residual against.

        That of the strongest unexplained structure, else the one the last added
        effect depends on (``elapsed_s`` by default).
        """
        un = self.unexplained
        if un:
            return un[0].observable
        last = self.effects[-1] if self.effects else ""
        return {
            "thermal_lag": "dtemp_dt_c_per_min",
            "two_way_lag": "dtemp_dt_c_per_min",
            "drift": "elapsed_s",
            "misalignment": "run_index",
            "nonlinearity": "run_index",
        }.get(last, "elapsed_s")


def _records(df: pd.DataFrame) -> list[dict[str, Any]]:
    """Rows of ``df`` as dicts of Python values, converted column by column.

    (pandas' per-row conversion took most of the time of a diagnosis' JSON.)
    """
    names = [str(k) for k in df.columns]
    columns = [
        [v.item() if isinstance(v, np.generic) else v for v in df[k].tolist()] for k in df.columns
    ]
    return [dict(zip(names, row, strict=True)) for row in zip(*columns, strict=True)]


def _finite(record: Mapping[str, Any]) -> dict[str, Any]:
    """Return the record with non-finite floats as None (strict JSON)."""
    return {
        k: None if isinstance(v, float) and not math.isfinite(v) else v for k, v in record.items()
    }


def _heldout_dict(table: pd.DataFrame) -> dict[str, dict[str, float | None]]:
    """Return ``{"base": {axis: mg}, "diagnosed": ..., "ratio": ..., "cut_pct": ...}``."""
    out: dict[str, dict[str, float | None]] = {}
    for key, col in (
        ("base", "base_mg"),
        ("diagnosed", "diagnosed_mg"),
        ("ratio", "ratio"),
        ("cut_pct", "cut_pct"),
    ):
        out[key] = {
            str(a): float(v) if math.isfinite(v) else None
            for a, v in zip(table["axis"], table[col], strict=True)
        }
    return out


def _fmt_param(p: Mapping[str, Any]) -> str:
    se = p.get("se")
    se_s = f" ± {se:.2g}" if se is not None and math.isfinite(se) and se > 0 else ""
    return f"{p['axis']}:{p['name']} = {p['value']:.4g}{se_s} {p['unit']}".rstrip()
