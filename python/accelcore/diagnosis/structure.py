"""The generic structure check: the residual binned by every observable, against its noise.

After the last step, the residual of each axis is binned by temperature, dT/dt,
elapsed time within each run and each extra column; the binned means are compared with
their white-noise standard errors (chi-square). Structure that no added term explains
is reported as a :class:`~accelcore.diagnosis.result.Structure`, naming the observable
(and the period of a periodic structure in time).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from accelcore.constants import MIN_TEMPERATURE_SPAN_C
from accelcore.model import AXES

from .engine import Engine
from .result import Structure
from .stats import chi2_sf

__all__ = ["MIN_TEMPERATURE_SPAN_C", "TEMPERATURE_FAMILIES", "structures", "temperature_span_c"]

# Below MIN_TEMPERATURE_SPAN_C (the foundation's) no temperature-driven effect is
# tried, and structure against temperature or dT/dt is not reported (it would be noise
# in the thermometer, or time seen through a slow wander).

#: Fewest engine windows per bin for the structure check to bin windows rather than
#: samples (:func:`structures`).
MIN_WINDOWS_PER_BIN = 16

#: Effect families driven by temperature.
TEMPERATURE_FAMILIES = ("offset_curvature", "sensitivity_curvature", "thermal_lag", "two_way_lag")


def temperature_span_c(eng: Engine) -> float:
    """Return the span of the engine's temperatures, 5th to 95th percentile, °C (kept)."""

    def span() -> float:
        lo, hi = np.quantile(eng.temperature, [0.05, 0.95])
        return float(hi - lo)

    return eng.kept("_temperature_span_c", None, span)


FloatArray = NDArray[np.float64]


def structures(
    eng: Engine,
    resid: Mapping[str, FloatArray],
    *,
    n_bins: int,
    alpha: float,
    min_structure_mg: float,
) -> list[Structure]:
    """Bin the residual by each observable and test the binned means (generic check)."""
    obs: dict[str, tuple[FloatArray, bool]] = {}
    if temperature_span_c(eng) >= MIN_TEMPERATURE_SPAN_C:
        obs["temperature_c"] = (eng.temperature, False)
        obs["dtemp_dt_c_per_min"] = (eng.rate, False)
    obs["elapsed_s"] = (eng.elapsed_s, True)
    for name, values in eng.extras.items():
        if np.nanstd(values) > 0:
            obs[name] = (values, False)
    out: list[Structure] = []
    part = eng.sample_part
    # Samples are binned by the engine's windows (consecutive samples of one block):
    # a bin's mean is then the count-weighted mean of its windows' means, and each
    # observable is sorted once per window, not once per sample. Where the windows are
    # too few to fill the bins several times over (a short static hold: 30 windows of
    # 15 s for 30 bins), each bin would be one window whatever the observable, and every
    # observable would show the same structure (the windows' scatter): the samples are
    # binned themselves.
    first = eng.window_start
    if first.size < MIN_WINDOWS_PER_BIN * n_bins:
        first = np.arange(eng.n, dtype=np.int64)
    count = np.diff(np.append(first, eng.n)).astype(np.float64)

    def means(values: FloatArray) -> FloatArray:
        return np.asarray(np.add.reduceat(values, first) / count, dtype=np.float64)

    obs_w = {name: (means(x), per_run) for name, (x, per_run) in obs.items()}
    run_w = eng.sample_run[first]
    for a in AXES:
        r = resid[a]
        same = part[1:] == part[:-1]
        d = np.diff(r)[same]
        sigma = math.sqrt(float(np.mean(d * d)) / 2.0) if d.size else math.nan
        if not sigma > 0:
            continue
        r_w = means(r)
        # Pooled observables are binned within each gravity value of the axis, so that
        # structure proportional to gravity (opposite in opposite orientations) shows.
        grav_group = np.unique(eng.gravity[first, AXES.index(a)], return_inverse=True)[1]
        for name, (x, per_run) in obs_w.items():
            groups = run_w if per_run else grav_group.astype(np.int64)
            bins = _bin_ids(x, groups, n_bins, per_run)
            chi2, dof, n_used = _binned_chi2(r_w, count, bins, sigma)
            if dof < 1:
                continue
            p = chi2_sf(chi2, dof)
            rms = sigma * math.sqrt(max(chi2 - dof, 0.0) / n_used)
            note = ""
            sig = p < alpha and rms >= min_structure_mg
            if sig and per_run:
                note = "; ".join(
                    n
                    for n in (
                        _between_runs_note(r_w, count, run_w, sigma, chi2),
                        _period_note(eng, r, sigma),
                    )
                    if n
                )
            out.append(Structure(a, name, chi2, dof, p, rms, sigma, bool(sig), note))
    return out


