"""Data-quality checks of a loaded session: what deserves a look before calibrating.

:func:`check_session` inspects what the reader counted in each raw log
(:class:`accelcore.input.session.RunStats`) and the decimated output, and returns one
:class:`QualityIssue` per finding, each with a message that says what was seen
and, where it applies, what data would fix it. With ``warn=True`` (the
default) each issue is also emitted as an :class:`accelcore.errors.DataQualityWarning`.

Checks
------
``rate``
    The mean raw sample rate differs from ``rate_hz`` by more than ``rate_tolerance``.
``gaps``
    Intervals between raw rows longer than 1.5 nominal periods (blocks stay aligned).
``nonfinite``
    Rows skipped because a value was NaN, infinite or empty (counted per run and in all).
``truncated``
    A last line cut off mid-write was dropped.
``clipping``
    Many raw samples at exactly one extreme value of a channel: output at the rails.
``outliers``
    Decimated blocks far from a running median (robust z-score), i.e. spikes.
``step``
    A persistent level change in the static output (the sensor moved), with its time.
``temperature``
    The logged temperature does not cover the analysis window, or too few
    temperature bins hold data of both orientations of an axis.
``short``
    A run covers much less of the temperature range than the other runs (a log
    cut short; the pieces of one log stored in several files count as one run,
    see :func:`accelcore.input.records.records`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from accelcore._accelcore import (
    block_noise,
    fingerprint,
    robust_sigma,
    running_median,
    sliding_median,
)
from accelcore.constants import AXES
from accelcore.errors import DataQualityWarning
from accelcore.input.levels import level_grid, quantiser_sigma
from accelcore.input.pinned import pinned_mask, pinned_stretches, pinned_text
from accelcore.input.records import records
from accelcore.input.session import Run, Session
from accelcore.input.temperature_units import other_unit_runs

__all__ = ["QualityIssue", "check_session", "excluded_blocks"]

IntArray = NDArray[np.int64]

#: Temperature span, °C, the other runs must have for a run to be called short.
SHORT_MIN_SPAN_C = 2.0


@dataclass(frozen=True)
class QualityIssue:
    """One finding of :func:`check_session`.

    Attributes
    ----------
    kind : str
        ``rate``, ``gaps``, ``nonfinite``, ``truncated``, ``clipping``,
        ``outliers``, ``step``, ``temperature``, ``temperature_pinned`` or ``short``.
    message : str
        What was seen and what to do about it.
    run : str or None
        Label of the run (its file name), or None for a session-wide finding.
    channel : str or None
        The channel concerned, if one.
    time_s : float or None
        When it happened (run time, s), for ``step`` and the first of ``outliers``.
    count : int or None
        How many rows, blocks or bins, where that is the measure.
    """

    kind: str
    message: str
    run: str | None = None
    channel: str | None = None
    time_s: float | None = None
    count: int | None = None


def check_session(
    session: Session,
    *,
    rate_tolerance: float = 0.1,
    clip_fraction: float = 0.002,
    clip_min_samples: int = 20,
    clip_min_blocks: int = 3,
    outlier_z: float = 8.0,
    outlier_window: int = 9,
    step_z: float = 12.0,
    step_window: int = 20,
    window_c: tuple[float, float] | Literal["logged"] | None = "logged",
    bin_width_c: float = 0.5,
    min_bins: int = 3,
    short_fraction: float = 0.5,
    warn: bool = True,
) -> list[QualityIssue]:
    """Check a session for data problems; return (and by default warn about) each.

    Parameters
    ----------
    session : Session
        From :func:`accelcore.load_session` or :meth:`Session.from_arrays`.
    rate_tolerance : float, default 0.1
        Relative difference of the mean raw rate from ``rate_hz`` that is reported.
    clip_fraction, clip_min_samples, clip_min_blocks : float, int, int
        A channel is reported as clipped when at least ``clip_min_samples`` and
        ``clip_fraction`` of its raw rows sit exactly at its minimum or maximum,
        and at least ``clip_min_blocks`` decimated blocks lie wholly on that value,
        unless the channel's output levels are coarser than its noise (a quantiser
        whose step exceeds the noise holds every code for whole blocks, its
        extremes too; a rail on such a channel is not told from its codes).
    outlier_z, outlier_window : float, int
        A decimated block whose robust z-score against a running median of
        ``outlier_window`` blocks exceeds ``outlier_z`` is an outlier (a block of
        fewer samples than a full one, at a gap's edge, scaled to a full block's
        noise; on a channel coarser than its noise, the noise is taken as at least
        the quantiser's, step/sqrt(12), so a block crossing to the next code is none).
    step_z, step_window : float, int
        A step is a jump between the medians of the ``step_window`` blocks
        after and before a point, less the local drift (from the neighbouring
        windows), whose robust z-score exceeds ``step_z``.
    window_c : (float, float), "logged" or None, default "logged"
        Analysis window (as in :func:`accelcore.calibrate`); ``"logged"`` (the
        default of :func:`accelcore.calibrate`): the logged range, so only the
        bins holding both orientations of an axis are checked; None skips the
        temperature checks. A session that logged no temperature has none.
    bin_width_c : float, default 0.5
        Temperature bin width, °C (as in :func:`accelcore.calibrate`).
    min_bins : int, default 3
        Fewest bins holding both orientations of an axis that a fit needs.
    short_fraction : float, default 0.5
        A run whose temperature span is less than this fraction of the median
        span of the other runs (when that median is at least
        :data:`SHORT_MIN_SPAN_C`) is reported as ``short``.
    warn : bool, default True
        Also emit each issue as a :class:`~accelcore.errors.DataQualityWarning`.

    Returns
    -------
    list of QualityIssue
        Empty when nothing was found.
    """
    issues: list[QualityIssue] = []
    total_nonfinite = 0
    for run in session.runs:
        issues += _check_rate_and_gaps(run, session.rate_hz, rate_tolerance)
        total_nonfinite += run.stats.n_skipped_nonfinite
        issues += _check_counts(run)
        issues += _check_clipping(run, clip_fraction, clip_min_samples, clip_min_blocks)
        issues += [  # a temperature probe at its rail (:mod:`accelcore.input.pinned`)
            QualityIssue(
                "temperature_pinned", pinned_text(run, p), run=run.label, count=p[1] - p[0]
            )
            for p in pinned_stretches(run)
        ]
        for a, axis in enumerate(AXES):
            if len(run) == 0:
                continue
            y = np.asarray(run.output[:, a], dtype=np.float64)
            issues += _check_outliers(run, axis, outlier_z, outlier_window)
            issues += _check_steps(run, axis, y, step_z, step_window)
    if total_nonfinite:
        issues.append(
            QualityIssue(
                "nonfinite",
                f"{total_nonfinite} rows skipped in all runs (NaN, infinite or empty values)",
                count=total_nonfinite,
            )
        )
    if window_c == "logged":
        window_c = _logged_range(session)
    if window_c is not None and session.has_temperature:
        issues += _check_temperature(session, window_c, bin_width_c, min_bins)
    issues += [
        QualityIssue("temperature", text, run=run.label)
        for run, text in other_unit_runs(session.runs)
    ]
    issues += _check_short_runs(session, short_fraction)
    if warn:
        for issue in issues:
            where = f"{issue.run}: " if issue.run else ""
            warnings.warn(f"{where}{issue.message}", DataQualityWarning, stacklevel=2)
    return issues


def _check_rate_and_gaps(run: Run, rate_hz: float, tolerance: float) -> list[QualityIssue]:
    stats = run.stats
    out: list[QualityIssue] = []
    rate = stats.mean_rate_hz
    intervals = max(stats.n_rows - 1, 0)
    rate_off = math.isfinite(rate) and abs(rate / rate_hz - 1.0) > tolerance
    if rate_off:
        hint = (
            "; check rate_hz and time_unit in session.toml"
            if stats.n_gaps < 0.5 * intervals
            else "; nearly every interval is longer than 1.5 periods: the log is slower "
            "than rate_hz, or time_unit is wrong"
        )
        out.append(
            QualityIssue(
                "rate",
                f"mean sample rate {rate:.6g} Hz differs from rate_hz = {rate_hz:g} Hz "
                f"by {100 * (rate / rate_hz - 1):+.0f} %{hint}",
                run=run.label,
                count=stats.n_rows,
            )
        )
    if stats.n_gaps and not (rate_off and stats.n_gaps >= 0.5 * intervals):
        out.append(
            QualityIssue(
                "gaps",
                f"{stats.n_gaps} gap(s) in the log (intervals > 1.5 periods), longest "
                f"{stats.max_interval_s:.6g} s; blocks stay on the time grid",
                run=run.label,
                count=stats.n_gaps,
            )
        )
    return out


def _check_counts(run: Run) -> list[QualityIssue]:
    stats = run.stats
    out: list[QualityIssue] = []
    if stats.n_skipped_nonfinite:
        share = stats.n_skipped_nonfinite / max(stats.n_rows, 1)
        out.append(
            QualityIssue(
                "nonfinite",
                f"{stats.n_skipped_nonfinite} of {stats.n_rows} rows ({100 * share:.3g} %) "
                "skipped: a NaN, infinite or empty value",
                run=run.label,
                count=stats.n_skipped_nonfinite,
            )
        )
    if stats.n_truncated_rows:
        out.append(
            QualityIssue(
                "truncated",
                "the last line was cut off mid-write and dropped",
                run=run.label,
                count=stats.n_truncated_rows,
            )
        )
    return out


def _channel_names(run: Run) -> list[str]:
    return list(AXES) + list(run.extras)


def _check_clipping(
    run: Run, fraction: float, min_samples: int, min_blocks: int
) -> list[QualityIssue]:
    stats = run.stats
    out: list[QualityIssue] = []
    if stats.n_rows == 0 or stats.n_at_min.size == 0 or len(run) == 0:
        return out
    threshold = max(float(min_samples), fraction * stats.n_rows)
    names = _channel_names(run)
    for c in range(min(3, stats.n_at_min.size)):
        lo, hi = float(stats.channel_min[c]), float(stats.channel_max[c])
        if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
            continue
        for which, value, n in (
            ("minimum", lo, int(stats.n_at_min[c])),
            ("maximum", hi, int(stats.n_at_max[c])),
        ):
            # A pile-up at the extreme, and whole blocks sitting on it: a rail, not
            # the tail of quantised noise. The blocks are only counted for a pile-up.
            if n < threshold:
                continue
            on_rail = np.abs(run.output[:, c] - value) <= 1e-12 * max(1.0, abs(value))
            if int(np.count_nonzero(on_rail)) >= min_blocks and not _coarse_levels(run, c):
                out.append(
                    QualityIssue(
                        "clipping",
                        f"channel {names[c]}: {n} of {stats.n_rows} raw samples "
                        f"({100 * n / stats.n_rows:.3g} %) sit exactly at the {which} "
                        f"{value:.9g}: output clipped at the rail; exclude them or reduce "
                        "the range (gain, supply, orientation)",
                        run=run.label,
                        channel=names[c],
                        count=n,
                    )
                )
    return out


def _coarse_levels(run: Run, c: int, window: int = 9) -> bool:
    """Whether channel ``c`` sits on output levels coarser than its own noise.

    Coarse: the grid of the block means (:func:`accelcore.input.levels.level_grid`)
    is at least the blocks' robust noise (:func:`_block_noise`); on a part whose noise
    spans several codes it is a fraction of it. Such a channel holds every code for
    whole blocks, its extremes too: a pile-up there is not a rail.
    """
    grid = level_grid(run.output[:, c], run.count)
    if grid is None:
        return True
    if len(run) < 2 * window:
        return False
    return grid >= _block_noise(run, c, window)[1]


def _block_noise(run: Run, c: int, window: int) -> tuple[NDArray[np.float64], float]:
    """Channel ``c``'s residual about a running median of ``window`` blocks, and its robust sigma.

    A block of fewer samples than most (the edge of a gap, a run's ends) is that much
    noisier, one of more that much quieter: each residual is scaled to the typical
    block's noise (:func:`accelcore.input.levels.typical_count`).
    """
    resid, sigma = block_noise(run.output[:, c], run.count, window=window)
    return resid, sigma


def _running_median(y: NDArray[np.float64], window: int) -> NDArray[np.float64]:
    """Centred running median, ends padded by reflection (Rust; twin of the reference's)."""
    return running_median(y, window=window)


def _robust_sigma(r: NDArray[np.float64]) -> float:
    """Robust standard deviation of ``r``: MAD, else mean absolute deviation, else 0 (core)."""
    return robust_sigma(r)


def _check_outliers(run: Run, axis: str, z_max: float, window: int) -> list[QualityIssue]:
    if len(run) < 2 * window:
        return []
    bad, worst = _spikes(run, AXES.index(axis), window, z_max)
    if bad.size == 0:
        return []
    first = float(run.time_s[bad[0]])
    return [
        QualityIssue(
            "outliers",
            f"axis {axis}: {bad.size} decimated block(s) are spikes (robust z up to "
            f"{worst:.3g}, first at t = {first:.6g} s); the fit's robust weights "
            "limit their effect",
            run=run.label,
            channel=axis,
            time_s=first,
            count=int(bad.size),
        )
    ]


#: Spikes found per channel content (its :func:`fingerprint`), window and threshold: the quality
#: check and the weights of every fit of a run ask for the same ones.
_SPIKES: dict[tuple[int, int, float], tuple[IntArray, float]] = {}
_SPIKES_KEPT = 256


def forget_spikes() -> None:
    """Forget the spikes kept per channel content (a first contact with data, as in a benchmark)."""
    _SPIKES.clear()


def _spikes(run: Run, c: int, window: int, z_max: float) -> tuple[IntArray, float]:
    """Spikes of channel ``c``: blocks whose robust z exceeds ``z_max``, and the largest z.

    The z-score is against a running median of ``window`` blocks; 0 when none.
    """
    y = np.ascontiguousarray(run.output[:, c], dtype=np.float64)
    key = (fingerprint(y, run.count), window, z_max)
    found = _SPIKES.get(key)
    if found is None:
        resid, sigma = _block_noise(run, c, window)
        bad = np.flatnonzero(np.abs(resid) > z_max * sigma) if sigma > 0.0 else np.zeros(0, int)
        grid = level_grid(y, run.count) if bad.size else None
        if grid is not None and grid >= sigma:
            # Coarse codes (`_coarse_levels`): a block that crosses to the next code is
            # no spike; the noise is at least the quantiser's own.
            sigma = max(sigma, quantiser_sigma(grid, run.count))
            bad = np.flatnonzero(np.abs(resid) > z_max * sigma)
        # A Python float: inf, not a warning.
        worst = float(np.max(np.abs(resid[bad]))) / sigma if bad.size else 0.0
        bad = bad.astype(np.int64)
        bad.flags.writeable = False
        found = (bad, worst)
        if len(_SPIKES) >= _SPIKES_KEPT:
            _SPIKES.clear()
        _SPIKES[key] = found
    return found


def _check_steps(
    run: Run, axis: str, y: NDArray[np.float64], z_min: float, window: int
) -> list[QualityIssue]:
    """Find persistent level changes: median after minus median before each point."""
    n = y.shape[0]
    if n < 5 * window:
        return []
    # The noise of one block, from first differences (insensitive to slow drift and
    # to a few steps); its floor is the output resolution.
    d = np.diff(y)
    sigma = _robust_sigma(d) / math.sqrt(2.0)
    nonzero = np.abs(d[d != 0])
    if nonzero.size:
        sigma = max(sigma, float(nonzero.min()))
    if sigma == 0.0:
        return []
    w = window
    medians = sliding_median(y, window=w)  # medians[j] = np.median(y[j : j + w])
    # For a boundary i (first block after a possible step), with the window medians
    # M-2, M-1 before and M0, M1 after it: D = (M0 - M-1) - ((M1 - M0) + (M-1 - M-2)) / 2,
    # the jump minus the local drift. D = h for a step h and 0 for a linear drift
    # (temperature ramps), so only abrupt changes count.
    m_b2, m_b1 = medians[: -3 * w], medians[w : -2 * w]
    m_a0, m_a1 = medians[2 * w : -w], medians[3 * w :]
    jump = 1.5 * (m_a0 - m_b1) - 0.5 * (m_a1 - m_b2)  # index k <-> boundary i = k + 2w
    # Standard error: a median of w normal samples has sd sqrt(pi/2) sigma / sqrt(w);
    # D weighs four independent medians by 1.5, 1.5, 0.5, 0.5.
    se = math.sqrt(5.0) * math.sqrt(math.pi / 2) * sigma / math.sqrt(w)
    z = np.abs(jump) / se
    # Only where the 4w blocks are contiguous in time: across a gap, drift is a jump.
    dt = np.diff(np.asarray(run.time_s, dtype=np.float64))
    if dt.size:
        gap = np.concatenate([[0], np.cumsum(dt > 1.5 * float(np.median(dt)))])
        first = np.arange(z.shape[0])
        z[gap[first + 4 * w - 1] != gap[first]] = 0.0
    out: list[QualityIssue] = []
    # Peaks above the threshold, strongest first; a kept peak masks +-2w around it
    # (the filter's side lobes).
    candidates = np.flatnonzero(z > z_min)
    kept: list[int] = []
    for k in candidates[np.argsort(-z[candidates], kind="stable")]:
        if all(abs(int(k) - j) > 2 * w for j in kept):
            kept.append(int(k))
        if len(kept) == 10:
            break
    for k in sorted(kept):
        i = k + 2 * w
        t = 0.5 * float(run.time_s[i - 1] + run.time_s[i])
        out.append(
            QualityIssue(
                "step",
                f"axis {axis}: the static output steps by {float(jump[k]):+.6g} "
                f"(robust z {float(z[k]):.3g}) at t = {t:.6g} s: the sensor moved "
                "during the run; cut the run there or re-log it",
                run=run.label,
                channel=axis,
                time_s=t,
            )
        )
    return out


def _logged_range(session: Session) -> tuple[float, float] | None:
    """Lowest and highest finite logged temperature, or None when none was logged."""
    temps = [r.temperature_c[np.isfinite(r.temperature_c)] for r in session.runs]
    temps = [t for t in temps if t.size]
    if not temps:
        return None
    return min(float(t.min()) for t in temps), max(float(t.max()) for t in temps)


def _check_temperature(
    session: Session, window_c: tuple[float, float], bin_width_c: float, min_bins: int
) -> list[QualityIssue]:
    lo_c, hi_c = float(window_c[0]), float(window_c[1])
    temps = [r.temperature_c[np.isfinite(r.temperature_c)] for r in session.runs]
    temps = [t for t in temps if t.size]
    out: list[QualityIssue] = []
    if not temps:
        return [QualityIssue("temperature", "no finite temperature in any run")]
    seen_lo = min(float(t.min()) for t in temps)
    seen_hi = max(float(t.max()) for t in temps)
    if seen_lo > lo_c + bin_width_c or seen_hi < hi_c - bin_width_c:
        out.append(
            QualityIssue(
                "temperature",
                f"the logged temperature covers {seen_lo:.4g}…{seen_hi:.4g} °C but the "
                f"analysis window is {lo_c:g}…{hi_c:g} °C: log sweeps that reach "
                f"{lo_c:g} and {hi_c:g} °C, or narrow window_c to "
                f"({max(lo_c, seen_lo):.4g}, {min(hi_c, seen_hi):.4g})",
            )
        )
    n_bins = max(1, math.ceil((hi_c - lo_c) / bin_width_c))
    edges = lo_c + bin_width_c * np.arange(n_bins + 1)

    def occupied(runs: list[Run]) -> NDArray[np.bool_]:
        hit = np.zeros(n_bins, dtype=bool)
        for r in runs:
            t = r.temperature_c[(r.temperature_c >= lo_c) & (r.temperature_c < edges[-1])]
            k = np.clip(((t - lo_c) / bin_width_c).astype(np.int64), 0, n_bins - 1)
            hit[k] = True
        return hit

    for a, axis in enumerate(AXES):
        plus = [r for r in session.runs if r.gravity_g[a] > 0 and len(r)]
        minus = [r for r in session.runs if r.gravity_g[a] < 0 and len(r)]
        if not plus or not minus:
            continue
        both = int(np.count_nonzero(occupied(plus) & occupied(minus)))
        if both < min_bins:
            out.append(
                QualityIssue(
                    "temperature",
                    f"axis {axis}: only {both} temperature bin(s) of {bin_width_c:g} °C in "
                    f"{lo_c:g}…{hi_c:g} °C hold both O{axis.upper()}+ and O{axis.upper()}- "
                    f"data; a fit needs at least {min_bins}: log both orientations over a "
                    f"sweep of at least {min_bins * bin_width_c:g} °C inside the window, "
                    "or use narrower bins",
                    channel=axis,
                    count=both,
                )
            )
    return out


def _check_short_runs(session: Session, fraction: float) -> list[QualityIssue]:
    # Records, not files: a log stored in pieces is one run whose pieces are not short.
    spans: list[tuple[Run, float, float] | None] = []
    for run in records(session):
        t = run.temperature_c[np.isfinite(run.temperature_c)]
        spans.append((run, float(t.min()), float(t.max())) if t.size else None)
    out: list[QualityIssue] = []
    for i, entry in enumerate(spans):
        others = [e[2] - e[1] for j, e in enumerate(spans) if j != i and e is not None]
        if entry is None or not others:
            continue
        run, lo, hi = entry
        typical = float(np.median(others))
        if typical >= SHORT_MIN_SPAN_C and hi - lo < fraction * typical:
            out.append(
                QualityIssue(
                    "short",
                    f"covers {lo:.4g}…{hi:.4g} °C, {100 * (hi - lo) / typical:.0f} % of the "
                    f"{typical:.4g} °C the other runs span: the log looks cut short: log the "
                    "whole sweep, or leave the run out",
                    run=run.label,
                    count=len(run),
                )
            )
    return out


def excluded_blocks(
    run: Run,
    *,
    outlier_z: float = 8.0,
    outlier_window: int = 9,
    clip_fraction: float = 0.002,
    clip_min_samples: int = 20,
    clip_min_blocks: int = 3,
) -> tuple[NDArray[np.bool_], int, int]:
    """Decimated blocks a fit should leave out: spikes, rails, a temperature at its rail.

    A temperature pinned at a rail: :mod:`accelcore.input.pinned`.

    A spike is a block of x, y or z whose robust z-score against a running
    median of ``outlier_window`` blocks exceeds ``outlier_z``, its residual scaled to
    a full block's noise where it holds fewer samples (the same test as
    :func:`check_session`; white noise reaches 8 robust sigma about once in
    10^15 blocks, so clean data loses nothing). On a channel that
    :func:`check_session` reports as clipped, every block sitting on the rail and
    its neighbours (which hold partly clipped samples) are left out.

    Returns
    -------
    mask : ndarray of bool
        True for the blocks to leave out.
    n_spikes, n_clipped : int
        How many blocks each reason removed (a pinned temperature counts as clipped).
    """
    n = len(run)
    spikes = np.zeros(n, dtype=bool)
    clipped = np.zeros(n, dtype=bool)
    if n >= 2 * outlier_window:
        for c in range(3):
            spikes[_spikes(run, c, outlier_window, outlier_z)[0]] = True
    for issue in _check_clipping(run, clip_fraction, clip_min_samples, clip_min_blocks):
        c = _channel_names(run).index(issue.channel or "")
        stats = run.stats
        for value in (float(stats.channel_min[c]), float(stats.channel_max[c])):
            on_rail = np.abs(run.output[:, c] - value) <= 1e-12 * max(1.0, abs(value))
            near = on_rail.copy()
            near[1:] |= on_rail[:-1]
            near[:-1] |= on_rail[1:]
            clipped |= near
    clipped |= pinned_mask(run)  # the temperature at its rail: no temperature there
    n_clipped = int(np.count_nonzero(clipped))
    n_spikes = int(np.count_nonzero(spikes & ~clipped))
    return spikes | clipped, n_spikes, n_clipped
