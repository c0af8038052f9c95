"""The time-constant search in the core against its NumPy twin and the Python loop.

``accelcore.core.TimeConstantSearch`` runs the trials of
``accelcore.diagnosis.search.search_1d``; ``accelcore.reference.search`` is the
same specification written plainly. On a diagnosis engine the core's trials are
also compared with the Python loop (each trial through ``Engine.cv_coarse``).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pandas as pd
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from numpy.typing import NDArray

from accelcore.core import TimeConstantSearch
from accelcore.diagnosis import diagnose
from accelcore.diagnosis import search as diagnosis_search
from accelcore.diagnosis.engine import Engine
from accelcore.diagnosis.observables import STEADY_C_PER_MIN
from accelcore.diagnosis.space import Spec, with_tau
from accelcore.errors import ParameterError, ShapeError
from accelcore.fitting.calibrate import calibrate
from accelcore.model import AXES, RunStep, Term
from accelcore.reference import search as reference
from accelcore.simulate import effects as se
from strategies import seeds
from test_diagnosis import make_session

FloatArray = NDArray[np.float64]

#: Scores of the core (QR per block, factors merged) and of the reference
#: (rows refitted with NumPy's SVD least squares, whose accuracy is the *unscaled*
#: condition number times eps) on the same trial. Trials are compared where every
#: fold's weighted training design has a condition number below MAX_CONDITION (a
#: decay of a few seconds leaves a column of 1e-20 beside columns of 1: the two
#: solvers then legitimately differ in the 6th digit). There each coefficient is
#: within ~1e6 * eps = 2e-10 of exact, and a held-out error, a sum of squared
#: residuals, within a few times that relative; the window means are summed in
#: another order (1e-16). 1e-8 leaves a margin and still catches a wrong row,
#: column, weight or fold.
SCORE_RTOL = 1e-8
MAX_CONDITION = 1e6

#: Scores of the core against the engine's own trials (``Engine.cv_coarse``): the
#: same columns (the same floats, but for the last bit of a decay's ``exp``), the same
#: rows rotated in the same order, into one factor per fold in the core and one per
#: block in the engine. Two backward-stable accumulations of one design differ by
#: about its condition number times eps relative; these designs (temperature powers
#: up to the fifth beside gravity and time) have scaled condition numbers below
#: ~1e5, and the differences seen are below 2e-13. 1e-10 bounds that with a margin
#: and is far below what moves a trial (the search's steps are 0.5 % in tau).
LOOP_RTOL = 1e-10


def _problem(seed: int, stride: int) -> tuple[dict[str, Any], dict[str, Any], float]:
    """A small random data set: (constructor arguments, model, the true tau)."""
    rng = np.random.default_rng(seed)
    records, gather, elapsed = [], [], []
    offset = 0
    for _ in range(int(rng.integers(1, 4))):
        n = int(rng.integers(25, 60))
        dt = rng.choice([5.0, 5.0, 5.0, 7.5], size=n)
        t = np.cumsum(dt) - dt[0]
        temp = 25.0 + 8.0 * np.sin(t / rng.uniform(30.0, 100.0)) + rng.normal(0, 0.05, n)
        keep = np.flatnonzero(rng.random(n) < 0.8)
        records.append((t, temp))
        gather.append(offset + keep)
        elapsed.append(t[keep])
        offset += n
    g = np.concatenate(gather)
    n = g.size
    w = rng.uniform(0.5, 2.0, n) * (rng.random(n) > 0.05)
    lengths = rng.integers(1, 5, n)
    start = np.unique(np.minimum(np.concatenate([[0], np.cumsum(lengths)]), n))[:-1]
    n_win = start.size
    window_weight = np.add.reduceat(w, start)
    window_block = np.arange(n_win) // int(rng.integers(3, 7))
    n_blocks = int(window_block[-1]) + 1
    block_fold = np.arange(n_blocks) % int(rng.integers(2, 4))
    data = {
        "records": records,
        "gather": g,
        "elapsed_s": np.concatenate(elapsed),
        "sample_weight": w,
        "window_start": start,
        "window_weight": window_weight,
        "window_block": window_block,
        "block_fold": block_fold,
        "t_ref_c": 25.0,
        "stride": stride,
    }
    p0 = int(rng.integers(1, 4))
    fixed = np.column_stack([np.ones(n_win), rng.normal(size=(n_win, p0 - 1))])
    gravity = rng.choice([-1.0, 1.0], size=n_win)
    columns: list[tuple[str, int, FloatArray | None]] = [("fixed", j, None) for j in range(p0)]
    moving: list[tuple[str, int, FloatArray | None]] = [
        ("lag", 1, None),
        ("lag", int(rng.integers(1, 3)), gravity),
        ("decay", 0, None),
    ]
    for column in [moving[i] for i in rng.permutation(3)[: int(rng.integers(1, 3))]]:
        columns.insert(int(rng.integers(0, len(columns) + 1)), column)
    tau = float(rng.uniform(20.0, 200.0))
    truth = reference.TimeConstantSearch(*_positional(data), **_keywords(data))
    x = truth.design(fixed, columns, tau)
    full = np.zeros((n_win, x.shape[1]))
    full[truth.rows] = x
    y = full @ rng.uniform(0.5, 2.0, x.shape[1]) + rng.normal(0, 0.05, n_win)
    return data, {"fixed": fixed, "response": y, "columns": columns}, tau


def _positional(data: dict[str, Any]) -> list[Any]:
    names = [
        "records",
        "gather",
        "elapsed_s",
        "sample_weight",
        "window_start",
        "window_weight",
        "window_block",
        "block_fold",
    ]
    return [data[k] for k in names]


def _keywords(data: dict[str, Any]) -> dict[str, Any]:
    return {"t_ref_c": data["t_ref_c"], "stride": data["stride"]}


def _well_posed(ref: reference.TimeConstantSearch, model: dict[str, Any], tau: float) -> bool:
    """Whether every fold's weighted training design is well conditioned at ``tau``."""
    x = ref.design(model["fixed"], model["columns"], tau)
    w = ref.window_weight[ref.rows]
    fold = ref.block_fold[ref.window_block[ref.rows]]
    for k in range(int(ref.block_fold.max()) + 1):
        train = (fold != k) & (w > 0)
        xt = x[train] * np.sqrt(w[train])[:, None]
        if xt.shape[0] < xt.shape[1] or np.linalg.cond(xt) > MAX_CONDITION:
            return False
    return True


