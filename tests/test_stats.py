"""The statistics that accept or reject a term: the Rust core against its plain twin.

``accelcore.core`` (``accelcore-core/src/stats.rs``) and ``accelcore.reference.stats``
write the same specification independently: the core regroups its special functions
for large arguments, the reference is Numerical Recipes over :func:`math.lgamma`. Both
are checked against values known without either: closed forms through
:func:`math.erfc`, :func:`math.atan` and :func:`math.exp`, and the critical values of
printed tables. The diagnosis' spelling of them (:mod:`accelcore.diagnosis.stats`) is
the core's.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from accelcore import core, reference
from accelcore.diagnosis import stats as diagnosis_stats
from accelcore.errors import ParameterError, ShapeError
from strategies import FloatArray, seeds

EPS = float(np.finfo(np.float64).eps)

#: Below this a tail is near the subnormal range, where a double keeps fewer digits.
SMALLEST = 1e-290

#: The core's relative accuracy (its Rust tests pin it to 40-digit values): its factors
#: are computed from terms no larger than the final exponent (at most ~745 where the
#: result is a normal double), each good to a few ulp.
CORE_RTOL = 2e-13


def reference_rtol(a: float, b: float = 0.0) -> float:
    """Relative accuracy of the plain reference at half degrees of freedom ``a``, ``b``.

    Its factor ``exp(a ln x - x - lgamma(a))`` (or ``exp(a ln x + b ln y - ln B(a, b))``)
    adds terms as large as ``(a + b) ln(a + b)``, each good to an ulp, and its continued
    fraction starts from ``1 - (a + b) x / (a + 1)``, which keeps about ``1 / (a + b)``
    of its digits near the switch to the mirrored side: about ``ε (a + b) ln(a + b)`` in
    all, and 1e-12 for the rounding of loops that run up to ~1e3 terms.
    """
    s = a + b + 2.0
    return 1e-12 + 16.0 * EPS * s * math.log(s)


def assert_tail_close(got: float, want: float, rtol: float, what: str) -> None:
    """Relative agreement where ``want`` is a normal double; both negligible below it."""
    if math.isnan(want):
        assert math.isnan(got), what
    elif want < SMALLEST:
        assert got < 2 * SMALLEST, f"{what}: {got} where {want} was expected"
    else:
        assert got == pytest.approx(want, rel=rtol, abs=0.0), what


# ----------------------------------------------------------------------- strategies

#: Degrees of freedom: small integers (the diagnosis' own) and 0.5 to 1e4 over decades.
dofs = st.one_of(
    st.integers(1, 60).map(float),
    st.floats(-0.3, 4.0).map(lambda e: 10.0**e),
)


@st.composite
def chi2_cases(draw: st.DrawFn) -> tuple[float, float]:
    """(x, dof): x over decades, or around the mean from 6 sd below to 40 sd above."""
    dof = draw(dofs)
    if draw(st.booleans()):
        x = 10.0 ** draw(st.floats(-8.0, 3.3))
    else:
        z = draw(st.floats(-6.0, 40.0))
        x = max(dof + z * math.sqrt(2.0 * dof), 1e-3 * dof)
    return x, dof


signed_t = st.tuples(st.sampled_from([-1.0, 1.0]), st.floats(-3.0, 4.0)).map(
    lambda s: s[0] * 10.0 ** s[1]
)


# ----------------------------------------------------------------------- tails


@given(chi2_cases())
def test_chi2_sf_matches_reference(case: tuple[float, float]) -> None:
    x, dof = case
    want = reference.chi2_sf(x, dof)
    assert_tail_close(core.chi2_sf(x, dof=dof), want, reference_rtol(0.5 * dof), f"{case}")


@given(t=signed_t, dof=dofs)
def test_t_sf_matches_reference(t: float, dof: float) -> None:
    want = reference.t_sf(t, dof)
    assert_tail_close(core.t_sf(t, dof=dof), want, reference_rtol(0.5 * dof, 0.5), f"{t}, {dof}")


@given(f=st.floats(-3.0, 3.0).map(lambda e: 10.0**e), dfn=dofs, dfd=dofs)
def test_f_sf_matches_reference(f: float, dfn: float, dfd: float) -> None:
    want = reference.f_sf(f, dfn, dfd)
    got = core.f_sf(f, dfn=dfn, dfd=dfd)
    assert_tail_close(got, want, reference_rtol(0.5 * dfd, 0.5 * dfn), f"{f}, {dfn}, {dfd}")


@given(t=st.floats(0.0, 50.0), dof=dofs)
def test_t_tails_add_up_to_one(t: float, dof: float) -> None:
    # Each side is computed without cancellation; their sum rounds once or twice.
    assert core.t_sf(t, dof=dof) + core.t_sf(-t, dof=dof) == pytest.approx(1.0, abs=2 * EPS)


# ----------------------------------------------------------------------- known values

#: The Python twins of the three tails, and the core's, with one calling convention.
TailFunctions = tuple[
    Callable[[float, float], float],
    Callable[[float, float], float],
    Callable[[float, float, float], float],
]
IMPLEMENTATIONS: dict[str, TailFunctions] = {
    "core": (
        lambda x, dof: core.chi2_sf(x, dof=dof),
        lambda t, dof: core.t_sf(t, dof=dof),
        lambda f, dfn, dfd: core.f_sf(f, dfn=dfn, dfd=dfd),
    ),
    "reference": (reference.chi2_sf, reference.t_sf, reference.f_sf),
}


def _chi2_closed_form(x: float, dof: int) -> float:
    """``P(X > x)`` for an integer ``dof``: erfc and a finite sum of positive terms."""
    h = 0.5 * x
    if dof % 2 == 0:
        return math.exp(-h) * sum(h**j / math.factorial(j) for j in range(dof // 2))
    tail = math.erfc(math.sqrt(h))
    return tail + math.exp(-h) * sum(
        math.pow(h, j - 0.5) / math.gamma(j + 0.5) for j in range(1, dof // 2 + 1)
    )


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
@pytest.mark.parametrize("dof", [1, 2, 3, 4, 7, 10, 25])
@pytest.mark.parametrize("x", [1e-4, 0.5, 3.0, 11.0, 40.0, 150.0])
def test_chi2_sf_closed_forms(impl: str, dof: int, x: float) -> None:
    chi2_sf = IMPLEMENTATIONS[impl][0]
    # erfc, exp and at most 13 positive terms: the closed form is good to ~1e-14.
    assert chi2_sf(x, dof) == pytest.approx(_chi2_closed_form(x, dof), rel=1e-13)


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
@pytest.mark.parametrize("t", [0.01, 0.4, 1.0, 2.2, 3.0])
def test_t_sf_closed_forms(impl: str, t: float) -> None:
    t_sf = IMPLEMENTATIONS[impl][1]
    root2 = math.sqrt(2.0 + t * t)
    theta = math.atan(t / math.sqrt(3.0))
    s = t / math.sqrt(4.0 + t * t)
    closed = {
        1: math.atan(1.0 / t) / math.pi,  # Cauchy
        2: 1.0 / ((root2 + t) * root2),  # (1 - t / sqrt(2 + t²)) / 2 without cancelling
        3: 0.5 - (theta + math.sin(theta) * math.cos(theta)) / math.pi,
        4: 0.5 - 0.5 * s * (1.5 - 0.5 * s * s),
    }
    for dof, want in closed.items():
        # dof 3 and 4 subtract from 0.5: good to ~1e-14 for t <= 3.
        assert t_sf(t, dof) == pytest.approx(want, rel=1e-13), dof
        assert t_sf(-t, dof) == pytest.approx(1.0 - want, rel=1e-13), dof


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
@pytest.mark.parametrize("f", [0.01, 0.7, 2.0, 9.0, 300.0])
@pytest.mark.parametrize("other", [1.0, 3.0, 12.0, 80.0])
def test_f_sf_closed_forms(impl: str, f: float, other: float) -> None:
    f_sf = IMPLEMENTATIONS[impl][2]
    # dfn = 2: (1 + 2 f / dfd)^(-dfd / 2); dfd = 2: 1 - (dfn f / (2 + dfn f))^(dfn / 2).
    two_over = math.exp(-0.5 * other * math.log1p(2.0 * f / other))
    two_under = -math.expm1(-0.5 * other * math.log1p(2.0 / (other * f)))
    assert f_sf(f, 2.0, other) == pytest.approx(two_over, rel=1e-13)
    assert f_sf(f, other, 2.0) == pytest.approx(two_under, rel=1e-13)


#: Critical values of printed tables, each with the relative change of the tail that
#: half a unit of its last printed digit makes (the tail's density times that half unit,
#: over p; rounded up).
TABLES = [
    ("chi2", 3.8415, (1.0,), 0.05, 3.0e-5),
    ("chi2", 5.9915, (2.0,), 0.05, 2.5e-5),
    ("chi2", 18.307, (10.0,), 0.05, 1.6e-4),
    ("chi2", 6.6349, (1.0,), 0.01, 2.9e-5),
    ("chi2", 37.566, (20.0,), 0.01, 1.4e-4),
    ("t", 6.314, (1.0,), 0.05, 7.8e-5),
    ("t", 1.812, (10.0,), 0.05, 8.2e-4),
    ("t", 3.169, (10.0,), 0.005, 8.5e-4),
    ("t", 2.750, (30.0,), 0.005, 1.2e-3),
    ("F", 3.326, (5.0, 10.0), 0.05, 4.1e-4),
    ("F", 4.938, (3.0, 20.0), 0.01, 4.1e-4),
    ("F", 161.4, (1.0, 1.0), 0.05, 1.6e-4),
    ("F", 2.690, (4.0, 30.0), 0.05, 6.3e-4),
]


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
@pytest.mark.parametrize(("kind", "x", "dof", "p", "rtol"), TABLES)
def test_printed_table_values(
    impl: str, kind: str, x: float, dof: tuple[float, ...], p: float, rtol: float
) -> None:
    chi2_sf, t_sf, f_sf = IMPLEMENTATIONS[impl]
    got = {"chi2": lambda: chi2_sf(x, *dof), "t": lambda: t_sf(x, *dof)}.get(
        kind, lambda: f_sf(x, dof[0], dof[1])
    )()
    assert got == pytest.approx(p, rel=rtol)


def test_values_quoted_in_the_issue() -> None:
    # 3.84146 is the 5 % point to 6 digits (3.8414588...): the tail moves by 7e-7.
    assert core.chi2_sf(3.84146, dof=1) == pytest.approx(0.05, rel=1e-6)
    # 0.036694017 is quoted to 9 decimals (0.0366940173853...).
    assert core.t_sf(2.0, dof=10) == pytest.approx(0.036694017, abs=5e-10)


# ----------------------------------------------------------------------- edge cases


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
def test_edge_cases_of_the_tails(impl: str) -> None:
    chi2_sf, t_sf, f_sf = IMPLEMENTATIONS[impl]
    inf, nan = math.inf, math.nan
    # x at or below 0, or no degrees of freedom: nothing tested, p = 1.
    assert chi2_sf(0.0, 3.0) == chi2_sf(-1.0, 3.0) == chi2_sf(5.0, 0.0) == 1.0
    assert chi2_sf(inf, 3.0) == 0.0
    assert math.isnan(chi2_sf(nan, 3.0)) and math.isnan(chi2_sf(1.0, inf))
    assert t_sf(0.0, 4.0) == 0.5 and t_sf(inf, 4.0) == 0.0 and t_sf(-inf, 4.0) == 1.0
    for dof in (0.0, -2.0, inf, nan):
        assert math.isnan(t_sf(1.0, dof)) and math.isnan(f_sf(1.0, dof, 3.0))
        assert math.isnan(f_sf(1.0, 3.0, dof))
    assert math.isnan(t_sf(nan, 4.0)) and math.isnan(f_sf(nan, 2.0, 3.0))
    assert f_sf(0.0, 2.0, 3.0) == f_sf(-1.0, 2.0, 3.0) == 1.0 and f_sf(inf, 2.0, 3.0) == 0.0


def test_the_core_keeps_tails_beyond_an_overflowing_square() -> None:
    # t² overflows for |t| > 1e154; the Cauchy tail is still 1 / (π t) there.
    assert core.t_sf(1e200, dof=1) == pytest.approx(1.0 / (math.pi * 1e200), rel=CORE_RTOL)
    assert core.t_sf(-1e200, dof=1) == 1.0


# ----------------------------------------------------------------------- paired test


@st.composite
def differences(draw: st.DrawFn) -> FloatArray:
    """Per-block differences: shifted noise over decades of scale, with ties sometimes."""
    n = draw(st.integers(0, 60))
    rng = np.random.default_rng(draw(seeds))
    d = draw(st.floats(-3.0, 3.0)) + rng.normal(size=n)
    if draw(st.booleans()):
        d = np.round(d)  # ties, and sometimes every value equal
    return d * 10.0 ** draw(st.integers(-150, 150))


def t_tolerance(d: FloatArray, t: float) -> float:
    """How far two correct computations of the paired ``t`` of ``d`` may differ.

    Both divide by max |d| first; their sums then differ by up to n ulp (sequential
    against pairwise), which moves the mean by n ε, so t by n ε over sd / sqrt(n), and
    the sum of squares by n ε relative, so t by n ε |t| (sd <= 1 after the division).
    """
    n = d.size
    sd = float((d / np.abs(d).max()).std(ddof=1))
    return 4.0 * n * EPS * (math.sqrt(n) / sd) * (1.0 + abs(t) / sd)


def p_tolerance(d: FloatArray, t: float, p: float) -> float:
    """How far the two p-values may differ: the functions' accuracy plus the t density
    (below 0.4) times :func:`t_tolerance`."""
    return reference_rtol(0.5 * d.size) * p + 0.4 * t_tolerance(d, t)


def _zero_variance(d: FloatArray) -> bool:
    return d.size < 2 or not np.isfinite(d).all() or bool((d == d[0]).all())


@given(differences())
def test_paired_test_matches_reference(d: FloatArray) -> None:
    got, want = core.paired_test(d), reference.paired_test(d)
    assert got.n == want.n == d.size
    if _zero_variance(d):  # the conventions: exact values
        assert np.array_equal([got.t, got.p], [want.t, want.p], equal_nan=True)
        return
    assert abs(got.t - want.t) <= t_tolerance(d, want.t)
    assert abs(got.p - want.p) <= p_tolerance(d, want.t, want.p)


@pytest.mark.parametrize("paired_test", [core.paired_test, reference.paired_test])
def test_paired_test_conventions(paired_test: Callable[[FloatArray], object]) -> None:
    def tp(values: list[float]) -> tuple[float, float, int]:
        r = paired_test(np.array(values, dtype=np.float64))
        return r.t, r.p, r.n  # type: ignore[attr-defined]

    assert tp([1.0, 2.0, 3.0])[0] == pytest.approx(2.0 * math.sqrt(3.0), rel=1e-14)
    t, p, n = tp([])
    assert math.isnan(t) and p == 1.0 and n == 0
    t, p, n = tp([4.0])
    assert math.isnan(t) and p == 1.0 and n == 1
    for bad in (math.nan, math.inf):
        t, p, n = tp([1.0, bad, 2.0])
        assert math.isnan(t) and math.isnan(p) and n == 3
    assert tp([0.5, 0.5, 0.5]) == (math.inf, 0.0, 3)
    assert tp([0.0, -0.0, 0.0]) == (0.0, 1.0, 3)
    assert tp([-2.0, -2.0]) == (0.0, 1.0, 2)


# ----------------------------------------------------------------------- multiple tests


@st.composite
def p_values(draw: st.DrawFn) -> tuple[FloatArray, int | None]:
    """P-values with ties, exact 0 and 1, NaN; and a number of tests at least as large."""
    k = draw(st.integers(0, 30))
    rng = np.random.default_rng(draw(seeds))
    p = rng.uniform(size=k) ** draw(st.sampled_from([1.0, 4.0]))
    pool = np.array([0.0, 1.0, 0.01, np.nan])
    special = rng.uniform(size=k) < draw(st.sampled_from([0.0, 0.3]))
    p[special] = rng.choice(pool, size=int(special.sum()))
    extra = draw(st.one_of(st.none(), st.integers(0, 50)))
    return p, None if extra is None else k + extra


@given(p_values())
def test_bonferroni_and_holm_match_reference(case: tuple[FloatArray, int | None]) -> None:
    p, m = case
    # The same operations in the same order on each side: the same bits.
    np.testing.assert_array_equal(core.bonferroni(p, n_tests=m), reference.bonferroni(p, m))
    holm = core.holm(p, n_tests=m)
    np.testing.assert_array_equal(holm, reference.holm(p, m))
    ok = ~np.isnan(p)
    bonferroni = core.bonferroni(p, n_tests=m)
    assert (p[ok] <= holm[ok]).all() and (holm[ok] <= bonferroni[ok]).all()
    order = np.argsort(p[ok], kind="stable")
    assert (np.diff(holm[ok][order]) >= 0).all()


#: Holm and Bonferroni of each implementation, both callable as ``f(p, n_tests=m)``.
ADJUSTMENTS: dict[str, tuple[Callable[..., FloatArray], Callable[..., FloatArray]]] = {
    "core": (core.holm, core.bonferroni),
    "reference": (reference.holm, reference.bonferroni),
}


@pytest.mark.parametrize("impl", ADJUSTMENTS)
def test_multiple_testing_values_and_errors(impl: str) -> None:
    holm, bonferroni = ADJUSTMENTS[impl]
    p = np.array([0.01, 0.04, 0.03, 0.5, np.nan])
    # Sorted 0.01, 0.03, 0.04, 0.5 (NaN last) over m = 5: 5 p, 4 p, max(3 p, 0.12), 1.
    np.testing.assert_allclose(holm(p), [0.05, 0.12, 0.12, 1.0, np.nan], rtol=1e-15)
    np.testing.assert_allclose(bonferroni(p), [0.05, 0.2, 0.15, 1.0, np.nan], rtol=1e-15)
    got = holm(np.array([0.2, 1e-4]), n_tests=10)
    np.testing.assert_allclose(got, [1.0, 1e-3], rtol=1e-15)
    assert holm(np.array([])).size == 0 and bonferroni(np.array([]), n_tests=3).size == 0
    for bad in ([-0.1], [1.5]):
        with pytest.raises(ValueError, match=r"\[0, 1\]") as err:
            holm(np.array(bad))
        assert type(err.value).__name__ == "ParameterError"
    with pytest.raises(ValueError, match="tests") as err:
        bonferroni(np.array([0.1, 0.2]), n_tests=1)
    assert type(err.value).__name__ == "ParameterError"
    with pytest.raises(ValueError) as err:
        holm(np.zeros((2, 2)))
    assert type(err.value).__name__ == "ShapeError"


def test_a_negative_number_of_tests_is_a_parameter_error() -> None:
    with pytest.raises(ParameterError) as err:
        core.holm(np.array([0.1]), n_tests=-1)
    assert err.value.parameter == "n_tests"


# ----------------------------------------------------------------------- the acceptance rule


@st.composite
def block_errors(draw: st.DrawFn) -> tuple[FloatArray, FloatArray]:
    """Held-out SSE per block before and after: an effect of some size, noise per block."""
    n = draw(st.integers(0, 40))
    rng = np.random.default_rng(draw(seeds))
    before = rng.gamma(2.0, 1.0, size=n) * 10.0 ** draw(st.integers(-6, 6))
    effect = draw(st.floats(-0.3, 0.8))
    noise = draw(st.floats(0.0, 0.5))
    after = before * (1.0 - effect) * np.exp(noise * rng.normal(size=n))
    return before, after


@given(
    blocks=block_errors(),
    min_improvement=st.sampled_from([0.0, 0.05, 0.10, 0.3]),
    alpha=st.sampled_from([0.001, 0.01, 0.05]),
)
def test_acceptance_rule_matches_reference(
    blocks: tuple[FloatArray, FloatArray], min_improvement: float, alpha: float
) -> None:
    before, after = blocks
    got = core.AcceptanceRule(min_improvement=min_improvement, alpha=alpha).judge(before, after)
    want = reference.AcceptanceRule(min_improvement=min_improvement, alpha=alpha).judge(
        before, after
    )
    n = before.size
    assert got.n == want.n == n
    # Sums of n positive terms, sequential against pairwise: the cut moves by ~n ε.
    cut_tol = 4.0 * (n + 1) * EPS
    assert got.cut == pytest.approx(want.cut, abs=cut_tol)
    # The rule's p combines its three tests the same way on both sides, exactly.
    for v in (got, want):
        tests = [q for q in (v.p_sum, v.p_log, v.p_sign) if not math.isnan(q)]
        expect = min(1.0, 3.0 * min(tests))
        assert v.p == expect or (math.isnan(v.p) and math.isnan(v.p_sum))
    # The sign test counts signs: exact on both sides (integers against doubles exact
    # below 2^53: C(n, j) for n up to the strategy's blocks).
    assert got.p_sign == pytest.approx(want.p_sign, rel=1e-13)
    d = before - after
    both = (before > 0) & (after > 0)
    dl = np.log(before[both] / after[both])
    if _zero_variance(d) or _zero_variance(dl):
        assume(False)  # the conventions of each test are checked on their own above
    p_tol = p_tolerance(d, want.t, want.p_sum)
    assert abs(got.p_sum - want.p_sum) <= p_tol
    # The log ratio: ln(a) - ln(b) against ln(a / b) moves each value by a few ulp of the
    # logarithms (up to ~4 eps max|ln|), which moves t by sqrt(n) delta / sd (1 + |t|).
    t_log = reference.paired_test(dl).t
    delta = 4.0 * EPS * float(np.abs(np.log(before[both])).max() + 1.0)
    dt = math.sqrt(dl.size) * delta / float(dl.std(ddof=1)) * (1.0 + abs(t_log))
    p_log_tol = p_tolerance(dl, t_log, want.p_log) + 0.4 * dt
    assert abs(got.p_log - want.p_log) <= p_log_tol
    # The verdicts agree away from the thresholds (where the figures' last digits decide).
    tol = 3.0 * max(p_tol, p_log_tol, 1e-13 * want.p_sign)
    assume(abs(want.cut - min_improvement) > cut_tol and abs(want.p - alpha) > tol)
    assert got.accepted == want.accepted


@given(blocks=block_errors(), weight_sum=st.floats(1.0, 1e6))
def test_rule_is_the_selections_rule_written_out(
    blocks: tuple[FloatArray, FloatArray], weight_sum: float
) -> None:
    # The selection's rule written out: cut from the held-out RMS sqrt(sum sse / sum w)
    # of each model; the paired test of the block differences and of their log ratios,
    # and the sign test of the differences, Bonferroni-combined.
    before, after = blocks
    rms_before = math.sqrt(float(before.sum()) / weight_sum)
    rms_after = math.sqrt(float(after.sum()) / weight_sum)
    cut = 1.0 - rms_after / rms_before if rms_before > 0 else 0.0
    d = before - after
    both = (before > 0) & (after > 0)
    dl = np.log(before[both] / after[both])
    if _zero_variance(d) or _zero_variance(dl):
        assume(False)
    test, test_log = reference.paired_test(d), reference.paired_test(dl)
    p = min(1.0, 3.0 * min(test.p, test_log.p, reference.sign_test(d)))
    inline = cut >= 0.10 and p < 0.01 and math.isfinite(cut)
    v = diagnosis_stats.accept(before, after, min_improvement=0.10, alpha=0.01)
    # Two roundings more on the inline side (the divisions by the weight sum).
    cut_tol = 8.0 * (before.size + 1) * EPS
    assert v.cut == pytest.approx(cut, abs=cut_tol)
    # As in test_acceptance_rule_matches_reference, with the logs' few ulp.
    delta = 4.0 * EPS * float(np.abs(np.log(before[both])).max() + 1.0)
    dt = math.sqrt(dl.size) * delta / float(dl.std(ddof=1)) * (1.0 + abs(test_log.t))
    p_tol = 3.0 * max(
        p_tolerance(d, test.t, test.p), p_tolerance(dl, test_log.t, test_log.p) + 0.4 * dt
    )
    assume(abs(cut - 0.10) > cut_tol and abs(p - 0.01) > p_tol)
    assert v.accepted == inline


def test_acceptance_rule_cases_and_errors() -> None:
    rule = core.AcceptanceRule(min_improvement=0.1, alpha=0.01)
    assert (rule.min_improvement, rule.alpha) == (0.1, 0.01)
    v = rule.judge([4.0, 5.0, 4.5, 5.5, 4.8], [1.0, 1.2, 0.9, 1.1, 1.0])
    assert v.accepted and v.n == 5 and v.p < 1e-4
    assert v.p == min(1.0, 3.0 * min(v.p_sum, v.p_log, v.p_sign))
    assert v.p_sign == 0.5**5  # every block cut
    # A cut on most blocks while one block dominates the total: the log ratio sees it.
    broad = rule.judge([20.0, *[1.0] * 7], [14.0, 0.4, 0.35, 0.4, 0.45, 0.4, 0.35, 0.4])
    assert broad.p_sum > 0.01 and broad.p_log < 1e-4 and broad.accepted
    assert v.cut == pytest.approx(1.0 - math.sqrt(5.2 / 23.8), rel=1e-15)
    # A big cut carried by one block is not significant; a significant small one is too small.
    assert not rule.judge([1.0, 1.0, 1.0, 9.0], [1.1, 0.9, 1.05, 0.5]).accepted
    small = rule.judge([1.0] * 6, [0.95, 0.96, 0.95, 0.94, 0.95, 0.96])
    assert small.p < 0.01 and small.cut < 0.1 and not small.accepted
    assert rule.judge([0.0, 0.0], [0.0, 0.0]).cut == 0.0
    nan = rule.judge([1.0, 1.0, 1.0], [0.1, math.nan, 0.1])
    assert not nan.accepted and math.isnan(nan.cut) and math.isnan(nan.p)
    assert rule.judge([5.0], [1.0]).p == 1.0
    with pytest.raises(ShapeError):
        rule.judge([1.0, 2.0], [1.0])
    for mi, alpha, name in ((1.0, 0.01, "min_improvement"), (0.1, 0.0, "alpha")):
        with pytest.raises(ParameterError) as err:
            core.AcceptanceRule(min_improvement=mi, alpha=alpha)
        assert err.value.parameter == name
        with pytest.raises(ValueError) as ref_err:
            reference.AcceptanceRule(min_improvement=mi, alpha=alpha)
        assert type(ref_err.value).__name__ == "ParameterError"


# ----------------------------------------------------------------------- the diagnosis' spelling


@given(x=st.floats(0.0, 500.0), dof=st.integers(-1, 200))
def test_diagnosis_stats_is_the_core(x: float, dof: int) -> None:
    assert diagnosis_stats.chi2_sf(x, dof) == core.chi2_sf(x, dof=dof)
    if dof > 0:
        assert diagnosis_stats.t_sf(x - 250.0, dof) == core.t_sf(x - 250.0, dof=dof)
    else:
        assert math.isnan(diagnosis_stats.t_sf(x, dof))
    p = core.chi2_sf(x, dof=3)
    n = max(dof, 1)
    assert diagnosis_stats.corrected_p(p, n) == min(1.0, p * n)


def test_diagnosis_paired_test_returns_t_and_p() -> None:
    d = np.array([0.3, 1.2, 0.8, 0.5])
    test = core.paired_test(d)
    assert diagnosis_stats.paired_test(d) == (test.t, test.p)
    t, p = diagnosis_stats.paired_test(np.array([2.0]))
    assert math.isnan(t) and p == 1.0
