"""Shared hypothesis strategies for the kernel property tests.

Hypothesis draws the *structure* of each case (sizes, configuration, where the
chunks split, how much is NaN, how collinear a design is) plus a seed; the bulk
float values come from a NumPy generator seeded by it. This keeps 300-example
CI runs fast while every failing case still shrinks to a small, reproducible
example (the seed is part of it).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from hypothesis import strategies as st
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

#: Values that make a row non-finite.
NON_FINITE = (np.nan, np.inf, -np.inf)

seeds = st.integers(min_value=0, max_value=2**32 - 1)


# --------------------------------------------------------------------------- chunking


@st.composite
def chunk_bounds(draw: st.DrawFn, n: int, max_cuts: int = 8) -> list[int]:
    """Sorted cut positions ``0 = b0 <= b1 <= ... <= bk = n``.

    Consecutive equal cuts give empty chunks and cuts one apart give 1-row
    chunks; both are drawn on purpose, as are a first or last chunk of 0 rows.
    """
    cuts = draw(st.lists(st.integers(0, n), max_size=max_cuts))
    extra: list[int] = []
    for cut in cuts:
        # 0: leave alone, 1: duplicate (empty chunk), 2: neighbour (1-row chunk)
        kind = draw(st.integers(0, 2))
        if kind == 1:
            extra.append(cut)
        elif kind == 2:
            extra.append(min(cut + 1, n))
    return [0, *sorted(cuts + extra), n]


def chunks(bounds: list[int], *arrays: FloatArray) -> Iterator[tuple[FloatArray, ...]]:
    """Slice every array (along axis 0) at ``bounds``."""
    for start, stop in itertools.pairwise(bounds):
        yield tuple(array[start:stop] for array in arrays)


@st.composite
def pieces(draw: st.DrawFn, n: int, max_pieces: int = 4) -> list[int]:
    """Cut positions splitting ``n`` rows into 1..``max_pieces`` contiguous pieces."""
    k = draw(st.integers(1, max_pieces))
    cuts = draw(st.lists(st.integers(0, n), min_size=k - 1, max_size=k - 1))
    return [0, *sorted(cuts), n]


# --------------------------------------------------------------------------- sensor streams


@dataclass(frozen=True)
class Stream:
    """Rows of (time, temperature, channels) as pushed to a kernel."""

    time_s: FloatArray
    temperature_c: FloatArray
    channels: FloatArray

    @property
    def n(self) -> int:
        """Number of rows."""
        return int(self.time_s.shape[0])

    def arrays(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The three arrays, in ``push`` argument order."""
        return self.time_s, self.temperature_c, self.channels


def _inject_non_finite(
    rng: np.random.Generator, columns: list[FloatArray], fraction: float
) -> None:
    """Overwrite about ``fraction`` of the rows of each column with NaN or ±inf."""
    if fraction == 0:
        return
    for column in columns:
        hit = rng.random(column.shape) < fraction
        column[hit] = rng.choice(NON_FINITE, size=int(hit.sum()))


non_finite_fractions = st.sampled_from([0.0, 0.0, 0.02, 0.1, 0.5])


@dataclass(frozen=True)
class DecimatorCase:
    """A decimator configuration, a stream and a chunking of it."""

    config: dict[str, Any]
    stream: Stream
    bounds: list[int]


@st.composite
def decimator_cases(draw: st.DrawFn, max_rows: int = 120) -> DecimatorCase:
    """Streams sampled at a nominal rate with jitter, gaps and non-finite values.

    ``t0_s`` is ``None`` or a value near the first sample (possibly after it,
    which gives negative block indices).
    """
    rng = np.random.default_rng(draw(seeds))
    n = draw(st.integers(0, max_rows))
    n_channels = draw(st.integers(1, 4))
    rate_hz = draw(
        st.sampled_from([1.0, 20.0, 25.6, 100.0, 3.3])
        | st.floats(0.5, 500.0, allow_nan=False, allow_infinity=False)
    )
    factor = draw(st.integers(1, 15))
    min_count = draw(st.integers(1, 4))
    jitter = draw(st.sampled_from([0.0, 0.1, 0.45]))  # of one sample period
    gap_probability = draw(st.sampled_from([0.0, 0.02, 0.2]))
    t_start = draw(st.sampled_from([0.0, -3.7, 12345.678, 86400.0 * 3]))

    period = 1.0 / rate_hz
    step = period * (1.0 + jitter * rng.uniform(-1.0, 1.0, n))
    gaps = rng.random(n) < gap_probability
    step[gaps] *= rng.uniform(1.0, 40.0, int(gaps.sum()))
    time_s = t_start + np.cumsum(step)
    temperature_c = 25.0 + 60.0 * np.sin(time_s / 500.0) + rng.normal(0.0, 0.05, n)
    offset = draw(st.sampled_from([0.0, 16384.0, -1000.0]))
    channels = offset + rng.normal(0.0, 50.0, (n, n_channels))
    _inject_non_finite(rng, [time_s, temperature_c], draw(non_finite_fractions))
    for c in range(n_channels):
        column = channels[:, c]  # a view: injection writes through
        _inject_non_finite(rng, [column], draw(non_finite_fractions) / 2)

    t0_s: float | None = None
    if draw(st.booleans()):
        block_s = factor * period
        t0_s = t_start + draw(st.floats(-5.0, 2.0)) * block_s
    config = {
        "factor": factor,
        "rate_hz": rate_hz,
        "n_channels": n_channels,
        "min_count": min_count,
        "t0_s": t0_s,
    }
    bounds = draw(chunk_bounds(n))
    return DecimatorCase(config, Stream(time_s, temperature_c, channels), bounds)


