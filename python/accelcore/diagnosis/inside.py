"""What a model does inside the engine's windows: the per-sample error the means leave out.

The engine fits and cross-validates on window means (:mod:`.windows`), which is exact
for the window-level part of a model's error; inside a window it counts only the
response's deviations from its mean, the same for every model. That holds while the
model's columns move smoothly inside a window, as a temperature power, a lag, time or
gravity do over a few seconds (the windows are chosen so that such moves explain
nothing of the response). A column that is a function of a noisy observable does not:
the rate of change of a noisy temperature probe jitters from one sample to the next,
and a few of its hinges with large, alternating coefficients can fit the smooth window
means closely, while the same coefficients, applied to each sample as the compensation
does, add that jitter, amplified, to the output. On window means such a model looks
better than it is; per sample, it can be far worse than none (sixteen hinges of the
rate: 0.72 against 58 mg² x 1e6 on one axis of a 2 h session).

A model is *rough* when a bound of its moves inside windows is above :data:`SCREEN` of
the response's own deviations there: the moves are at most ``sum_j |b_j| s_j`` in norm,
``s_j`` the roughness of column ``j`` (its second differences inside windows, which a
smooth column has almost none of, scaled to a spread) and ``b_j`` its largest
coefficient over the folds. :func:`alike` scores a set of models the same way: per
sample when one of them is rough (each block's error gains ``sum w (g^2 - 2 r g)``,
``g`` the model's fitted values less their window mean, with the coefficients of the
fold that held the block out, ``r`` the response's deviation from its window mean:
the block's error is then the sum of the weighted squared per-sample held-out
residuals), else on window means, as before.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from accelcore.model import AXES, Term

from .engine import Engine
from .fits import CV, fold_coefficients

__all__ = [
    "ROUGH_STRIDE",
    "SCREEN",
    "alike",
    "excess",
    "heldout_window_residuals",
    "is_rough",
    "per_sample",
]

FloatArray = NDArray[np.float64]

#: Largest share of an axis' deviations inside windows (its per-sample noise, mostly)
#: that the bound of a model's moves inside windows may reach for its window-level
#: figures to stand: below it, the per-sample error differs from them by less than
#: this share, far from the least improvement a candidate needs.
SCREEN = 1e-3

#: The screen's roughness is estimated from every this-many-th second difference.
ROUGH_STRIDE = 4


def _fold_beta(eng: Engine, axis: str, terms: Sequence[Term]) -> FloatArray | None:
    """Coefficients of the fit that held each fold out, one row per fold (None: no column)."""
    held = eng._heldout_of(axis, terms)
    return None if held is None else fold_coefficients(held, eng.n_folds)[1]


def _roughness(eng: Engine, key: tuple[object, str | None]) -> float:
    """Return a column's spread inside windows beyond a smooth move (second differences).

    For independent jitter of standard deviation ``s``, a second difference has
    variance ``6 s^2``; a straight line has none. A gain column's gravity is constant in
    a window: the basis' roughness times the largest gravity.
    """
    cache: dict[object, float] = eng.__dict__.setdefault("_inside_rough", {})
    if key in cache:
        return cache[key]
    basis, source = key
    found = cache.get(basis)
    if found is None:
        weight = eng.__dict__.get("_inside_weight")
        if weight is None:
            # Every ROUGH_STRIDE-th second difference (an estimate of the sum of all),
            # counted where its three samples share a window.
            win, w = eng.sample_window, eng.w
            m = (eng.n - 2 + ROUGH_STRIDE - 1) // ROUGH_STRIDE
            lo, mid, hi = (slice(k, k + ROUGH_STRIDE * m, ROUGH_STRIDE) for k in range(3))
            inside = (win[lo] == win[hi]) & (w[lo] > 0) & (w[hi] > 0)
            weight = np.where(inside, w[mid], 0.0) * (ROUGH_STRIDE / 6.0)
            eng.__dict__["_inside_weight"] = weight
        x = eng.basis(basis)  # type: ignore[arg-type]
        m = weight.size
        step = ROUGH_STRIDE
        second = x[0 : step * m : step] - 2.0 * x[1 : 1 + step * m : step]
        second += x[2 : 2 + step * m : step]
        found = math.sqrt(float(np.dot(weight, second * second)))
        cache[basis] = found
    if source is not None:
        found *= float(np.abs(eng.gravity[:, AXES.index(source)]).max())
    cache[key] = found
    return found


def heldout_window_residuals(eng: Engine, axis: str, terms: Sequence[Term]) -> FloatArray:
    """Return each window's mean residual under the fit that held its fold out, mg.

    The window-level half of the engine's held-out error: the weighted squares of
    these, summed per block, plus each block's deviations of the samples about their
    window means, are :meth:`Engine.cv`'s ``sse_blocks``.
    """
    y = eng._yc[axis]
    held = eng._heldout_of(axis, terms)
    if held is None:
        return y.copy()
    keys = eng._keys(axis, terms)
    _, beta = fold_coefficients(held, eng.n_folds)
    per_window = beta[eng.block_fold[eng.window_block]]
    fitted = np.zeros_like(y)
    for j, key in enumerate(keys):
        fitted += eng._window_column(key) * per_window[:, j]
    return y - fitted


def is_rough(eng: Engine, axis: str, terms: Sequence[Term]) -> bool:
    """Tell whether a model's moves inside windows may matter (the screen of the module)."""

    def screen() -> bool:
        beta = _fold_beta(eng, axis, terms)
        if beta is None:
            return False
        keys = eng._keys(axis, terms)
        largest = np.abs(beta).max(axis=0)
        bound = sum(float(b) * _roughness(eng, k) for b, k in zip(largest, keys, strict=True))
        return bound * bound > SCREEN * eng._within_total[axis]

    return eng.kept("_inside_is_rough", (axis, tuple(terms)), screen, 4 * eng.memo_size)


