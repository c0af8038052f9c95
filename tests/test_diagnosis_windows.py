"""The diagnosis fits window means: exact for a linear model, chosen from the data."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from accelcore import calibrate
from accelcore.core import BlockedLeastSquares
from accelcore.diagnosis import diagnose
from accelcore.diagnosis.engine import Engine
from accelcore.diagnosis.windows import MAX_WINDOW, MIN_WINDOWS_PER_BLOCK, choose_windows
from accelcore.reference import heldout as reference_heldout
from accelcore.simulate import effects as se
from test_diagnosis import make_session


def _blocks(sizes: list[int]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    stop = np.cumsum(sizes).astype(np.int64)
    return np.concatenate([[0], stop[:-1]]).astype(np.int64), stop


def test_window_means_lose_nothing_of_a_model_whose_columns_are_constant_in_them() -> None:
    # Columns constant inside each window, a response with noise inside them: the
    # held-out error of every block on the window means plus the response's own
    # variation inside the windows equals the error on every sample (same algebra).
    rng = np.random.default_rng(3)
    start, stop = _blocks([96, 64, 128, 80, 96, 112])
    n = int(stop[-1])
    w = rng.uniform(0.5, 1.5, n)
    w[rng.choice(n, 20, replace=False)] = 0.0  # spikes left out, as the calibration does
    slow = np.repeat(rng.normal(size=n // 8 + 1), 8)[:n]
    win = choose_windows(w, start, stop, [np.arange(n, dtype=float)], [rng.normal(size=n)])
    assert win.length > 1
    x = np.column_stack([np.ones(n), slow, slow**2])
    # Make the columns exactly constant inside each window.
    x = np.column_stack([win.compress(c)[win.sample_window] for c in x.T])
    y = x @ np.array([0.3, -1.2, 0.4]) + rng.normal(scale=0.5, size=n)
    sizes = stop - start
    sample_block = np.repeat(np.arange(sizes.size), sizes)
    block_fold = np.array([0, 1, 2, 0, 1, 2])
    full = reference_heldout.cross_validate(x, y, sample_block, block_fold, w)
    xw = np.column_stack([win.compress(c) for c in x.T])
    yw = win.compress(y)
    lsq = BlockedLeastSquares(3, sizes.size)
    lsq.push(xw, yw, win.block, win.weight)
    fit = lsq.cross_validate(block_fold)
    dev = y - yw[win.sample_window]
    within = np.bincount(sample_block, weights=w * dev * dev, minlength=sizes.size)
    # Sums of a few hundred squares of O(1) values: 1e-9 relative is far above rounding.
    np.testing.assert_allclose(
        np.asarray(fit.heldout_rss_per_block) + within, full.heldout_rss_per_block, rtol=1e-9
    )
    np.testing.assert_allclose(fit.in_sample_rss + within.sum(), full.in_sample_rss, rtol=1e-9)


def test_windows_keep_every_block_cut_and_never_cross_one() -> None:
    start, stop = _blocks([600, 600, 20, 5])
    n = int(stop[-1])
    w = np.ones(n)
    t = np.arange(n, dtype=float)
    win = choose_windows(w, start, stop, [t, 0.01 * t], [np.zeros(n)])
    assert win.length == MAX_WINDOW
    sizes = np.bincount(win.block, minlength=4)
    # A long block gets n / MAX_WINDOW windows; a short one at least MIN_WINDOWS_PER_BLOCK
    # (or one per sample when it holds fewer).
    assert sizes.tolist() == [600 // MAX_WINDOW + 1, 600 // MAX_WINDOW + 1, 10, 5]
    assert sizes[2] >= MIN_WINDOWS_PER_BLOCK
    sample_block = np.repeat(np.arange(4), stop - start)
    assert np.array_equal(win.block[win.sample_window], sample_block)
    assert np.all(np.diff(win.sample_window) >= 0)


def test_a_fast_observable_that_drives_the_response_shortens_the_windows() -> None:
    rng = np.random.default_rng(5)
    start, stop = _blocks([600] * 6)
    n = int(stop[-1])
    w = np.ones(n)
    supply = rng.normal(size=n)  # changes from sample to sample
    quiet = choose_windows(w, start, stop, [supply], [rng.normal(size=n)])
    driven = choose_windows(w, start, stop, [supply], [2.0 * supply + rng.normal(size=n)])
    assert quiet.length == MAX_WINDOW  # noise in a logged column changes nothing
    assert driven.length == 1  # the response follows it sample by sample: no averaging


def test_a_supply_that_wanders_within_seconds_is_still_found() -> None:
    # The supply's wander (20 s period) lives inside 16 s windows: the windows shrink,
    # and the effect is found as with every sample.
    fx = se.SupplySensitivity(period_s=20.0, wander_v=0.004, step_v=0.0)
    session = make_session([fx], duration_h=0.5)
    eng = Engine(session, calibrate(session), folds="auto", block_s=300.0, steady_c_per_min=0.1)
    assert eng.windows.length < MAX_WINDOW
    d = diagnose(session)
    assert "extra:supply_v" in d.effects


def test_clean_sessions_average_windows_of_many_samples() -> None:
    session = make_session([], duration_h=0.5)
    eng = Engine(session, calibrate(session), folds="auto", block_s=300.0, steady_c_per_min=0.1)
    # Temperature moves ~0.1 °C in 16 s: nothing the model can use lives inside a window.
    assert eng.windows.length == MAX_WINDOW
    assert eng.n_windows < eng.n / 8