@dataclass(frozen=True)
class BinnerCase:
    """A binner configuration, a stream and a chunking of it."""

    config: dict[str, Any]
    stream: Stream
    bounds: list[int]


@st.composite
def binner_configs(draw: st.DrawFn) -> dict[str, Any]:
    """Windows of 1..40 widths, sometimes not a whole number of widths."""
    lo_c = draw(st.sampled_from([-40.0, 0.0, 12.5]) | st.floats(-60.0, 60.0))
    width_c = draw(st.sampled_from([0.1, 0.25, 0.3, 0.5, 1.0, 2.0, 5.0]) | st.floats(0.01, 10.0))
    n_whole = draw(st.integers(1, 40))
    remainder = draw(st.sampled_from([0.0, 0.0, 0.5]) | st.floats(0.0, 0.999))
    hi_c = lo_c + (n_whole + remainder) * width_c
    return {"lo_c": lo_c, "hi_c": hi_c, "width_c": width_c, "n_channels": draw(st.integers(1, 4))}


@st.composite
def binner_cases(draw: st.DrawFn, max_rows: int = 150) -> BinnerCase:
    """Temperatures spread over and around the window; some sit exactly on edges."""
    config = draw(binner_configs())
    rng = np.random.default_rng(draw(seeds))
    n = draw(st.integers(0, max_rows))
    lo_c, hi_c, width_c = config["lo_c"], config["hi_c"], config["width_c"]
    margin = draw(st.sampled_from([0.0, 0.1, 0.5])) * (hi_c - lo_c)
    temperature_c = rng.uniform(lo_c - margin, hi_c + margin, n)
    # Snap some rows to the exact edges the kernels compute, to hi_c and to the
    # float just below hi_c: the [lo, hi) closure is decided there.
    n_bins = int(np.ceil((hi_c - lo_c) / width_c - 1e-9))
    edges = lo_c + np.arange(n_bins) * width_c
    specials = np.concatenate([edges, [hi_c, np.nextafter(hi_c, -np.inf), lo_c]])
    snap = rng.random(n) < draw(st.sampled_from([0.0, 0.1, 0.5]))
    temperature_c[snap] = rng.choice(specials, size=int(snap.sum()))
    time_s = np.cumsum(rng.uniform(0.01, 1.0, n)) + 1000.0
    offset = draw(st.sampled_from([0.0, 16000.0, -300.0]))
    spread = draw(st.sampled_from([1.0, 1e-3, 100.0]))
    n_channels = config["n_channels"]
    channels = offset + spread * rng.normal(size=(n, n_channels))
    _inject_non_finite(rng, [time_s, temperature_c], draw(non_finite_fractions))
    for c in range(n_channels):
        _inject_non_finite(rng, [channels[:, c]], draw(non_finite_fractions) / 2)
    bounds = draw(chunk_bounds(n))
    return BinnerCase(config, Stream(time_s, temperature_c, channels), bounds)


# --------------------------------------------------------------------------- regression


@dataclass(frozen=True)
class RegressionCase:
    """A weighted least-squares problem and a chunking of its rows."""

    design: FloatArray
    response: FloatArray
    weights: FloatArray | None
    bounds: list[int]
    column_names: list[str] = field(default_factory=list)
    #: Names of the columns built as exact combinations of earlier ones.
    dependent: list[str] = field(default_factory=list)

    @property
    def n_columns(self) -> int:
        """Number of columns ``p``."""
        return int(self.design.shape[1])