def _both(data: dict[str, Any]) -> tuple[TimeConstantSearch, reference.TimeConstantSearch]:
    args, kw = _positional(data), _keywords(data)
    return TimeConstantSearch(*args, **kw), reference.TimeConstantSearch(*args, **kw)


@given(seed=seeds, stride=st.integers(1, 2), taus=st.lists(st.floats(5.0, 2000.0), max_size=3))
def test_trial_scores_equal_the_reference(seed: int, stride: int, taus: list[float]) -> None:
    data, model, true_tau = _problem(seed, stride)
    core, ref = _both(data)
    m = (model["fixed"], model["response"], model["columns"])
    assert core.n_rows == ref.n_rows
    for tau in [true_tau, *taus, true_tau]:  # the last one from the core's kept means
        assume(_well_posed(ref, model, tau))
        assert core.score(*m, tau) == pytest.approx(ref.score(*m, tau), rel=SCORE_RTOL)


@given(seed=seeds, stride=st.integers(1, 2))
def test_search_equals_the_reference(seed: int, stride: int) -> None:
    data, model, _ = _problem(seed, stride)
    core, ref = _both(data)
    m = (model["fixed"], model["response"], model["columns"])
    best, trials = core.search(*m, range_s=(5.0, 2000.0))
    assume(all(_well_posed(ref, model, tau) for tau in trials[:, 0]))
    ref_best, ref_trials = ref.search(*m, range_s=(5.0, 2000.0))
    # The same taus in the same order (each rounded to three digits), scores to the
    # numerics of two solvers, and the same best.
    np.testing.assert_array_equal(trials[:, 0], ref_trials[:, 0])
    np.testing.assert_allclose(trials[:, 1], ref_trials[:, 1], rtol=SCORE_RTOL)
    assert best == ref_best
    assert trials[:, 1].min() == trials[trials[:, 0] == best, 1][0]


def test_a_dependent_later_column_is_held_at_zero() -> None:
    data, model, tau = _problem(5, 1)
    core, ref = _both(data)
    once = [("fixed", 0, None), ("lag", 1, None)]
    twice = [("fixed", 0, None), ("lag", 1, None), ("lag", 1, None)]
    score = core.score(model["fixed"], model["response"], once, tau)
    assert core.score(model["fixed"], model["response"], twice, tau) == pytest.approx(
        score, rel=1e-9
    )
    assert ref.score(model["fixed"], model["response"], twice, tau) == pytest.approx(
        score, rel=SCORE_RTOL
    )


def test_the_reference_lag_is_the_cores_filter() -> None:
    from accelcore._accelcore import first_order_lag

    t = np.cumsum(np.r_[0.0, np.full(50, 0.5), 0.7, np.full(20, 0.5)])
    x = 20.0 + np.sin(t / 3.0)
    np.testing.assert_array_equal(reference.first_order_lag(t, x, 7.0), first_order_lag(t, x, 7.0))


