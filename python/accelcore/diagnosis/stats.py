"""Statistics of the diagnosis: chi-square and t tails, the paired test, the acceptance rule.

Also the Bonferroni correction of the event searches and the weighted RMS.

The statistics are the Rust core's (:mod:`accelcore.core`, ``accelcore-core/src/stats.rs``:
special functions accurate to about 1e-13 relative in either tail); this module only
keeps the diagnosis' spelling of them. :mod:`accelcore.reference.stats` is the same
specification written plainly in Python, against which the tests check the core.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from accelcore import core

__all__ = [
    "MIN_SYSTEMATIC_CUT",
    "MIN_SYSTEMATIC_MG",
    "Verdict",
    "accept",
    "chi2_sf",
    "corrected_p",
    "f_sf",
    "paired_test",
    "pooled_rms",
    "t_sf",
    "wrms",
]

FloatArray = NDArray[np.float64]

#: Least cut of the systematic held-out RMS error (above the noise floor) that meets
#: the least improvement instead of the whole error's cut (:func:`accept`).
MIN_SYSTEMATIC_CUT = 0.2

#: Least RMS, mg, that a candidate accepted on its systematic cut must take off it.
MIN_SYSTEMATIC_MG = 0.1


def chi2_sf(chi2: float, dof: int) -> float:
    """Survival function of the chi-square distribution; 1 when ``dof <= 0``."""
    return core.chi2_sf(chi2, dof=dof)


def t_sf(t: float, dof: int) -> float:
    """One-sided upper tail of Student's t; NaN when ``dof <= 0``."""
    return core.t_sf(t, dof=dof)


def f_sf(f: float, dfn: int, dfd: int) -> float:
    """Survival function of Fisher's F distribution with ``(dfn, dfd)`` degrees of freedom."""
    return core.f_sf(f, dfn=dfn, dfd=dfd)


def paired_test(diff: FloatArray) -> tuple[float, float]:
    """One-sided paired t-test that ``mean(diff) > 0``: (t, p).

    Fewer than two differences give ``(nan, 1)``; zero variance gives ``(inf, 0)`` when
    the differences are positive, else ``(0, 1)``; a non-finite difference ``(nan, nan)``.
    """
    test = core.paired_test(diff)
    return test.t, test.p


@dataclass(frozen=True)
class Verdict:
    """The diagnosis' verdict on a candidate (:func:`accept`) and its figures.

    ``cut``, ``t`` and ``p`` are the core's :class:`accelcore.core.Acceptance`;
    ``cut_systematic`` is the cut of the held-out error above its floor (NaN without one).
    """

    accepted: bool
    cut: float
    t: float
    p: float
    cut_systematic: float = math.nan


def accept(
    current_sse: FloatArray,
    candidate_sse: FloatArray,
    *,
    min_improvement: float,
    alpha: float,
    floor: float = 0.0,
    least: float = 0.0,
    min_systematic: float = MIN_SYSTEMATIC_CUT,
) -> Verdict:
    """Judge a candidate by the diagnosis' rule (:class:`accelcore.core.AcceptanceRule`).

    The held-out RMS error falls by at least ``min_improvement`` and the paired one-sided
    test over blocks gives ``p < alpha``: the t-tests of the per-block change of held-out
    squared error and of its log ratio and the exact sign test of that change,
    Bonferroni-combined.

    The least improvement may instead be met on the *systematic* error: the held-out
    squared error above ``floor`` (the noise every model leaves), which is what another
    session of the part sees of a missing effect once its own noise is averaged out. On
    an axis whose noise is large next to its systematic error, a real effect cuts the
    whole error by a few percent and the systematic one by most of it. Such a candidate
    must cut the systematic RMS error by ``min_systematic`` or more (a fifth,
    :data:`MIN_SYSTEMATIC_CUT`: what is
    left beside a disturbance no term can follow is often a tenth of it, a partial fit
    of the disturbance), take ``least`` or more off the squared error (an effect too
    small to matter is not added however significant), and pass the same test.
    """
    v = core.AcceptanceRule(min_improvement=min_improvement, alpha=alpha).judge(
        current_sse, candidate_sse
    )
    before, after = float(np.sum(current_sse)), float(np.sum(candidate_sse))
    systematic = math.nan
    if floor > 0.0 and before > floor:
        systematic = 1.0 - math.sqrt(max(after - floor, 0.0) / (before - floor))
    accepted = bool(v.accepted) or (
        math.isfinite(v.cut)
        and v.cut > 0.0
        and v.p < alpha
        and systematic >= max(min_systematic, min_improvement)
        and before - after >= least
    )
    return Verdict(accepted, float(v.cut), float(v.t), float(v.p), systematic)


def corrected_p(p: float, n_tests: int) -> float:
    """Bonferroni-corrected p-value of the smallest of ``n_tests`` p-values, ``min(1, p n)``."""
    return float(core.bonferroni(np.array([p]), n_tests=n_tests)[0])


def pooled_rms(values: Mapping[str, float]) -> float:
    """RMS of per-axis RMS values: ``sqrt(mean(v²))``."""
    return math.sqrt(sum(v * v for v in values.values()) / len(values))


def wrms(r: FloatArray, w: FloatArray) -> float:
    """Weighted RMS ``sqrt(sum w r² / sum w)``; NaN when the weights sum to zero."""
    return math.sqrt(float((w * r * r).sum() / w.sum())) if w.sum() > 0 else math.nan