def _bin_ids(
    x: FloatArray, groups: NDArray[np.int64], n_bins: int, uniform: bool
) -> NDArray[np.int64]:
    """Bin index per sample: within each group, quantile bins or (time) uniform bins."""
    ids = np.zeros(x.size, dtype=np.int64)
    offset = 0
    for g in np.unique(groups):
        sel = groups == g
        xs = x[sel]
        if uniform:
            width = max(float(xs.max() - xs.min()) / n_bins, 60.0)
            local = np.floor((xs - xs.min()) / width).astype(np.int64)
        else:
            edges = np.unique(np.quantile(xs, np.linspace(0, 1, n_bins + 1)))
            local = np.clip(np.searchsorted(edges, xs, side="right") - 1, 0, max(edges.size - 2, 0))
        ids[sel] = local + offset
        offset += int(local.max()) + 1
    return ids


def _binned_chi2(
    r: FloatArray, count: FloatArray, bins: NDArray[np.int64], sigma: float
) -> tuple[float, int, int]:
    """Chi-square of the bins' means of ``r`` (each value the mean of ``count`` samples)."""
    counts = np.bincount(bins, weights=count)
    sums = np.bincount(bins, weights=count * r)
    ok = counts >= 10
    if ok.sum() < 2:
        return 0.0, 0, 0
    n = counts[ok].astype(np.float64)
    means = sums[ok] / n
    grand = float((means * n).sum() / n.sum())
    chi2 = float((n * (means - grand) ** 2).sum()) / (sigma * sigma)
    return chi2, int(ok.sum()) - 1, int(n.sum())


def _between_runs_note(
    r: FloatArray, count: FloatArray, run: NDArray[np.int64], sigma: float, chi2: float
) -> str:
    """Say when most of a structure in time is between the runs' mean levels.

    Runs whose levels differ (a re-placement, a re-seat, a turn-on offset) show as
    structure against time, binned within each run; when the runs' means alone hold
    half its chi-square or more, the note says so, with how far apart they are.
    """
    n = np.bincount(run, weights=count)
    used = n > 0
    if np.count_nonzero(used) < 2 or not chi2 > 0:
        return ""
    means = np.bincount(run, weights=count * r)[used] / n[used]
    grand = float((means * n[used]).sum() / n[used].sum())
    between = float((n[used] * (means - grand) ** 2).sum()) / (sigma * sigma)
    if between < 0.5 * chi2:
        return ""
    return (
        f"mostly between runs: their mean levels differ by up to "
        f"{float(means.max() - means.min()):.3g} mg"
    )


def _period_note(eng: Engine, r: FloatArray, sigma: float) -> str:
    """Strongest period of the residual in time (periodogram over the parts)."""
    t = eng.elapsed_s
    spans = [float(np.ptp(t[eng.sample_run == r])) for r in np.unique(eng.sample_run)]
    span = max(spans)
    if span < 900:
        return ""
    # At least three cycles inside the longest run.
    periods = np.geomspace(120.0, span / 3.0, 160)
    power = np.zeros(periods.size)
    for run in np.unique(eng.sample_run):
        sel = eng.sample_run == run
        rp = r[sel] - r[sel].mean()
        tp = t[sel]
        phase = np.exp(-2j * np.pi * tp[None, :] / periods[:, None])
        power += np.abs(phase @ rp) ** 2
    power /= r.size * sigma * sigma
    k = int(np.argmax(power))
    near = (periods >= periods[k] / 2) & (periods <= periods[k] * 2)
    # A sharp, isolated peak: well above the noise and above the spectrum around it.
    if power[k] < 30.0 or power[k] < 4.0 * float(np.median(power[near])):
        return ""
    return f"periodic, strongest period ≈ {periods[k] / 60:.1f} min"