@given(
    steps=st.lists(st.sampled_from([0.5, 0.5, 0.5, 0.7, 2.0, 0.0]), min_size=1, max_size=80),
    wiggle=st.floats(0.1, 10.0),
    tau_heat=st.floats(0.5, 500.0),
    tau_cool=st.floats(0.5, 500.0),
)
def test_the_reference_direction_lag_is_the_cores(
    steps: list[float], wiggle: float, tau_heat: float, tau_cool: float
) -> None:
    """Heating and cooling time constants: the core's filter and the reference's, the
    same floats (both take tau by the sign of input minus output, and -expm1)."""
    from accelcore._accelcore import first_order_lag

    t = np.cumsum(np.r_[0.0, steps])
    x = 20.0 + wiggle * np.sin(t / 3.0) + 0.05 * t
    np.testing.assert_array_equal(
        reference.first_order_lag(t, x, tau_heat, tau_cool),
        first_order_lag(t, x, tau_heat, tau_cool_s=tau_cool),
    )


def test_bad_inputs_are_typed_errors() -> None:
    data, model, _ = _problem(7, 1)
    core, _ = _both(data)
    f, y = model["fixed"], model["response"]
    with pytest.raises(ParameterError):
        TimeConstantSearch(*_positional(data), t_ref_c=25.0, stride=0)
    with pytest.raises(ShapeError):
        core.score(f, y[1:], [("lag", 1, None)], 5.0)
    with pytest.raises(ParameterError):
        core.score(f, y, [("spline", 1, None)], 5.0)
    with pytest.raises(ParameterError):
        core.score(f, y, [("fixed", f.shape[1], None)], 5.0)
    with pytest.raises(ParameterError):
        core.search(f, y, [("lag", 1, None)], range_s=(10.0, 1.0))


def _models(seed: int, stride: int) -> tuple[dict[str, Any], list[tuple[Any, ...]]]:
    """A data set and several models on it: its own, lags only, decays only, both."""
    data, model, _ = _problem(seed, stride)
    f, y = model["fixed"], model["response"]
    gravity = np.where(np.arange(f.shape[0]) % 7 < 3, 1.0, -1.0)
    columns: list[list[tuple[str, int, FloatArray | None]]] = [
        model["columns"],
        [("fixed", 0, None), ("lag", 1, None), ("lag", 3, gravity)],
        [("decay", 0, gravity), ("fixed", 0, None)],
        [("lag", 2, None), ("fixed", 0, None), ("decay", 0, None)],
    ]
    return data, [(f, y, c) for c in columns]


@given(seed=seeds, stride=st.integers(1, 2))
def test_searches_together_are_the_searches_alone(seed: int, stride: int) -> None:
    data, models = _models(seed, stride)
    settings: dict[str, Any] = {"range_s": (5.0, 2000.0)}
    alone = [_both(data)[0].search(*m, **settings) for m in models]
    for threads in (1, 2, 3):
        core = _both(data)[0]
        for _ in range(2):  # then again, from the window means the first kept
            together = core.search_many(models, threads=threads, **settings)
            assert len(together) == len(models)
            # The same trials in the same order, the same floats: bit for bit.
            for (best, trials), (want_best, want_trials) in zip(together, alone, strict=True):
                assert best == want_best
                assert trials.tobytes() == want_trials.tobytes()
    assert _both(data)[0].search_many([], threads=2, **settings) == []


def test_searches_together_give_the_first_models_error() -> None:
    data, models = _models(3, 1)
    core, _ = _both(data)
    f, y, _ = models[0]
    bad_column = (f, y, [("fixed", f.shape[1], None)])
    short = (f, y[1:], [("lag", 1, None)])
    for threads in (1, 2):
        with pytest.raises(ParameterError):
            core.search_many([models[1], bad_column, short], range_s=(5.0, 2000.0), threads=threads)
        with pytest.raises(ShapeError):
            core.search_many([models[1], short, bad_column], range_s=(5.0, 2000.0), threads=threads)
    with pytest.raises(ParameterError):
        core.search_many(models, range_s=(5.0, 2000.0), threads=0)
    with pytest.raises(ParameterError):
        core.search_many(models, range_s=(10.0, 1.0), threads=2)


# ----------------------------------------------------------------- on a diagnosis engine


@pytest.fixture(scope="module")
def engine() -> Engine:
    session = make_session((se.ThermalLag(90.0), se.WarmUp(3.0, 400.0)), 3)
    return Engine(
        session,
        calibrate(session),
        folds="auto",
        block_s=300.0,
        steady_c_per_min=STEADY_C_PER_MIN,
    )


def _makers() -> list[tuple[str, Any]]:
    base = Spec()
    curved = replace(base, offset_order=3, gain_order=2, cross=("y",), drift=True)
    return [
        ("die lag", lambda t: with_tau(base, "die", t)),
        ("die lag, curved", lambda t: with_tau(curved, "die", t)),
        ("rate term", lambda t: with_tau(curved, "rate", t)),
        ("warm-up", lambda t: diagnosis_search.with_warm_up(curved, t)),
    ]


