"""Reference statistics that accept or reject a term (twin of ``accelcore-core/src/stats.rs``).

The same specification as the Rust core, written plainly: the special functions are
Numerical Recipes' series and continued fractions (3rd ed., §6.2 and §6.4) over
:func:`math.lgamma`, with none of the core's regrouping for large arguments. They are
accurate to about 1e-14 for moderate degrees of freedom; with ``a`` degrees of freedom
(halved) the factor ``exp(a ln x - x - lgamma(a))`` cancels terms of size ``a ln a``,
so the relative error grows to about ``a ln(a) · 1e-16``, which the tests allow for.

The arguments of the incomplete beta function are passed as ``x`` and ``y = 1 - x``
computed each from the statistic, so that ``1 - x`` does not cancel near ``x = 1``.

Conventions, as in the core: NaN in, NaN out; a chi-square with ``dof <= 0`` gives
p = 1 (nothing tested); a t or F with ``dof <= 0`` or an infinite ``dof`` gives NaN.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
from numpy.typing import ArrayLike

from accelcore.reference._common import FloatArray, vector
from accelcore.reference.errors import ParameterError, ShapeError

__all__ = [
    "Acceptance",
    "AcceptanceRule",
    "PairedTest",
    "bonferroni",
    "chi2_sf",
    "f_sf",
    "holm",
    "paired_test",
    "sign_test",
    "t_sf",
]

#: Relative step at which a series or a continued fraction stops.
_EPS = 1e-16
#: Guard of the modified Lentz method against a zero denominator.
_TINY = 1e-300
#: Most terms of a series or continued fraction (they need O(sqrt(a))).
_MAX_TERMS = 100_000


def _gamma_q(a: float, x: float) -> float:
    """Regularised upper incomplete gamma ``Q(a, x)``, ``a > 0``, ``0 < x < inf``."""
    front = math.exp(-x + a * math.log(x) - math.lgamma(a))
    if x < a + 1.0:
        ap, total, delta = a, 1.0 / a, 1.0 / a
        for _ in range(_MAX_TERMS):
            ap += 1.0
            delta *= x / ap
            total += delta
            if abs(delta) < abs(total) * _EPS:
                break
        return max(0.0, 1.0 - total * front)
    b = x + 1.0 - a
    c = 1.0 / _TINY
    d = 1.0 / b
    h = d
    for i in range(1, _MAX_TERMS):
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        d = _TINY if abs(d) < _TINY else d
        c = b + an / c
        c = _TINY if abs(c) < _TINY else c
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < _EPS:
            break
    return min(1.0, front * h)


def _betainc(a: float, b: float, x: float, y: float) -> float:
    """Regularised incomplete beta ``I_x(a, b)``, ``a, b > 0``, ``x + y = 1``, both in [0, 1].

    ``y`` is given beside ``x``: a caller near ``x = 1`` knows ``y`` to more digits than
    ``1 - x`` would keep.
    """
    if x <= 0.0:
        return 0.0
    if y <= 0.0:
        return 1.0
    if x > (a + 1.0) / (a + b + 2.0):
        return 1.0 - _betainc(b, a, y, x)
    lbeta = math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b)
    front = math.exp(lbeta + a * math.log(x) + b * math.log(y))

    def guard(v: float) -> float:
        return _TINY if abs(v) < _TINY else v

    c, d = 1.0, 1.0 / guard(1.0 - (a + b) * x / (a + 1.0))
    h = d
    for m in range(1, _MAX_TERMS):
        m2 = 2 * m
        num = m * (b - m) * x / ((a + m2 - 1) * (a + m2))
        d = 1.0 / guard(1.0 + num * d)
        c = guard(1.0 + num / c)
        h *= d * c
        num = -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1))
        d = 1.0 / guard(1.0 + num * d)
        c = guard(1.0 + num / c)
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < _EPS:
            break
    return min(1.0, front * h / a)


def _ratio_tail(a: float, b: float, r: float) -> float:
    """``I_x(a, b)`` at ``x = 1 / (1 + r)``, ``y = r / (1 + r)``; 0 when ``r`` overflows."""
    if math.isinf(r):
        return 0.0
    return _betainc(a, b, 1.0 / (1.0 + r), r / (1.0 + r))


def _valid_dof(dof: float) -> bool:
    return dof > 0 and math.isfinite(dof)


def chi2_sf(x: float, dof: float) -> float:
    """Survival function of the chi-square distribution, ``P(X > x)``.

    Parameters
    ----------
    x : float
        The statistic.
    dof : float
        Degrees of freedom (need not be an integer).

    Returns
    -------
    float
        ``Q(dof / 2, x / 2)``; 1 for ``x <= 0`` or ``dof <= 0``, 0 for ``x = inf``, NaN
        for a NaN argument or an infinite ``dof``.
    """
    if math.isnan(x) or math.isnan(dof) or math.isinf(dof):
        return math.nan
    if dof <= 0 or x <= 0:
        return 1.0
    if math.isinf(x):
        return 0.0
    return _gamma_q(0.5 * dof, 0.5 * x)


def t_sf(t: float, dof: float) -> float:
    """One-sided upper tail of Student's t, ``P(T > t)``.

    Parameters
    ----------
    t : float
        The statistic.
    dof : float
        Degrees of freedom, > 0 and finite.

    Returns
    -------
    float
        ``I_x(dof/2, 1/2) / 2`` with ``x = dof / (dof + t²)`` for ``t > 0``, 1 minus it
        for ``t < 0``, 0.5 at 0; NaN for a NaN argument or a ``dof`` that is not > 0
        and finite. Where ``t² / dof`` overflows (``|t| > 1e154``) the tail is taken as
        0; the core carries on (the Cauchy tail at ``t = 1e200`` is 3e-201).
    """
    if math.isnan(t) or not _valid_dof(dof):
        return math.nan
    if t == 0:
        return 0.5
    if math.isinf(t):
        return 0.0 if t > 0 else 1.0
    tail = 0.5 * _ratio_tail(0.5 * dof, 0.5, t * t / dof)
    return tail if t > 0 else 1.0 - tail


def f_sf(f: float, dfn: float, dfd: float) -> float:
    """Survival function of Fisher's F, ``P(F > f)``: the p-value of a nested-model F test.

    Parameters
    ----------
    f : float
        The statistic.
    dfn, dfd : float
        Numerator and denominator degrees of freedom, > 0 and finite.

    Returns
    -------
    float
        ``I_x(dfd/2, dfn/2)`` with ``x = dfd / (dfd + dfn f)``; 1 for ``f <= 0``, 0 for
        ``f = inf``; NaN for a NaN argument or degrees of freedom not > 0 and finite.
    """
    if math.isnan(f) or not (_valid_dof(dfn) and _valid_dof(dfd)):
        return math.nan
    if f <= 0:
        return 1.0
    if math.isinf(f):
        return 0.0
    return _ratio_tail(0.5 * dfd, 0.5 * dfn, dfn * f / dfd)


@dataclass(frozen=True)
class PairedTest:
    """Result of :func:`paired_test`: Student's ``t``, one-sided ``p``, ``n`` differences."""

    t: float
    p: float
    n: int


