"""The figures of one step of the diagnosis and of one leftover structure.

:class:`Step` (a step of the greedy selection: what was added, where, and the
in-sample and held-out errors after it) and :class:`Structure` (what the final
residual still shows against one observable) are plain data: the selection makes
them, :mod:`~accelcore.diagnosis.tables` renders them, and
:class:`~accelcore.diagnosis.result.Diagnosis` holds them.

May import: foundation, model.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from accelcore.model import Term

__all__ = ["Step", "Structure"]


@dataclass(frozen=True)
class Structure:
    """Structure of the final residual against one observable (binned means vs noise).

    Attributes
    ----------
    axis : str
    observable : str
        ``temperature_c``, ``dtemp_dt_c_per_min``, ``elapsed_s`` (binned within
        each run) or an extra column.
    chi2, dof, p_value : float, int, float
        Chi-square of the binned means against their white-noise standard errors.
    structure_rms_mg : float
        Estimated RMS of the binned structure, mg (excess over noise).
    noise_mg : float
        White-noise level of the residual (first differences), mg.
    significant : bool
        ``p_value < alpha_structure`` and ``structure_rms_mg >= min_structure_mg``.
    note : str
        E.g. the period of a periodic structure in time.
    """

    axis: str
    observable: str
    chi2: float
    dof: int
    p_value: float
    structure_rms_mg: float
    noise_mg: float
    significant: bool
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form for JSON."""
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class Step:
    """One step of the greedy selection (step 0: the base model).

    Attributes
    ----------
    index : int
    effect : str
        Family added (``base`` for step 0).
    axes : tuple of str
        Axes it was added to.
    variant : dict of str to str
        Per axis: the chosen variant (``order 3``, ``tau 118 s``, ...).
    parameters : list of dict
        Each added parameter: ``axis``, ``name``, ``value``, ``se``, ``unit``.
    rms_in_mg, max_in_mg, rms_out_mg, max_out_mg : float
        In-sample and held-out error of the model after this step, all axes pooled.
    rms_out_axis_mg, rms_in_axis_mg, max_out_axis_mg : dict of str to float
        The same per axis.
    rms_out_fold_axis_mg : dict of str to dict of str to float
        Held-out RMS per fold (name) and axis.
    cut : dict of str to float
        Relative cut of held-out RMS per axis it was added to.
    p_value : dict of str to float
        Of the paired test per axis it was added to.
    terms : dict of str to list of Term
        The model of every axis after this step.
    """

    index: int
    effect: str
    axes: tuple[str, ...]
    variant: dict[str, str]
    parameters: list[dict[str, Any]]
    rms_in_mg: float
    max_in_mg: float
    rms_out_mg: float
    max_out_mg: float
    rms_in_axis_mg: dict[str, float]
    rms_out_axis_mg: dict[str, float]
    max_out_axis_mg: dict[str, float]
    rms_out_fold_axis_mg: dict[str, dict[str, float]]
    cut: dict[str, float]
    p_value: dict[str, float]
    terms: dict[str, tuple[Term, ...]]

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form for JSON."""
        d = dataclasses.asdict(self)
        d["terms"] = {a: [t.to_dict() for t in ts] for a, ts in self.terms.items()}
        d["axes"] = list(self.axes)
        return d