@pytest.mark.parametrize("axis", ["x", "z"])
@pytest.mark.parametrize("name", [name for name, _ in _makers()])
def test_core_trials_are_the_python_loops(engine: Engine, axis: str, name: str) -> None:
    make = dict(_makers())[name]
    assert diagnosis_search.tau_columns(engine, axis, make, (5.0, 3600.0)) is not None
    best, trials = diagnosis_search.tau_trials(engine, axis, make, (5.0, 3600.0), core=True)
    py_best, py_trials = diagnosis_search.tau_trials(engine, axis, make, (5.0, 3600.0), core=False)
    assert list(trials) == list(py_trials)
    assert best == py_best
    got, want = np.array(list(trials.values())), np.array(list(py_trials.values()))
    np.testing.assert_allclose(got, want, rtol=LOOP_RTOL)


def test_models_the_core_cannot_express_fall_back_to_the_loop(engine: Engine) -> None:
    fixed_lag = with_tau(Spec(), "die", 90.0)
    rate = diagnosis_search.tau_columns(
        engine, "x", lambda t: with_tau(fixed_lag, "rate", t), (5.0, 3600.0)
    )
    assert rate is None  # lag(90):dT^1 is a fixed column that a trial could duplicate
    run = engine.record_names[0]

    def step(t: float) -> Spec:
        return replace(Spec(), events=(Term("offset", RunStep(run, t), effect="step"),))

    assert diagnosis_search.tau_columns(engine, "x", step, (5.0, 3600.0)) is None
    best, trials = diagnosis_search.tau_trials(engine, "x", step, (100.0, 1000.0))
    assert (best, trials) == diagnosis_search.tau_trials(
        engine, "x", step, (100.0, 1000.0), core=False
    )


def test_diagnose_finds_the_same_lag_with_the_core_and_the_loop(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    session = make_session((se.ThermalLag(90.0),), 2)
    found = diagnose(session)
    monkeypatch.setattr(diagnosis_search, "CORE_SEARCH", False)
    looped = diagnose(session)
    assert "thermal_lag" in found.effects
    assert found.effects == looped.effects
    assert [s.variant for s in found.steps] == [s.variant for s in looped.steps]
    # Every candidate tried scores the same, and the diagnosed model is the same.
    pd.testing.assert_frame_equal(found.candidates, looped.candidates)
    for a in AXES:
        got, want = found.calibration.axes[a], looped.calibration.axes[a]
        assert got.terms == want.terms
        np.testing.assert_array_equal(got.coefficients, want.coefficients)


class _CountedSearch:
    """The core's search of an engine, its calls counted."""

    def __init__(self, inner: TimeConstantSearch, calls: list[tuple[str, int, int]]) -> None:
        self.inner, self.calls = inner, calls

    def search(self, *args: Any, **kw: Any) -> Any:
        self.calls.append(("search", 1, 1))
        return self.inner.search(*args, **kw)

    def search_many(self, models: Any, **kw: Any) -> Any:
        self.calls.append(("search_many", len(models), kw["threads"]))
        return self.inner.search_many(models, **kw)


def test_diagnose_is_the_same_on_one_thread_and_two(monkeypatch: pytest.MonkeyPatch) -> None:
    session = make_session((se.ThermalLag(90.0), se.WarmUp(3.0, 400.0)), 2)
    core = diagnosis_search._core
    found: dict[int, Any] = {}
    calls: dict[int, list[tuple[str, int, int]]] = {}
    for threads in (1, 2):
        calls[threads] = []
        monkeypatch.setattr(diagnosis_search, "search_threads", threads)
        monkeypatch.setattr(
            diagnosis_search,
            "_core",
            lambda eng, seen=calls[threads]: _CountedSearch(core(eng), seen),
        )
        found[threads] = diagnose(session)
    # Every search of the lag and the warm-up ran in a batch of the axes' models, none
    # alone afterwards; the batches the same on one thread and two.
    assert calls[1] and all(kind == "search_many" for kind, _, _ in calls[1])
    assert any(n > 1 for _, n, _ in calls[1])
    assert [c[:2] for c in calls[1]] == [c[:2] for c in calls[2]]
    assert {c[2] for c in calls[2]} == {2}
    one, two = found[1], found[2]
    assert "thermal_lag" in one.effects
    assert one.effects == two.effects
    # Exactly the same figures (repr writes each float's shortest exact form; NaN too).
    assert repr(one.steps) == repr(two.steps)
    pd.testing.assert_frame_equal(one.candidates, two.candidates, check_exact=True)
    for a in AXES:
        got, want = one.calibration.axes[a], two.calibration.axes[a]
        assert got.terms == want.terms
        np.testing.assert_array_equal(got.coefficients, want.coefficients)