def paired_test(diff: ArrayLike) -> PairedTest:
    """One-sided paired t-test that the mean of ``diff`` is positive.

    Parameters
    ----------
    diff : array_like, shape (n,)
        The differences.

    Returns
    -------
    PairedTest
        ``t = mean / (sd / sqrt(n))`` (sample sd) and ``p = t_sf(t, n - 1)``, computed on
        ``diff`` divided by its largest magnitude (``t`` is the same). Fewer than two
        differences: ``t = nan``, ``p = 1``; a non-finite one: ``t = p = nan``; all equal:
        ``t = inf``, ``p = 0`` when positive, else ``t = 0``, ``p = 1``.

    Raises
    ------
    ShapeError
        ``diff`` is not 1-D.
    """
    d = vector(diff, "diff")
    n = int(d.size)
    if n < 2:
        return PairedTest(math.nan, 1.0, n)
    if not np.isfinite(d).all():
        return PairedTest(math.nan, math.nan, n)
    if (d == d[0]).all():
        return PairedTest(math.inf, 0.0, n) if d[0] > 0 else PairedTest(0.0, 1.0, n)
    z = d / np.abs(d).max()
    t = float(z.mean()) / (float(z.std(ddof=1)) / math.sqrt(n))
    return PairedTest(t, t_sf(t, n - 1), n)


def _p_values(p: ArrayLike, n_tests: int | None) -> tuple[FloatArray, int]:
    values = vector(p, "p")
    if ((values < 0) | (values > 1)).any():
        raise ParameterError("p-values must lie in [0, 1]")
    m = values.size if n_tests is None else int(n_tests)
    if m < values.size:
        raise ParameterError(f"{m} tests cannot hold {values.size} p-values")
    return values, m


def bonferroni(p: ArrayLike, n_tests: int | None = None) -> FloatArray:
    """Bonferroni-adjusted p-values ``min(1, m p)``.

    Parameters
    ----------
    p : array_like, shape (k,)
        P-values in [0, 1] (NaN stays NaN).
    n_tests : int, optional
        Number of tests ``m >= k`` (the others' p-values were not computed); default ``k``.

    Returns
    -------
    ndarray of float64, shape (k,)
        The adjusted p-values.

    Raises
    ------
    ParameterError
        A p-value outside [0, 1], or ``n_tests < k``.
    """
    values, m = _p_values(p, n_tests)
    return np.minimum(values * float(m), 1.0)


