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

import numpy as np
from numpy.typing import NDArray

from accelcore import core

__all__ = [
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


def accept(
    current_sse: FloatArray, candidate_sse: FloatArray, *, min_improvement: float, alpha: float
) -> core.Acceptance:
    """Judge a candidate by the diagnosis' rule (:class:`accelcore.core.AcceptanceRule`).

    The held-out RMS error falls by at least ``min_improvement`` and the paired one-sided
    test over blocks gives ``p < alpha``: the t-tests of the per-block change of held-out
    squared error and of its log ratio, Bonferroni-combined.
    """
    rule = core.AcceptanceRule(min_improvement=min_improvement, alpha=alpha)
    return rule.judge(current_sse, candidate_sse)


def corrected_p(p: float, n_tests: int) -> float:
    """Bonferroni-corrected p-value of the smallest of ``n_tests`` p-values, ``min(1, p n)``."""
    return float(core.bonferroni(np.array([p]), n_tests=n_tests)[0])


def pooled_rms(values: Mapping[str, float]) -> float:
    """RMS of per-axis RMS values: ``sqrt(mean(v²))``."""
    return math.sqrt(sum(v * v for v in values.values()) / len(values))


def wrms(r: FloatArray, w: FloatArray) -> float:
    """Weighted RMS ``sqrt(sum w r² / sum w)``; NaN when the weights sum to zero."""
    return math.sqrt(float((w * r * r).sum() / w.sum())) if w.sum() > 0 else math.nan