def excess(eng: Engine, axis: str, terms: Sequence[Term]) -> FloatArray:
    """Per block, what a model's moves inside windows add to its held-out error (kept)."""

    def make() -> FloatArray:
        fit = eng.fit(axis, terms)
        if not fit.columns:
            return np.zeros(eng.block_start.size)
        # The response's deviation from its window mean (r), and the fitted values' (g,
        # each sample with its fold's coefficients): the held-out residual per sample less
        # the window's, taken from r.
        win = eng.sample_window
        r = eng.y[axis] - eng._yc[axis][win]
        r_out = eng.heldout_residuals(eng.y[axis], fit)
        g = r - (r_out - heldout_window_residuals(eng, axis, terms)[win])
        return np.bincount(
            eng.sample_block, weights=eng.w * g * (g - 2.0 * r), minlength=eng.block_start.size
        ).astype(np.float64)

    return eng.kept("_inside_excess", (axis, tuple(terms)), make)


def per_sample(eng: Engine, axis: str, cv: CV) -> CV:
    """``cv`` with its held-out error per sample (itself when it already is)."""
    if cv.per_sample:
        return cv
    sse_blocks = cv.sse_blocks + excess(eng, axis, cv.terms)
    return replace(
        cv,
        sse_blocks=sse_blocks,
        rms_out=math.sqrt(float(sse_blocks.sum()) / eng._wsum),
        per_sample=True,
    )


def alike(eng: Engine, axis: str, cvs: Sequence[CV]) -> tuple[list[CV], bool]:
    """Score models to be compared the same way: per sample if one is rough or is already.

    Returns the models' figures and whether they are per sample.
    """
    exact = any(cv.per_sample or is_rough(eng, axis, cv.terms) for cv in cvs)
    if not exact:
        return list(cvs), False
    return [per_sample(eng, axis, cv) for cv in cvs], True