def holm(p: ArrayLike, n_tests: int | None = None) -> FloatArray:
    """Holm's step-down adjusted p-values, in the order given.

    Parameters
    ----------
    p : array_like, shape (k,)
        P-values in [0, 1]; a NaN stays NaN and ranks after every other.
    n_tests : int, optional
        Number of tests ``m >= k`` (the untested ones rank last); default ``k``.

    Returns
    -------
    ndarray of float64, shape (k,)
        With the p-values sorted increasing, the ``j``-th (from 0) becomes the running
        maximum of ``min(1, (m - j) p_(j))``.

    Raises
    ------
    ParameterError
        A p-value outside [0, 1], or ``n_tests < k``.
    """
    values, m = _p_values(p, n_tests)
    out = np.full(values.size, np.nan)
    running = 0.0
    for rank, i in enumerate(np.argsort(values, kind="stable")):
        if math.isnan(values[i]):
            break
        running = max(running, min(1.0, (m - rank) * float(values[i])))
        out[i] = running
    return out


@dataclass(frozen=True)
class Acceptance:
    """The verdict of an :class:`AcceptanceRule`.

    ``accepted``, ``cut``, ``t`` (of the test of the differences), ``p`` (the rule's),
    ``p_sum``, ``p_log`` and ``p_sign`` (the three tests it combines), ``n``.
    """

    accepted: bool
    cut: float
    t: float
    p: float
    p_sum: float
    p_log: float
    p_sign: float
    n: int


def sign_test(diff: ArrayLike) -> float:
    """One-sided exact sign test that the differences are more often positive than not.

    ``P(K >= k)`` for ``K ~ Binomial(n, 1/2)``: ``n`` the non-zero differences, ``k``
    the positive ones, in exact integers (``math.comb``). No difference gives 1, a NaN
    gives NaN.
    """
    d = np.asarray(diff, dtype=np.float64).ravel()
    if np.isnan(d).any():
        return math.nan
    n, k = int(np.count_nonzero(d)), int(np.count_nonzero(d > 0))
    if n == 0:
        return 1.0
    return min(1.0, float(Fraction(sum(math.comb(n, j) for j in range(k, n + 1)), 2**n)))


class AcceptanceRule:
    """When the diagnosis adds a term to an axis.

    The held-out RMS error falls by at least ``min_improvement`` and the paired
    one-sided test over blocks gives ``p < alpha``: the t-test of the per-block change
    of held-out squared error (``p_sum``), the t-test of its log ratio over the
    blocks where both errors are positive (``p_log``) and the exact sign test of the
    change (``p_sign``), combined as ``p = min(1, 3 min(p_sum, p_log, p_sign))`` over
    those that are not NaN (NaN when ``p_sum`` is).

    Parameters
    ----------
    min_improvement : float
        Least fraction of the held-out RMS error cut, in [0, 1).
    alpha : float
        Level of the paired test, in (0, 1).

    Raises
    ------
    ParameterError
        A value out of range.
    """

    def __init__(self, *, min_improvement: float, alpha: float) -> None:
        if not 0 <= min_improvement < 1:
            raise ParameterError(f"min_improvement must be in [0, 1), got {min_improvement}")
        if not 0 < alpha < 1:
            raise ParameterError(f"alpha must be in (0, 1), got {alpha}")
        self.min_improvement = float(min_improvement)
        self.alpha = float(alpha)

    def judge(self, current_sse: ArrayLike, candidate_sse: ArrayLike) -> Acceptance:
        """Judge a candidate from the held-out squared error per block, before and after.

        Parameters
        ----------
        current_sse, candidate_sse : array_like, shape (n_blocks,)
            Held-out squared error of each block under the current model and the candidate.

        Returns
        -------
        Acceptance
            ``cut = 1 - sqrt(sum(candidate) / sum(current))`` (0 when the current sum is not
            positive), the paired test of ``current - candidate``, and
            ``accepted = cut >= min_improvement and p < alpha`` with ``cut`` finite.

        Raises
        ------
        ShapeError
            The two differ in length, or one is not 1-D.
        """
        current = vector(current_sse, "current_sse")
        candidate = vector(candidate_sse, "candidate_sse")
        if current.size != candidate.size:
            raise ShapeError(f"candidate_sse has {candidate.size} blocks, expected {current.size}")
        before, after = float(current.sum()), float(candidate.sum())
        ratio = after / before if before > 0 else 1.0
        cut = 1.0 - math.sqrt(ratio) if ratio >= 0 else math.nan
        test = paired_test(current - candidate)
        both = (current > 0) & (candidate > 0)
        p_log = paired_test(np.log(current[both] / candidate[both])).p
        p_sign = sign_test(current - candidate)
        if math.isnan(test.p):
            p = math.nan
        else:
            p = min(1.0, 3.0 * min(q for q in (test.p, p_log, p_sign) if not math.isnan(q)))
        ok = math.isfinite(cut) and cut >= self.min_improvement and p < self.alpha
        return Acceptance(ok, cut, test.t, p, test.p, p_log, p_sign, test.n)