def _weights(draw: st.DrawFn, rng: np.random.Generator, n: int) -> FloatArray | None:
    kind = draw(st.sampled_from(["none", "uniform", "integer", "with_zeros"]))
    if kind == "none":
        return None
    if kind == "integer":
        return rng.integers(0, 4, n).astype(np.float64)
    weights = rng.uniform(0.05, 5.0, n)
    if kind == "with_zeros":
        weights[rng.random(n) < 0.3] = 0.0
    return weights


@st.composite
def regression_cases(draw: st.DrawFn, max_rows: int = 60) -> RegressionCase:
    """Random full-rank designs: mixed column scales, offsets and near-collinear pairs.

    A near-collinear column is ``a * earlier + delta * rms(earlier) * noise``
    with ``delta >= 1e-6``, so that its component orthogonal to the earlier
    columns stays at least ~1e-6 of its norm: four orders of magnitude above
    the 1e-10 rank threshold, so both implementations agree it is identifiable.
    """
    rng = np.random.default_rng(draw(seeds))
    p = draw(st.integers(1, 6))
    n = draw(st.integers(0, max_rows))
    columns: list[FloatArray] = []
    for j in range(p):
        kind = draw(st.sampled_from(["intercept", "normal", "offset", "near_collinear"]))
        scale = 10.0 ** draw(st.floats(-3.0, 3.0))
        if kind == "intercept":
            column = np.full(n, scale)
        elif kind == "normal" or not columns:
            column = scale * rng.normal(size=n)
        elif kind == "offset":
            column = scale * (rng.normal(size=n) + draw(st.sampled_from([10.0, 1e3])))
        else:
            earlier = columns[draw(st.integers(0, j - 1))]
            delta = draw(st.sampled_from([1e-6, 1e-4, 1e-2]))
            rms = float(np.sqrt(np.mean(earlier**2))) if n else 0.0
            column = rng.uniform(-3.0, 3.0) * earlier + delta * rms * rng.normal(size=n)
        columns.append(column)
    design = np.column_stack(columns) if n else np.empty((0, p))
    # Coefficients of order 1 / column rms, so every column contributes to the signal.
    column_rms = np.sqrt(np.mean(design**2, axis=0)) if n else np.ones(p)
    signal = design @ (rng.normal(size=p) / column_rms)
    # Noise keeps the residual clearly above rounding level, so the residual
    # sum of squares (and with it the covariance) is well defined to compare.
    relative_noise = draw(st.sampled_from([1e-3, 0.1, 1.0]))
    signal_rms = float(np.sqrt(np.mean(signal**2))) if n else 1.0
    response = signal + relative_noise * signal_rms * rng.normal(size=n)
    weights = _weights(draw, rng, n)
    names = draw(st.sampled_from([[f"x{j}" for j in range(p)], [f"col_{j}" for j in range(p)]]))
    return RegressionCase(design, response, weights, draw(chunk_bounds(n)), names)


@st.composite
def collinear_cases(draw: st.DrawFn) -> RegressionCase:
    """Designs with exactly dependent columns inserted among independent ones.

    A dependent column is zero or a small-integer combination of earlier
    independent columns; its name is listed in ``dependent``.
    """
    rng = np.random.default_rng(draw(seeds))
    n_independent = draw(st.integers(1, 4))
    n_dependent = draw(st.integers(1, 3))
    n = draw(st.integers(n_independent + n_dependent, 50))
    kinds = draw(st.permutations(["i"] * n_independent + ["d"] * n_dependent))
    columns: list[FloatArray] = []
    names: list[str] = []
    dependent: list[str] = []
    independent: list[FloatArray] = []
    for j, kind in enumerate(kinds):
        name = f"c{j}"
        if kind == "d":
            if not independent or draw(st.integers(0, 4)) == 0:
                column = np.zeros(n)
            else:
                multipliers = draw(
                    st.lists(
                        st.integers(-3, 3), min_size=len(independent), max_size=len(independent)
                    )
                )
                if not any(multipliers):
                    multipliers[0] = 1
                column = sum(
                    (m * c for m, c in zip(multipliers, independent, strict=True)), np.zeros(n)
                )
            dependent.append(name)
        else:
            column = 10.0 ** draw(st.floats(-2.0, 2.0)) * rng.normal(size=n)
            independent.append(column)
        columns.append(column)
        names.append(name)
    design = np.column_stack(columns)
    response = design @ rng.normal(size=design.shape[1]) + rng.normal(size=n)
    weights = None if draw(st.booleans()) else rng.uniform(0.5, 2.0, n)
    return RegressionCase(design, response, weights, draw(chunk_bounds(n)), names, dependent)
