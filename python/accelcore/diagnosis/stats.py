"""Statistics of the diagnosis: chi-square and Student-t tails, the paired test, weighted RMS.

Plain-Python special functions (regularised incomplete gamma and beta by series and
continued fractions), so the diagnosis needs no SciPy.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["chi2_sf", "paired_test", "t_sf", "wrms"]

FloatArray = NDArray[np.float64]


def _gammainc_upper(a: float, x: float) -> float:
    """Regularised upper incomplete gamma Q(a, x) (Numerical Recipes' series / fraction)."""
    if x <= 0:
        return 1.0
    gln = math.lgamma(a)
    if x < a + 1.0:
        ap, total, delta = a, 1.0 / a, 1.0 / a
        for _ in range(1000):
            ap += 1.0
            delta *= x / ap
            total += delta
            if abs(delta) < abs(total) * 1e-14:
                break
        return max(0.0, 1.0 - total * math.exp(-x + a * math.log(x) - gln))
    b = x + 1.0 - a
    c = 1.0 / 1e-300
    d = 1.0 / b
    h = d
    for i in range(1, 1000):
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        d = 1e-300 if abs(d) < 1e-300 else d
        c = b + an / c
        c = 1e-300 if abs(c) < 1e-300 else c
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < 1e-14:
            break
    return math.exp(-x + a * math.log(x) - gln) * h


def chi2_sf(chi2: float, dof: int) -> float:
    """Survival function of the chi-square distribution."""
    return _gammainc_upper(0.5 * dof, 0.5 * chi2) if dof > 0 else 1.0


def t_sf(t: float, dof: int) -> float:
    """One-sided upper tail of Student's t (regularised incomplete beta via continued fraction)."""
    if dof <= 0:
        return math.nan
    x = dof / (dof + t * t)
    tail = 0.5 * _betainc(0.5 * dof, 0.5, x)
    return tail if t > 0 else 1.0 - tail


def _betainc(a: float, b: float, x: float) -> float:
    if x <= 0:
        return 0.0
    if x >= 1:
        return 1.0
    lbeta = math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b)
    front = math.exp(lbeta + a * math.log(x) + b * math.log(1.0 - x))
    if x > (a + 1.0) / (a + b + 2.0):
        return 1.0 - _betainc(b, a, 1.0 - x)
    # Lentz's continued fraction.
    c, d = 1.0, 1.0 - (a + b) * x / (a + 1.0)
    d = 1.0 / (d if abs(d) > 1e-300 else 1e-300)
    h = d
    for m in range(1, 500):
        m2 = 2 * m
        num = m * (b - m) * x / ((a + m2 - 1) * (a + m2))
        d = 1.0 + num * d
        d = 1.0 / (d if abs(d) > 1e-300 else 1e-300)
        c = 1.0 + num / c
        c = c if abs(c) > 1e-300 else 1e-300
        h *= d * c
        num = -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1))
        d = 1.0 + num * d
        d = 1.0 / (d if abs(d) > 1e-300 else 1e-300)
        c = 1.0 + num / c
        c = c if abs(c) > 1e-300 else 1e-300
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < 1e-14:
            break
    return front * h / a


def paired_test(diff: FloatArray) -> tuple[float, float]:
    """One-sided paired t-test that ``mean(diff) > 0``: (t, p)."""
    n = diff.size
    if n < 2:
        return math.nan, 1.0
    sd = float(np.std(diff, ddof=1))
    mean = float(np.mean(diff))
    if sd == 0.0:
        return (math.inf, 0.0) if mean > 0 else (0.0, 1.0)
    t = mean / (sd / math.sqrt(n))
    return t, t_sf(t, n - 1)


def wrms(r: FloatArray, w: FloatArray) -> float:
    """Weighted RMS ``sqrt(sum w r² / sum w)``; NaN when the weights sum to zero."""
    return math.sqrt(float((w * r * r).sum() / w.sum())) if w.sum() > 0 else math.nan
