"""Residual diagnosis: find what the calibration model misses, add it, report before and after.

:func:`residuals` gives, per decimated sample, the error in mg against the
gravity the run's orientation implies, beside the observables (temperature,
its rate, elapsed time, branch, extra columns). :func:`diagnose` searches a
catalogue of candidate effects, each a named set of model terms
(:mod:`accelcore.model`), and adds them greedily by *held-out* error only:

``offset_curvature``
    offset terms ``dT^2 … dT^k`` (nested, ``k`` up to ``max_order``);
``sensitivity_curvature``
    own-axis gain terms ``dT^2 … dT^k`` (needs two gravity values on the axis);
``thermal_lag``
    every ``dT^k`` basis of the axis replaced by ``lag(tau):dT^k``, ``tau``
    estimated by a grid and golden-section search on the held-out error;
``misalignment``
    gain terms on the other axes' gravity (cross-axis sensitivity; with six
    orientations, the full 3x3 sensitivity matrix);
``drift``
    offset linear in the time since the run's start (``elapsed_h``);
``extra:NAME``
    offset linear in an extra logged column.

Cross-validation is blocked: whole runs are held out (three runs or more, when
every fold keeps the orientations that identify each axis), else the legs of
the temperature cycle (monotonic heating/cooling stretches, by the sign of the
smoothed dT/dt), else thirds of each run in time. A family is added to an axis
when the axis' held-out RMS error falls by at least ``min_improvement``
(default 10 %) *and* a paired one-sided t-test over held-out blocks of
``block_s`` seconds (the per-block change of the squared error) is significant
at ``alpha`` (default 1 %). Each step adds the family with the largest total
cut of held-out squared error over the axes that accept it, then repeats.

The fast path of the search works on per-block Gram matrices (scaled columns,
eigen-decomposition with a rank cut for unidentifiable directions); the
reported coefficients and their standard errors come from
:func:`accelcore.fitting.calibrate.fit_axis` (the core's Givens least squares).
Errors are per axis, linearised: the output residual divided by the axis'
sensitivity, in mg.

After the last step a generic check bins the residual by every observable
(temperature, dT/dt, elapsed time within each run, each extra column) and
compares the binned means with their white-noise standard errors (chi-square);
structure that no added term explains is reported, naming the observable.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from accelcore.errors import (
    InsufficientDataError,
    ParameterError,
    TemperatureRangeWarning,
)
from accelcore.fitting.calibrate import CutFeatures, Stacked, block_weights, calibrate, fit_axis
from accelcore.input.session import Session
from accelcore.model import AXES, Features, Term, design_columns
from accelcore.result.calibration import AxisModel, Calibration, nominal_sensitivity

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "FAMILIES",
    "Diagnosis",
    "Step",
    "Structure",
    "diagnose",
    "leg_labels",
    "rate_c_per_min",
    "residuals",
]

FloatArray = NDArray[np.float64]

#: Candidate effect families of the catalogue, in the order they are tried.
FAMILIES = (
    "offset_curvature",
    "sensitivity_curvature",
    "thermal_lag",
    "misalignment",
    "drift",
    "extra",
)
_RATE_HALF_WINDOW_S = 60.0
_STEADY_C_PER_MIN = 0.1
_CONFOUND_TAU_S = 120.0


# ---------------------------------------------------------------------- observables
def rate_c_per_min(
    time_s: FloatArray, temperature_c: FloatArray, half_window_s: float = _RATE_HALF_WINDOW_S
) -> FloatArray:
    """Centred, smoothed rate of change of temperature, °C/min.

    ``(T(t + h) - T(t - h)) / 2h`` with linear interpolation, the window
    shortened at the ends of the record.

    Parameters
    ----------
    time_s, temperature_c : ndarray
        Sample times (s, increasing) and temperatures (°C).
    half_window_s : float, default 60
        Half-width ``h`` of the window, s.

    Returns
    -------
    ndarray
        Rate per sample, °C/min (0 for fewer than two samples).
    """
    t = np.asarray(time_s, dtype=np.float64)
    temp = np.asarray(temperature_c, dtype=np.float64)
    if t.size < 2:
        return np.zeros(t.size)
    lo = np.clip(t - half_window_s, t[0], t[-1])
    hi = np.clip(t + half_window_s, t[0], t[-1])
    span = hi - lo
    rate = (np.interp(hi, t, temp) - np.interp(lo, t, temp)) / np.where(span > 0, span, 1.0)
    return np.asarray(np.where(span > 0, rate * 60.0, 0.0), dtype=np.float64)


def _branch_sign(rate: FloatArray, steady_c_per_min: float) -> NDArray[np.int64]:
    return np.where(rate > steady_c_per_min, 1, np.where(rate < -steady_c_per_min, -1, 0)).astype(
        np.int64
    )


def leg_labels(
    time_s: FloatArray,
    temperature_c: FloatArray,
    *,
    steady_c_per_min: float = _STEADY_C_PER_MIN,
    min_leg_s: float = 300.0,
) -> tuple[NDArray[np.int64], list[str]]:
    """Split a run into monotonic legs of its temperature cycle.

    Samples are heating or cooling by the sign of :func:`rate_c_per_min`
    (steady within ``steady_c_per_min``); contiguous stretches of one sign form
    a leg, steady stretches join the leg before them (or after, at the start),
    and legs shorter than ``min_leg_s`` join a neighbour.

    Returns
    -------
    labels : ndarray of int
        Leg index of each sample, from 0.
    kinds : list of str
        ``"heating"``, ``"cooling"`` or ``"steady"`` per leg.
    """
    t = np.asarray(time_s, dtype=np.float64)
    n = t.size
    if n == 0:
        return np.zeros(0, dtype=np.int64), []
    sign = _branch_sign(rate_c_per_min(t, temperature_c), steady_c_per_min)
    # Fill steady samples with the previous non-steady sign (or the next one at the start).
    filled = sign.copy()
    nz = np.flatnonzero(sign)
    if nz.size == 0:
        return np.zeros(n, dtype=np.int64), ["steady"]
    idx = np.where(sign != 0, np.arange(n), -1)
    idx = np.maximum.accumulate(idx)
    filled = np.where(idx >= 0, sign[np.maximum(idx, 0)], sign[nz[0]])
    # Segments of constant sign.
    bounds = [0, *(np.flatnonzero(np.diff(filled)) + 1).tolist(), n]
    segs = [[bounds[i], bounds[i + 1], int(filled[bounds[i]])] for i in range(len(bounds) - 1)]
    # Merge short segments into a neighbour until none is short.
    while len(segs) > 1:
        durations = [t[s[1] - 1] - t[s[0]] for s in segs]
        k = int(np.argmin(durations))
        if durations[k] >= min_leg_s:
            break
        if k == 0:
            segs[1][0] = segs[0][0]
            del segs[0]
        else:
            segs[k - 1][1] = segs[k][1]
            del segs[k]
        # Neighbours of equal sign fuse.
        merged: list[list[int]] = []
        for s in segs:
            if merged and merged[-1][2] == s[2]:
                merged[-1][1] = s[1]
            else:
                merged.append(s)
        segs = merged
    labels = np.empty(n, dtype=np.int64)
    kinds = []
    for i, (a, b, sg) in enumerate(segs):
        labels[a:b] = i
        kinds.append({1: "heating", -1: "cooling"}.get(sg, "steady"))
    return labels, kinds


# ---------------------------------------------------------------------- residuals
def residuals(calibration: Calibration, session: Session) -> pd.DataFrame:
    """Error of a calibration on every decimated sample of a session, with the observables.

    Each run's raw output is compensated (:meth:`Calibration.compensate`, with
    time and extra columns), the gravity its orientation implies subtracted,
    and the result given in mg; ``err_norm_mg`` is ``|a| - 1 g`` in mg.
    Samples outside the calibrated temperature range are included (the model
    extrapolated, without the range warning) and flagged by ``in_range``.

    Parameters
    ----------
    calibration : Calibration
    session : Session

    Returns
    -------
    pandas.DataFrame
        One row per decimated sample: ``run`` (label), ``run_index``,
        ``orientation``, ``time_s``, ``elapsed_s``, ``temperature_c``,
        ``dtemp_dt_c_per_min`` (centred over ±60 s), ``branch`` (``heating``,
        ``cooling`` or ``steady``, within ±0.1 °C/min), ``err_x_mg``,
        ``err_y_mg``, ``err_z_mg``, ``err_norm_mg``, ``in_range``, then every
        extra column.
    """
    frames = []
    lo, hi = calibration.temperature_range_c
    for i, run in enumerate(session.runs):
        if len(run) == 0:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TemperatureRangeWarning)
            acc = calibration.compensate(run.output, run.temperature_c, run.time_s, run.extras)
        err = (acc - run.gravity_g[None, :]) * 1000.0
        norm = (np.linalg.norm(acc, axis=1) - 1.0) * 1000.0
        rate = rate_c_per_min(run.time_s, run.temperature_c)
        sign = _branch_sign(rate, _STEADY_C_PER_MIN)
        frame: dict[str, Any] = {
            "run": run.label,
            "run_index": i,
            "orientation": run.orientation,
            "time_s": run.time_s,
            "elapsed_s": run.time_s - run.time_s[0],
            "temperature_c": run.temperature_c,
            "dtemp_dt_c_per_min": rate,
            "branch": np.where(sign > 0, "heating", np.where(sign < 0, "cooling", "steady")),
            "err_x_mg": err[:, 0],
            "err_y_mg": err[:, 1],
            "err_z_mg": err[:, 2],
            "err_norm_mg": norm,
            "in_range": (run.temperature_c >= lo) & (run.temperature_c <= hi),
        }
        for name, values in run.extras.items():
            frame[name] = values
        frames.append(pd.DataFrame(frame))
    if not frames:
        raise InsufficientDataError("the session holds no samples")
    return pd.concat(frames, ignore_index=True)


# ---------------------------------------------------------------------- model space
@dataclass(frozen=True)
class _Spec:
    """A point of the model space of one axis."""

    tau: float | None = None
    rate_tau: float | None = None
    offset_order: int = 1
    gain_order: int = 1
    cross: tuple[str, ...] = ()
    drift: bool = False
    extras: tuple[str, ...] = ()

    def temp_basis(self, k: int) -> str:
        return f"dT^{k}" if self.tau is None else f"lag({self.tau:.6g}):dT^{k}"

    def terms(self, axis: str) -> tuple[Term, ...]:
        out = [Term("offset", "1")]
        for k in range(1, self.offset_order + 1):
            eff = "base" if k == 1 else "offset_curvature"
            out.append(Term("offset", self.temp_basis(k), effect=eff))
        if self.rate_tau is not None:
            out.append(Term("offset", f"lag({self.rate_tau:.6g}):dT^1", effect="thermal_lag"))
        out.append(Term("gain", "1", source=axis))
        for k in range(1, self.gain_order + 1):
            eff = "base" if k == 1 else "sensitivity_curvature"
            out.append(Term("gain", self.temp_basis(k), source=axis, effect=eff))
        out += [Term("gain", "1", source=b, effect="misalignment") for b in self.cross]
        if self.drift:
            out.append(Term("offset", "elapsed_h", effect="drift"))
        out += [Term("offset", f"extra:{e}", effect="extra") for e in self.extras]
        if self.tau is not None:
            out = [
                replace(t, effect="thermal_lag")
                if t.basis.startswith("lag(") and t.effect == "base"
                else t
                for t in out
            ]
        return tuple(out)


def _spec_from_terms(axis: str, terms: Sequence[Term]) -> _Spec | None:
    """Return the spec a base calibration's terms correspond to (None: outside the space)."""
    spec = _Spec(offset_order=0, gain_order=0)
    has = set()
    plain = {t.basis for t in terms if t.kind == "offset"}
    for t in terms:
        basis = t.basis
        if basis.startswith("lag(") and t.kind == "offset" and "dT^1" in plain:
            if basis.endswith(":dT^1") and spec.rate_tau is None:
                spec = replace(spec, rate_tau=float(basis[4 : basis.index(")")]))
                continue
            return None
        if basis.startswith("lag("):
            tau = float(basis[4 : basis.index(")")])
            if spec.tau is not None and spec.tau != tau:
                return None
            spec = replace(spec, tau=tau)
            basis = basis[basis.index(":") + 1 :]
        if basis == "1":
            has.add((t.kind, t.source))
            if t.kind == "gain" and t.source != axis:
                spec = replace(spec, cross=(*spec.cross, str(t.source)))
            continue
        if basis.startswith("dT^"):
            k = int(basis[3:])
            if t.kind == "offset":
                spec = replace(spec, offset_order=max(spec.offset_order, k))
            elif t.source == axis:
                spec = replace(spec, gain_order=max(spec.gain_order, k))
            else:
                return None
        elif basis == "elapsed_h" and t.kind == "offset":
            spec = replace(spec, drift=True)
        elif basis.startswith("extra:") and t.kind == "offset":
            spec = replace(spec, extras=(*spec.extras, basis[6:]))
        else:
            return None
    if ("offset", None) not in has or ("gain", axis) not in has:
        return None
    if spec.offset_order < 1 or spec.gain_order < 1:
        return None
    return spec


# ---------------------------------------------------------------------- statistics
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


def _t_sf(t: float, dof: int) -> float:
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


def _paired_p(diff: FloatArray) -> tuple[float, float]:
    """One-sided paired t-test that ``mean(diff) > 0``: (t, p)."""
    n = diff.size
    if n < 2:
        return math.nan, 1.0
    sd = float(np.std(diff, ddof=1))
    mean = float(np.mean(diff))
    if sd == 0.0:
        return (math.inf, 0.0) if mean > 0 else (0.0, 1.0)
    t = mean / (sd / math.sqrt(n))
    return t, _t_sf(t, n - 1)


def _solve(g: FloatArray, b: FloatArray) -> FloatArray:
    """Minimum-norm solution of the (scaled) normal equations with a rank cut."""
    evals, evecs = np.linalg.eigh(g)
    top = float(evals.max()) if evals.size else 0.0
    keep = evals > top * 1e-12
    inv = np.zeros_like(evals)
    inv[keep] = 1.0 / evals[keep]
    return np.asarray(evecs @ (inv * (evecs.T @ b)), dtype=np.float64)


# ---------------------------------------------------------------------- engine
@dataclass
class _CV:
    """Cross-validated fit of one axis model."""

    terms: tuple[Term, ...]
    sse_blocks: FloatArray  # held-out weighted SSE per block, mg²
    sse_in: float  # in-sample weighted SSE, mg²
    rms_out: float
    rms_in: float


class _Engine:
    """Samples cut into parts (run x leg), blocks and folds; fast blocked CV per axis."""

    def __init__(
        self,
        session: Session,
        base: Calibration,
        *,
        folds: str,
        block_s: float,
        steady_c_per_min: float,
    ) -> None:
        self.session = session
        self.t_ref_c = base.t_ref_c
        window = None if not np.all(np.isfinite(base.window_c)) else base.window_c
        self.references = dict(base.references)
        feats: list[Features] = []
        grav, out, wts, run_idx = [], [], [], []
        part_run: list[int] = []
        part_leg: list[int] = []
        leg_kinds: dict[tuple[int, int], str] = {}
        rates: list[FloatArray] = []
        for i, run in enumerate(session.runs):
            if len(run) == 0:
                continue
            time_s = run.time_s - run.time_s[0]
            whole = Features(run.temperature_c, time_s, run.extras, self.t_ref_c)
            rate = rate_c_per_min(run.time_s, run.temperature_c)
            legs, kinds = leg_labels(
                run.time_s, run.temperature_c, steady_c_per_min=steady_c_per_min
            )
            if window is None:
                inside = np.ones(len(run), dtype=bool)
            else:
                inside = (run.temperature_c >= window[0]) & (run.temperature_c <= window[1])
            # Same weights as the calibration: spikes and clipped blocks left out.
            weight, _ = block_weights(run, robust=bool(base.options.get("robust", True)))
            for leg in range(len(kinds)):
                keep = inside & (legs == leg)
                if np.count_nonzero(keep) < 2:
                    continue
                feats.append(CutFeatures.cut(whole, keep))
                grav.append(run.gravity_g)
                out.append(run.output[keep])
                wts.append(weight[keep])
                run_idx.append(i)
                part_run.append(i)
                part_leg.append(leg)
                leg_kinds[(i, leg)] = kinds[leg]
                rates.append(rate[keep])
        if not feats:
            raise InsufficientDataError("no decimated sample lies in the calibration's window")
        self.data = Stacked(feats, grav, out, wts, run_idx)
        self.part_run = part_run
        self.part_leg = part_leg
        sizes = [len(f) for f in feats]
        self.n = int(sum(sizes))
        self.part_start = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        self.w = np.concatenate(wts)
        self.gravity = np.vstack(
            [np.broadcast_to(g, (s, 3)) for g, s in zip(grav, sizes, strict=True)]
        )
        self.output = np.vstack(out)
        self.temperature = np.concatenate([f.temperature_c for f in feats])
        self.elapsed_s = np.concatenate([np.asarray(f.time_s) for f in feats])
        self.rate = np.concatenate(rates)
        self.sample_part = np.repeat(np.arange(len(feats)), sizes)
        self.sample_run = np.repeat(np.asarray(part_run), sizes)
        self.extras = {
            name: np.concatenate([np.asarray(f.extras[name]) for f in feats])
            for name in session.extra_columns
        }
        self._basis_cache: dict[str, FloatArray] = {}
        # Blocks: contiguous stretches of at most block_s inside one part.
        starts: list[int] = []
        block_part: list[int] = []
        for p, f in enumerate(feats):
            t = np.asarray(f.time_s)
            chunk = np.floor((t - t[0]) / block_s).astype(np.int64)
            edges = np.flatnonzero(np.diff(chunk)) + 1
            b0 = [0, *edges.tolist()]
            # Merge a short last chunk into the one before it.
            if len(b0) > 1 and (t[-1] - t[b0[-1]]) < 0.5 * block_s:
                b0 = b0[:-1]
            starts += [int(self.part_start[p]) + s for s in b0]
            block_part += [p] * len(b0)
        self.block_start = np.asarray(starts, dtype=np.int64)
        self.block_part = np.asarray(block_part, dtype=np.int64)
        self.block_stop = np.append(self.block_start[1:], self.n)
        self.sample_block = np.repeat(
            np.arange(self.block_start.size), self.block_stop - self.block_start
        )
        self.scheme, self.fold_names, self.block_fold = self._choose_folds(folds, leg_kinds)
        self.n_folds = len(self.fold_names)
        # Scale per axis (units per g) for mg conversion, fixed terms, centring.
        self.base = base
        self.scale: dict[str, float] = {}
        self.fixed: dict[str, list[tuple[Term, float]]] = {}
        self.y: dict[str, FloatArray] = {}
        for a_i, a in enumerate(AXES):
            m = base.axes[a]
            s0, _ = m.value("gain", "1", a)
            if not s0:
                nominal = nominal_sensitivity(session.units, session.sensor)
                s0 = nominal[a_i] if nominal else 1.0
            self.scale[a] = float(s0)
            fixed = [
                (term, float(c))
                for term, c, e in zip(m.terms, m.coefficients, m.estimated, strict=True)
                if not e
            ]
            self.fixed[a] = fixed
            y = self.output[:, a_i].copy()
            for term, c in fixed:
                y -= c * self.column(term)
            # Centre with the base model's constant and own-gain terms (in every model's span).
            c_off, _ = m.value("offset", "1")
            y -= c_off
            if not any(
                term.kind == "gain" and term.basis == "1" and term.source == a for term, _ in fixed
            ):
                y -= s0 * self.gravity[:, a_i]
            self.y[a] = y * (1000.0 / self.scale[a])

    # -------------------------------------------------------------- folds
    def _choose_folds(
        self, folds: str, leg_kinds: Mapping[tuple[int, int], str]
    ) -> tuple[str, list[str], NDArray[np.int64]]:
        runs = sorted(set(self.part_run))
        part_run = np.asarray(self.part_run)
        part_leg = np.asarray(self.part_leg)
        if folds not in ("auto", "runs", "legs", "blocks"):
            raise ParameterError(f"folds must be auto, runs, legs or blocks, got {folds!r}")

        def diverse(part_fold: NDArray[np.int64]) -> bool:
            sample_fold = part_fold[self.sample_part]
            # Every fold's training data must keep each axis' gravity at two values or more
            # (offset and sensitivity told apart) wherever the whole session does.
            for a_i in range(3):
                need = min(2, np.unique(self.gravity[:, a_i]).size)
                for k in np.unique(part_fold):
                    train = self.gravity[sample_fold != k, a_i]
                    if train.size == 0 or np.unique(train).size < need:
                        return False
            return True

        if folds in ("auto", "runs") and len(runs) >= 3:
            pf = np.searchsorted(runs, part_run).astype(np.int64)
            if folds == "runs" or diverse(pf):
                names = [f"run {self.session.runs[r].label}" for r in runs]
                return "runs", names, pf[self.block_part]
        n_legs = int(part_leg.max()) + 1
        if folds in ("auto", "legs") and n_legs >= 2:
            names = []
            for leg in range(n_legs):
                kinds = sorted({leg_kinds[(r, lg)] for (r, lg) in leg_kinds if lg == leg})
                names.append(f"leg {leg + 1} ({'/'.join(kinds)})")
            return "legs", names, part_leg.astype(np.int64)[self.block_part]
        if folds == "legs" and n_legs < 2:
            raise ParameterError("folds='legs' needs runs with at least two legs")
        # Thirds of every run in time: parts are split further by third.
        return "blocks", ["first third", "middle third", "last third"], self._split_thirds()

    def _split_thirds(self) -> NDArray[np.int64]:
        # Blocks of each run assigned to thirds of its duration.
        block_fold = np.zeros(self.block_start.size, dtype=np.int64)
        for r in set(self.part_run):
            sel = np.flatnonzero(np.asarray(self.part_run)[self.block_part] == r)
            t = self.elapsed_s[self.block_start[sel]]
            span = max(float(t.max() - t.min()), 1e-9)
            block_fold[sel] = np.minimum(2, np.floor(3 * (t - t.min()) / span * 0.9999)).astype(
                np.int64
            )
        return block_fold

    # -------------------------------------------------------------- columns
    def basis(self, name: str) -> FloatArray:
        if name not in self._basis_cache:
            one = Term("offset", name)
            self._basis_cache[name] = np.concatenate(
                [
                    design_columns((one,), f, g, self.references)[:, 0]
                    for f, g in zip(self.data.features, self.data.gravity, strict=True)
                ]
            )
        return self._basis_cache[name]

    def drop_lag_cache(self, keep: Sequence[float]) -> None:
        keep_s = {f"lag({k:.6g})" for k in keep}
        for key in list(self._basis_cache):
            if key.startswith("lag(") and key.split(":")[0] not in keep_s:
                del self._basis_cache[key]

    def column(self, term: Term) -> FloatArray:
        col = self.basis(term.basis)
        if term.kind == "gain":
            col = col * self.gravity[:, AXES.index(term.source or "x")]
        return col

    def free_terms(self, axis: str, terms: Sequence[Term]) -> tuple[Term, ...]:
        """Terms minus those the base held fixed (matched ignoring lag)."""

        def key(t: Term) -> tuple[str, str, str | None]:
            basis = t.basis.split(":", 1)[1] if t.basis.startswith("lag(") else t.basis
            return t.kind, basis, t.source if t.kind == "gain" else None

        fixed = {key(t) for t, _ in self.fixed[axis]}
        return tuple(t for t in terms if key(t) not in fixed)

    def design(self, axis: str, terms: Sequence[Term]) -> FloatArray:
        free = self.free_terms(axis, terms)
        if not free:
            return np.zeros((self.n, 0))
        return np.column_stack([self.column(t) for t in free])

    # -------------------------------------------------------------- fitting
    def _grams(
        self, axis: str, terms: Sequence[Term]
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        x = self.design(axis, terms)
        sw = np.sqrt(self.w)
        norm = np.sqrt((x**2 * self.w[:, None]).sum(axis=0))
        norm[norm == 0] = 1.0
        xs = x / norm
        z = xs * sw[:, None]
        yw = self.y[axis] * sw
        nb = self.block_start.size
        p = xs.shape[1]
        g = np.empty((nb, p, p))
        bvec = np.empty((nb, p))
        yy = np.empty(nb)
        for k in range(nb):
            s, e = self.block_start[k], self.block_stop[k]
            zb = z[s:e]
            g[k] = zb.T @ zb
            bvec[k] = zb.T @ yw[s:e]
            yy[k] = yw[s:e] @ yw[s:e]
        return xs, norm, g, bvec, yy, z

    def cv(self, axis: str, terms: Sequence[Term]) -> _CV:
        _, _, g, bvec, yy, _ = self._grams(axis, terms)
        g_tot, b_tot, yy_tot = g.sum(axis=0), bvec.sum(axis=0), float(yy.sum())
        sse_blocks = np.empty(yy.size)
        for k in range(self.n_folds):
            sel = self.block_fold == k
            if not sel.any():
                continue
            beta = _solve(g_tot - g[sel].sum(axis=0), b_tot - bvec[sel].sum(axis=0))
            sse_blocks[sel] = (
                yy[sel] - 2.0 * bvec[sel] @ beta + np.einsum("bij,i,j->b", g[sel], beta, beta)
            )
        beta = _solve(g_tot, b_tot)
        sse_in = yy_tot - 2.0 * float(b_tot @ beta) + float(beta @ g_tot @ beta)
        sse_blocks = np.maximum(sse_blocks, 0.0)
        wsum = float(self.w.sum())
        return _CV(
            tuple(terms),
            sse_blocks,
            max(sse_in, 0.0),
            math.sqrt(float(sse_blocks.sum()) / wsum),
            math.sqrt(max(sse_in, 0.0) / wsum),
        )

    def residuals(self, axis: str, terms: Sequence[Term]) -> tuple[FloatArray, FloatArray]:
        """In-sample and held-out residual per sample, mg."""
        xs, _, g, bvec, _, _ = self._grams(axis, terms)
        g_tot, b_tot = g.sum(axis=0), bvec.sum(axis=0)
        y = self.y[axis]
        r_in = y - xs @ _solve(g_tot, b_tot)
        r_out = np.empty(self.n)
        for k in range(self.n_folds):
            sel_b = self.block_fold == k
            if not sel_b.any():
                continue
            beta = _solve(g_tot - g[sel_b].sum(axis=0), b_tot - bvec[sel_b].sum(axis=0))
            rows = self.sample_fold == k
            r_out[rows] = y[rows] - xs[rows] @ beta
        return r_in, r_out

    @property
    def sample_fold(self) -> NDArray[np.int64]:
        return self.block_fold[self.sample_block]


# ---------------------------------------------------------------------- results
@dataclass(frozen=True)
class Structure:
    """Structure of the final residual against one observable (binned means vs noise).

    Attributes
    ----------
    axis : str
    observable : str
        ``temperature_c``, ``dtemp_dt_c_per_min``, ``elapsed_s`` (binned within
        each run) or an extra column.
    chi2, dof, p_value : float, int, float
        Chi-square of the binned means against their white-noise standard errors.
    structure_rms_mg : float
        Estimated RMS of the binned structure, mg (excess over noise).
    noise_mg : float
        White-noise level of the residual (first differences), mg.
    significant : bool
        ``p_value < alpha_structure`` and ``structure_rms_mg >= min_structure_mg``.
    note : str
        E.g. the period of a periodic structure in time.
    """

    axis: str
    observable: str
    chi2: float
    dof: int
    p_value: float
    structure_rms_mg: float
    noise_mg: float
    significant: bool
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form for JSON."""
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class Step:
    """One step of the greedy selection (step 0: the base model).

    Attributes
    ----------
    index : int
    effect : str
        Family added (``base`` for step 0).
    axes : tuple of str
        Axes it was added to.
    variant : dict of str to str
        Per axis: the chosen variant (``order 3``, ``tau 118 s``, ...).
    parameters : list of dict
        Each added parameter: ``axis``, ``name``, ``value``, ``se``, ``unit``.
    rms_in_mg, max_in_mg, rms_out_mg, max_out_mg : float
        In-sample and held-out error of the model after this step, all axes pooled.
    rms_out_axis_mg, rms_in_axis_mg, max_out_axis_mg : dict of str to float
        The same per axis.
    rms_out_fold_axis_mg : dict of str to dict of str to float
        Held-out RMS per fold (name) and axis.
    cut : dict of str to float
        Relative cut of held-out RMS per axis it was added to.
    p_value : dict of str to float
        Of the paired test per axis it was added to.
    terms : dict of str to list of Term
        The model of every axis after this step.
    """

    index: int
    effect: str
    axes: tuple[str, ...]
    variant: dict[str, str]
    parameters: list[dict[str, Any]]
    rms_in_mg: float
    max_in_mg: float
    rms_out_mg: float
    max_out_mg: float
    rms_in_axis_mg: dict[str, float]
    rms_out_axis_mg: dict[str, float]
    max_out_axis_mg: dict[str, float]
    rms_out_fold_axis_mg: dict[str, dict[str, float]]
    cut: dict[str, float]
    p_value: dict[str, float]
    terms: dict[str, tuple[Term, ...]]

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form for JSON."""
        d = dataclasses.asdict(self)
        d["terms"] = {a: [t.to_dict() for t in ts] for a, ts in self.terms.items()}
        d["axes"] = list(self.axes)
        return d


@dataclass(frozen=True)
class Diagnosis:
    """Result of :func:`diagnose`.

    Attributes
    ----------
    base : Calibration
        The model diagnosed.
    calibration : Calibration
        The improved calibration (method ``"diagnosed"``); it is ``base``
        refitted when nothing was added.
    steps : tuple of Step
        Step 0 is the base model, then one per added effect.
    candidates : pandas.DataFrame
        Every family tried at every step, per axis: best variant, held-out
        RMS before and after, cut, p-value, accepted.
    structures : tuple of Structure
        Generic check of the final residual against every observable.
    warnings : tuple of str
        Effects that cannot be told apart on this data, and other caveats.
    folds : tuple of str
        The held-out folds (``scheme`` says how they were formed).
    scheme : str
        ``runs``, ``legs`` or ``blocks``.
    options : dict
        Every option used.
    """

    base: Calibration
    calibration: Calibration
    steps: tuple[Step, ...]
    candidates: pd.DataFrame
    structures: tuple[Structure, ...]
    warnings: tuple[str, ...]
    folds: tuple[str, ...]
    scheme: str
    options: dict[str, Any]
    _engine: _Engine | None = field(default=None, repr=False, compare=False)

    @property
    def effects(self) -> tuple[str, ...]:
        """Families added, in order."""
        return tuple(s.effect for s in self.steps[1:])

    @property
    def unexplained(self) -> tuple[Structure, ...]:
        """Significant structures, strongest first."""
        sig = [s for s in self.structures if s.significant]
        return tuple(sorted(sig, key=lambda s: -s.structure_rms_mg))

    # -------------------------------------------------------------- tables
    def report(self) -> pd.DataFrame:
        """One row per step: effect, parameters, in-sample and held-out error before and after.

        Returns
        -------
        pandas.DataFrame
            Columns ``step``, ``effect``, ``axes``, ``parameters`` (text with
            standard errors), ``rms_in_before_mg``, ``rms_in_after_mg``,
            ``max_in_before_mg``, ``max_in_after_mg``, ``rms_out_before_mg``,
            ``rms_out_after_mg``, ``max_out_before_mg``, ``max_out_after_mg``
            (all axes pooled), ``cut_pct`` (held-out RMS), then
            ``rms_out_{axis}_before_mg`` / ``_after_mg`` per axis.
        """
        rows = []
        prev = self.steps[0]
        for s in self.steps:
            row: dict[str, Any] = {
                "step": s.index,
                "effect": s.effect,
                "axes": ",".join(s.axes),
                "variant": "; ".join(f"{a}: {v}" for a, v in s.variant.items()),
                "parameters": "; ".join(_fmt_param(p) for p in s.parameters),
                "rms_in_before_mg": prev.rms_in_mg,
                "rms_in_after_mg": s.rms_in_mg,
                "max_in_before_mg": prev.max_in_mg,
                "max_in_after_mg": s.max_in_mg,
                "rms_out_before_mg": prev.rms_out_mg,
                "rms_out_after_mg": s.rms_out_mg,
                "max_out_before_mg": prev.max_out_mg,
                "max_out_after_mg": s.max_out_mg,
                "cut_pct": 100.0 * (1.0 - s.rms_out_mg / prev.rms_out_mg)
                if prev.rms_out_mg > 0
                else 0.0,
            }
            for a in AXES:
                row[f"rms_out_{a}_before_mg"] = prev.rms_out_axis_mg[a]
                row[f"rms_out_{a}_after_mg"] = s.rms_out_axis_mg[a]
            rows.append(row)
            prev = s
        return pd.DataFrame(rows)

    def heldout_table(self) -> pd.DataFrame:
        """Held-out RMS error per step, fold and axis (mg), one row each."""
        rows = []
        for s in self.steps:
            for fold, per_axis in s.rms_out_fold_axis_mg.items():
                for a, v in per_axis.items():
                    rows.append(
                        {"step": s.index, "effect": s.effect, "fold": fold, "axis": a, "rms_mg": v}
                    )
        return pd.DataFrame(rows)

    def evaluate(self, terms: Mapping[str, Sequence[Term]]) -> pd.DataFrame:
        """Held-out and in-sample error of any model on this diagnosis' folds.

        Parameters
        ----------
        terms : mapping of axis to sequence of Term
            E.g. the fixed cubic offset model of PX4/ArduPilot.

        Returns
        -------
        pandas.DataFrame
            One row per fold and ``all``, per axis: ``rms_out_mg``, ``max_out_mg``;
            the ``all`` row also ``rms_in_mg``.
        """
        if self._engine is None:
            raise ParameterError("this Diagnosis was restored without its data")
        eng = self._engine
        rows = []
        for a in AXES:
            ts = tuple(terms[a])
            r_in, r_out = eng.residuals(a, ts)
            for k, name in enumerate(eng.fold_names):
                sel = eng.sample_fold == k
                if not sel.any():
                    continue
                rows.append(
                    {
                        "fold": name,
                        "axis": a,
                        "rms_out_mg": _wrms(r_out[sel], eng.w[sel]),
                        "max_out_mg": float(np.abs(r_out[sel]).max()),
                        "rms_in_mg": math.nan,
                    }
                )
            rows.append(
                {
                    "fold": "all",
                    "axis": a,
                    "rms_out_mg": _wrms(r_out, eng.w),
                    "max_out_mg": float(np.abs(r_out).max()),
                    "rms_in_mg": _wrms(r_in, eng.w),
                }
            )
        return pd.DataFrame(rows)

    def text(self) -> str:
        """Plain-text rendering: the step table, warnings and unexplained structure."""
        rep = self.report()
        lines = [
            f"Diagnosis: {len(self.steps) - 1} effect(s) added; held-out folds: "
            f"{self.scheme} ({', '.join(self.folds)})",
            f"{'step':>4}  {'effect':<22}{'axes':<7}{'RMS in':>9}{'RMS out':>9}"
            f"{'max out':>9}{'cut':>7}   (mg, all axes; before → after)",
        ]
        for r in rep.to_dict(orient="records"):
            lines.append(
                f"{r['step']:>4}  {r['effect']:<22}{r['axes']:<7}{r['rms_in_after_mg']:>9.3f}"
                f"{r['rms_out_after_mg']:>9.3f}{r['max_out_after_mg']:>9.2f}{r['cut_pct']:>6.1f}%"
            )
            if r["variant"]:
                lines.append(f"{'':>6}{r['variant']}")
            if r["parameters"]:
                lines.append(f"{'':>6}{r['parameters']}")
        per_axis = "  ".join(
            f"{a}: {self.steps[0].rms_out_axis_mg[a]:.3f} → {self.steps[-1].rms_out_axis_mg[a]:.3f}"
            for a in AXES
        )
        lines.append(f"held-out RMS per axis (mg), base → diagnosed: {per_axis}")
        for w in self.warnings:
            lines.append(f"warning: {w}")
        un = self.unexplained
        if un:
            lines.append("unexplained structure (no catalogue term explains it):")
            for s in un:
                lines.append(
                    f"  axis {s.axis} vs {s.observable}: {s.structure_rms_mg:.3f} mg rms "
                    f"(noise {s.noise_mg:.3f} mg, chi2 {s.chi2:.0f}/{s.dof}, p {s.p_value:.1e})"
                    + (f"; {s.note}" if s.note else "")
                )
        else:
            lines.append("no unexplained structure against any observable")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.text()

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form for JSON (every step, every figure, warnings, structures)."""
        return {
            "scheme": self.scheme,
            "folds": list(self.folds),
            "effects": list(self.effects),
            "steps": [s.to_dict() for s in self.steps],
            "report": _records(self.report()),
            "candidates": _records(self.candidates),
            "structures": [s.to_dict() for s in self.structures],
            "unexplained": [s.to_dict() for s in self.unexplained],
            "warnings": list(self.warnings),
            "options": dict(self.options),
            "calibration": self.calibration.to_dict(),
        }

    # -------------------------------------------------------------- plot
    def plot(self, observable: str | None = None) -> Figure:
        """Residual vs temperature and vs a chosen observable, base model and diagnosed.

        Parameters
        ----------
        observable : str, optional
            Column of :func:`residuals` for the second row; default the
            observable of the strongest unexplained structure, else the one the
            last added effect depends on.

        Returns
        -------
        matplotlib.figure.Figure
        """
        try:
            import matplotlib.pyplot as plt
        except ImportError as exc:  # pragma: no cover - optional dependency
            raise ImportError(
                "Diagnosis.plot needs matplotlib (pip install accelcore[plot])"
            ) from exc
        if self._engine is None:
            raise ParameterError("this Diagnosis was restored without its data")
        session = self._engine.session
        before = residuals(self.base, session)
        after = residuals(self.calibration, session)
        obs = observable or self._default_observable()
        fig, axs = plt.subplots(2, 2, figsize=(11, 7), sharey="row", squeeze=False)
        for col, (title, df) in enumerate((("base model", before), ("diagnosed", after))):
            for row, x in enumerate(("temperature_c", obs)):
                ax = axs[row][col]
                for a in AXES:
                    ax.plot(df[x], df[f"err_{a}_mg"], ".", ms=1.5, label=a, alpha=0.6)
                ax.set_xlabel(x)
                ax.set_ylabel("error, mg")
                ax.set_title(title)
                ax.grid(True, alpha=0.3)
        axs[0][0].legend(markerscale=6)
        fig.tight_layout()
        return fig

    def _default_observable(self) -> str:
        un = self.unexplained
        if un:
            return un[0].observable
        last = self.effects[-1] if self.effects else ""
        return {
            "thermal_lag": "dtemp_dt_c_per_min",
            "drift": "elapsed_s",
            "misalignment": "run_index",
        }.get(last, "elapsed_s")


def _wrms(r: FloatArray, w: FloatArray) -> float:
    return math.sqrt(float((w * r * r).sum() / w.sum())) if w.sum() > 0 else math.nan


def _records(df: pd.DataFrame) -> list[dict[str, Any]]:
    out = []
    for rec in df.to_dict(orient="records"):
        out.append({str(k): (v.item() if isinstance(v, np.generic) else v) for k, v in rec.items()})
    return out


def _fmt_param(p: Mapping[str, Any]) -> str:
    se = p.get("se")
    se_s = f" ± {se:.2g}" if se is not None and math.isfinite(se) and se > 0 else ""
    return f"{p['axis']}:{p['name']} = {p['value']:.4g}{se_s} {p['unit']}".rstrip()


# ---------------------------------------------------------------------- diagnose
@dataclass
class _Candidate:
    family: str
    axis: str
    variant: str
    spec: _Spec
    cv: _CV
    cut: float
    t: float
    p: float
    accepted: bool


def _variants(
    family: str, axis: str, spec: _Spec, eng: _Engine, max_order: int, extras: Sequence[str]
) -> list[tuple[str, str, _Spec]]:
    """(family, variant label, spec) of one family on one axis, cheapest first."""
    a_i = AXES.index(axis)
    own_values = np.unique(eng.gravity[:, a_i]).size
    out: list[tuple[str, str, _Spec]] = []
    if family == "offset_curvature":
        out = [
            (family, f"order {k}", replace(spec, offset_order=k))
            for k in range(max(2, spec.offset_order + 1), max_order + 1)
        ]
    elif family == "sensitivity_curvature" and own_values >= 2:
        out = [
            (family, f"order {k}", replace(spec, gain_order=k))
            for k in range(max(2, spec.gain_order + 1), max_order + 1)
        ]
    elif family == "misalignment" and not spec.cross:
        sources = tuple(
            b for b in AXES if b != axis and np.unique(eng.gravity[:, AXES.index(b)]).size >= 2
        )
        if sources:
            out = [(family, "from " + "+".join(sources), replace(spec, cross=sources))]
    elif family == "drift" and not spec.drift:
        out = [(family, "linear", replace(spec, drift=True))]
    elif family == "extra":
        out = [
            (f"extra:{e}", e, replace(spec, extras=(*spec.extras, e)))
            for e in extras
            if e not in spec.extras
        ]
    return out


def _with_tau(spec: _Spec, variant: str, tau: float) -> _Spec:
    return replace(spec, tau=tau) if variant == "die" else replace(spec, rate_tau=tau)


def _search_tau(
    eng: _Engine, axis: str, spec: _Spec, tau_range_s: tuple[float, float], variant: str
) -> tuple[float, _CV]:
    """Grid then golden-section search of the lag time constant on held-out SSE."""
    cache: dict[float, _CV] = {}

    def score(tau: float) -> float:
        tau = float(f"{tau:.3g}")
        if tau not in cache:
            cache[tau] = eng.cv(axis, _with_tau(spec, variant, tau).terms(axis))
        return float(cache[tau].sse_blocks.sum())

    lo, hi = math.log(tau_range_s[0]), math.log(tau_range_s[1])
    grid = np.linspace(lo, hi, 12)
    vals = [score(math.exp(g)) for g in grid]
    i = int(np.argmin(vals))
    a, b = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    golden = (math.sqrt(5) - 1) / 2
    c, d = b - golden * (b - a), a + golden * (b - a)
    fc, fd = score(math.exp(c)), score(math.exp(d))
    for _ in range(10):
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - golden * (b - a)
            fc = score(math.exp(c))
        else:
            a, c, fc = c, d, fd
            d = a + golden * (b - a)
            fd = score(math.exp(d))
    best = min(cache, key=lambda t: float(cache[t].sse_blocks.sum()))
    return best, cache[best]


def _tau_se(eng: _Engine, axis: str, spec: _Spec) -> float:
    """Return the standard error of tau from the curvature of the in-sample SSE profile."""
    variant = "die" if spec.tau is not None else "rate"
    tau = spec.tau if spec.tau is not None else spec.rate_tau
    if tau is None:
        return math.nan
    h = 0.05 * tau
    s0 = eng.cv(axis, spec.terms(axis))
    sp = eng.cv(axis, _with_tau(spec, variant, tau + h).terms(axis)).sse_in
    sm = eng.cv(axis, _with_tau(spec, variant, max(tau - h, 1e-3)).terms(axis)).sse_in
    curv = (sp - 2 * s0.sse_in + sm) / (h * h)
    p = len(s0.terms)
    sigma2 = s0.sse_in / max(eng.n - p - 1, 1)
    return math.sqrt(2.0 * sigma2 / curv) if curv > 0 else math.nan


def _confounding(
    eng: _Engine, specs: Mapping[str, _Spec], extras: Sequence[str], threshold: float
) -> list[str]:
    """Pairs of effects whose signature columns correlate beyond ``threshold``."""
    found: dict[tuple[str, str], tuple[float, list[str]]] = {}
    w = eng.w
    for a in AXES:
        a_i = AXES.index(a)
        sig: dict[str, FloatArray] = {
            "temperature (linear tempco)": eng.basis("dT^1"),
            "offset_curvature": eng.basis("dT^2"),
            "thermal_lag": eng.basis(f"lag({_CONFOUND_TAU_S:g}):dT^1") - eng.basis("dT^1"),
            "drift": eng.basis("elapsed_h"),
        }
        if np.unique(eng.gravity[:, a_i]).size >= 2:
            sig["sensitivity_curvature"] = eng.basis("dT^2") * eng.gravity[:, a_i]
        for b in AXES:
            if b != a and np.unique(eng.gravity[:, AXES.index(b)]).size >= 2:
                sig[f"misalignment (gravity on {b})"] = eng.gravity[:, AXES.index(b)].copy()
        for e in extras:
            sig[f"extra:{e}"] = eng.basis(f"extra:{e}")
        names = list(sig)
        centred = {}
        for k in names:
            v = sig[k] - float((w * sig[k]).sum() / w.sum())
            nrm = math.sqrt(float((w * v * v).sum()))
            if nrm > 0:
                centred[k] = v / nrm
        keys = list(centred)
        for i in range(len(keys)):
            for j in range(i + 1, len(keys)):
                r = float((w * centred[keys[i]] * centred[keys[j]]).sum())
                if abs(r) > threshold:
                    pair = (keys[i], keys[j])
                    prev = found.get(pair, (0.0, []))
                    found[pair] = (max(prev[0], abs(r)), [*prev[1], a])
    out = []
    for (p1, p2), (r, axes) in found.items():
        out.append(
            f"{p1} and {p2} cannot be told apart on this data (|r| = {r:.3f} between their "
            f"model columns, axes {','.join(axes)}); which one is chosen is arbitrary: log a "
            "profile that separates them (e.g. heat and cool back, or soak at several temperatures)"
        )
    return out


def _structures(
    eng: _Engine,
    resid: Mapping[str, FloatArray],
    *,
    n_bins: int,
    alpha: float,
    min_structure_mg: float,
) -> list[Structure]:
    """Bin the residual by each observable and test the binned means (generic check)."""
    obs: dict[str, tuple[FloatArray, bool]] = {
        "temperature_c": (eng.temperature, False),
        "dtemp_dt_c_per_min": (eng.rate, False),
        "elapsed_s": (eng.elapsed_s, True),
    }
    for name, values in eng.extras.items():
        if np.nanstd(values) > 0:
            obs[name] = (values, False)
    out: list[Structure] = []
    part = eng.sample_part
    for a in AXES:
        r = resid[a]
        same = part[1:] == part[:-1]
        d = np.diff(r)[same]
        sigma = math.sqrt(float(np.mean(d * d)) / 2.0) if d.size else math.nan
        if not sigma > 0:
            continue
        # Pooled observables are binned within each gravity value of the axis, so that
        # structure proportional to gravity (opposite in opposite orientations) shows.
        grav_group = np.unique(eng.gravity[:, AXES.index(a)], return_inverse=True)[1]
        for name, (x, per_run) in obs.items():
            groups = eng.sample_run if per_run else grav_group.astype(np.int64)
            bins = _bin_ids(x, groups, n_bins, per_run)
            chi2, dof, n_used = _binned_chi2(r, bins, sigma)
            if dof < 1:
                continue
            p = chi2_sf(chi2, dof)
            rms = sigma * math.sqrt(max(chi2 - dof, 0.0) / n_used)
            note = ""
            sig = p < alpha and rms >= min_structure_mg
            if sig and per_run:
                note = _period_note(eng, r, sigma)
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


def _binned_chi2(r: FloatArray, bins: NDArray[np.int64], sigma: float) -> tuple[float, int, int]:
    counts = np.bincount(bins)
    sums = np.bincount(bins, weights=r)
    ok = counts >= 10
    if ok.sum() < 2:
        return 0.0, 0, 0
    n = counts[ok].astype(np.float64)
    means = sums[ok] / n
    grand = float((means * n).sum() / n.sum())
    chi2 = float((n * (means - grand) ** 2).sum()) / (sigma * sigma)
    return chi2, int(ok.sum()) - 1, int(n.sum())


def _period_note(eng: _Engine, r: FloatArray, sigma: float) -> str:
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


def _params(
    eng: _Engine,
    models: Mapping[str, AxisModel],
    axes: Sequence[str],
    family: str,
    specs: Mapping[str, _Spec],
) -> list[dict[str, Any]]:
    """Return the added parameters with standard errors, in readable units."""
    out: list[dict[str, Any]] = []
    for a in axes:
        m = models[a]
        s = eng.scale[a]
        if family == "thermal_lag":
            spec = specs[a]
            tau = spec.tau if spec.tau is not None else spec.rate_tau
            out.append(
                {"axis": a, "name": "tau", "value": tau, "se": _tau_se(eng, a, spec), "unit": "s"}
            )
            if spec.rate_tau is not None:
                # offset c·(T_lag - T_ref) beside c1·(T - T_ref): c·(T_lag - T) ≈ -c·tau·dT/dt.
                c, se = m.value("offset", f"lag({spec.rate_tau:.6g}):dT^1")
                k = -spec.rate_tau / 60.0 * 1000.0 / s
                out.append(
                    {
                        "axis": a,
                        "name": "rate coefficient",
                        "value": c * k,
                        "se": abs(se * k),
                        "unit": "mg per °C/min",
                    }
                )
            continue
        for t, c, var, est in zip(
            m.terms, m.coefficients, np.diag(m.covariance), m.estimated, strict=True
        ):
            if t.effect != (family if not family.startswith("extra:") else "extra"):
                continue
            if family.startswith("extra:") and t.basis != family:
                continue
            se = math.sqrt(max(float(var), 0.0)) if est else math.nan
            basis = t.basis.split(":", 1)[1] if t.basis.startswith("lag(") else t.basis
            if t.kind == "offset":
                unit = {"elapsed_h": "mg/h"}.get(
                    basis, "mg/°C^" + basis[3:] if basis.startswith("dT^") else "mg/unit"
                )
                factor = 1000.0 / s
            elif t.source == a:
                unit, factor = "%/°C^" + basis[3:], 100.0 / s
            else:
                unit, factor = "deg", math.degrees(1.0) / s
            out.append(
                {
                    "axis": a,
                    "name": t.name,
                    "value": float(c) * factor,
                    "se": se * factor,
                    "unit": unit,
                }
            )
    return out


def _fit_models(
    eng: _Engine, specs: Mapping[str, _Spec], axes: Sequence[str] = AXES
) -> tuple[dict[str, AxisModel], list[str], list[str]]:
    nominal = nominal_sensitivity(eng.session.units, eng.session.sensor)
    models: dict[str, AxisModel] = {}
    fixed_all: list[str] = []
    notes: list[str] = []
    for a in axes:
        i = AXES.index(a)
        model, fixed, axis_notes = fit_axis(
            a, specs[a].terms(a), eng.data, None if nominal is None else nominal[i], eng.references
        )
        models[a] = model
        fixed_all += fixed
        notes += axis_notes
    return models, fixed_all, notes


def _step_figures(
    eng: _Engine, specs: Mapping[str, _Spec]
) -> tuple[
    dict[str, float], dict[str, float], dict[str, float], dict[str, dict[str, float]], float, float
]:
    rms_in, rms_out, max_out, max_in = {}, {}, {}, {}
    fold_axis: dict[str, dict[str, float]] = {name: {} for name in eng.fold_names}
    for a in AXES:
        r_in, r_out = eng.residuals(a, specs[a].terms(a))
        rms_in[a] = _wrms(r_in, eng.w)
        rms_out[a] = _wrms(r_out, eng.w)
        max_out[a] = float(np.abs(r_out).max())
        max_in[a] = float(np.abs(r_in).max())
        for k, name in enumerate(eng.fold_names):
            sel = eng.sample_fold == k
            if sel.any():
                fold_axis[name][a] = _wrms(r_out[sel], eng.w[sel])
    return rms_in, rms_out, max_out, fold_axis, max(max_in.values()), max(max_out.values())


def _pooled(values: Mapping[str, float]) -> float:
    return math.sqrt(sum(v * v for v in values.values()) / len(values))


def diagnose(
    session: Session,
    calibration: Calibration | None = None,
    *,
    max_steps: int = 4,
    t_ref_c: float = 25.0,
    window_c: tuple[float, float] | None = (0.0, 60.0),
    folds: Literal["auto", "runs", "legs", "blocks"] = "auto",
    min_improvement: float = 0.10,
    alpha: float = 0.01,
    block_s: float = 300.0,
    max_order: int = 5,
    tau_range_s: tuple[float, float] = (5.0, 3600.0),
    families: Sequence[str] = FAMILIES,
    extras: Sequence[str] | None = None,
    confound_r: float = 0.95,
    steady_c_per_min: float = _STEADY_C_PER_MIN,
    n_bins: int = 30,
    alpha_structure: float = 1e-3,
    min_structure_mg: float = 0.1,
) -> Diagnosis:
    """Find what a calibration model misses and add it, choosing by held-out error only.

    Parameters
    ----------
    session : Session
    calibration : Calibration, optional
        The model to start from; default ``calibrate(session, t_ref_c=...,
        window_c=...)`` (the seed paper's model, joint fit). Its ``t_ref_c``
        and window are used when given.
    max_steps : int, default 4
        Most effects to add.
    t_ref_c : float, default 25
        Reference temperature (without ``calibration``).
    window_c : (float, float) or None, default (0, 60)
        Temperature window of the samples used (without ``calibration``).
    folds : {"auto", "runs", "legs", "blocks"}, default "auto"
        Held-out blocks: whole runs (three runs or more that keep every axis
        identified), legs of the temperature cycle, or thirds of each run.
    min_improvement : float, default 0.10
        Least relative cut of an axis' held-out RMS error for an effect to be added.
    alpha : float, default 0.01
        Level of the paired one-sided t-test over held-out blocks.
    block_s : float, default 300
        Length of the blocks of the paired test, s.
    max_order : int, default 5
        Highest order of the curvature families.
    tau_range_s : (float, float), default (5, 3600)
        Search range of the lag time constant, s.
    families : sequence of str, default :data:`FAMILIES`
        Families of the catalogue to try.
    extras : sequence of str, optional
        Extra columns to try (default: every one logged in all runs that varies).
    confound_r : float, default 0.95
        Correlation above which two effects are reported as confounded.
    steady_c_per_min : float, default 0.1
        Rate below which temperature counts as steady (legs, branch).
    n_bins : int, default 30
        Bins of the generic structure check per observable (per run for time).
    alpha_structure : float, default 1e-3
        Level of the generic structure check.
    min_structure_mg : float, default 0.1
        Smallest structure reported, mg rms.

    Returns
    -------
    Diagnosis

    Notes
    -----
    Never emits Python warnings; caveats are in :attr:`Diagnosis.warnings`.
    """
    unknown = [f for f in families if f not in FAMILIES]
    if unknown:
        raise ParameterError(f"unknown effect families {unknown}; available: {list(FAMILIES)}")
    if max_steps < 0 or not 0 <= min_improvement < 1 or not 0 < alpha < 1:
        raise ParameterError("max_steps >= 0, 0 <= min_improvement < 1 and 0 < alpha < 1 needed")
    notes: list[str] = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if calibration is None:
            base = calibrate(session, t_ref_c=t_ref_c, window_c=window_c)
        else:
            base = calibration
    specs: dict[str, _Spec] = {}
    for a in AXES:
        if a not in base.axes:
            raise ParameterError(f"the calibration has no model of axis {a}")
        spec = _spec_from_terms(a, base.axes[a].terms) if base.method != "paper" else None
        if spec is None:
            notes.append(
                f"axis {a}: the starting model is outside the diagnosis' model space "
                f"(method {base.method}); started from the seed paper's model, joint fit"
            )
            spec = _Spec()
        specs[a] = spec
    if calibration is not None and (
        base.method == "paper" or any(_spec_from_terms(a, base.axes[a].terms) is None for a in AXES)
    ):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            win = None if not np.all(np.isfinite(base.window_c)) else base.window_c
            base = calibrate(session, t_ref_c=base.t_ref_c, window_c=win)
    eng = _Engine(session, base, folds=folds, block_s=block_s, steady_c_per_min=steady_c_per_min)
    usable_extras = [
        e
        for e in (session.extra_columns if extras is None else extras)
        if e in eng.extras and float(np.nanstd(eng.extras[e])) > 0
    ]
    if extras is not None:
        missing = [e for e in extras if e not in usable_extras]
        if missing:
            notes.append(f"extra columns not usable (absent or constant): {', '.join(missing)}")
    warn = _confounding(eng, specs, usable_extras, confound_r)
    warn += notes
    if eng.n_folds < 2:
        warn.append("fewer than two held-out folds: nothing can be selected")
    cv_cur = {a: eng.cv(a, specs[a].terms(a)) for a in AXES}
    steps: list[Step] = []
    cand_rows: list[dict[str, Any]] = []

    def make_step(
        idx: int,
        effect: str,
        axes: tuple[str, ...],
        variant: dict[str, str],
        params: list[dict[str, Any]],
        cut: dict[str, float],
        pval: dict[str, float],
    ) -> Step:
        rms_in, rms_out, max_out, fold_axis, max_in_all, max_out_all = _step_figures(eng, specs)
        return Step(
            idx,
            effect,
            axes,
            variant,
            params,
            _pooled(rms_in),
            max_in_all,
            _pooled(rms_out),
            max_out_all,
            rms_in,
            rms_out,
            max_out,
            fold_axis,
            cut,
            pval,
            {a: specs[a].terms(a) for a in AXES},
        )

    steps.append(make_step(0, "base", (), {}, [], {}, {}))
    for step in range(1, max_steps + 1):
        if eng.n_folds < 2:
            break
        by_family: dict[str, list[_Candidate]] = {}
        for family in families:
            for a in AXES:
                cur = cv_cur[a]
                tried: list[tuple[str, str, _CV, _Spec]] = []
                if family == "thermal_lag":
                    if specs[a].tau is None and specs[a].rate_tau is None:
                        for variant, what in (("die", "die lag"), ("rate", "rate term")):
                            tau, cv = _search_tau(eng, a, specs[a], tau_range_s, variant)
                            tried.append(
                                (
                                    family,
                                    f"{what}, tau {tau:.3g} s",
                                    cv,
                                    _with_tau(specs[a], variant, tau),
                                )
                            )
                else:
                    for fam, label, spec in _variants(
                        family, a, specs[a], eng, max_order, usable_extras
                    ):
                        tried.append((fam, label, eng.cv(a, spec.terms(a)), spec))
                if not tried:
                    continue
                # Per family name (extra:NAME are separate families): parsimony among orders.
                groups: dict[str, list[tuple[str, str, _CV, _Spec]]] = {}
                for o in tried:
                    groups.setdefault(o[0], []).append(o)
                for fam, opts in groups.items():
                    best_rms = min(o[2].rms_out for o in opts)
                    pick = next(o for o in opts if o[2].rms_out <= best_rms * 1.01)
                    _, label, cv, spec = pick
                    cut = 1.0 - cv.rms_out / cur.rms_out if cur.rms_out > 0 else 0.0
                    t, p = _paired_p(cur.sse_blocks - cv.sse_blocks)
                    ok = cut >= min_improvement and p < alpha
                    cand = _Candidate(fam, a, label, spec, cv, cut, t, p, ok)
                    by_family.setdefault(fam, []).append(cand)
                    cand_rows.append(
                        {
                            "step": step,
                            "family": fam,
                            "axis": a,
                            "variant": label,
                            "rms_out_before_mg": cur.rms_out,
                            "rms_out_after_mg": cv.rms_out,
                            "cut_pct": 100.0 * cut,
                            "t": t,
                            "p_value": p,
                            "accepted": ok,
                        }
                    )
        best_fam, best_gain = None, 0.0
        for fam, cands in by_family.items():
            gain = sum(
                float(cv_cur[c.axis].sse_blocks.sum() - c.cv.sse_blocks.sum())
                for c in cands
                if c.accepted
            )
            if gain > best_gain:
                best_fam, best_gain = fam, gain
        if best_fam is None:
            break
        chosen = [c for c in by_family[best_fam] if c.accepted]
        for c in chosen:
            specs[c.axis] = c.spec
            cv_cur[c.axis] = c.cv
        # Revisit the lag of every axis given the terms added since it was chosen
        # (variant and tau); keep the better by held-out error.
        if best_fam != "thermal_lag":
            for a in AXES:
                if specs[a].tau is None and specs[a].rate_tau is None:
                    continue
                bare = replace(specs[a], tau=None, rate_tau=None)
                for variant in ("die", "rate"):
                    tau, cv = _search_tau(eng, a, bare, tau_range_s, variant)
                    if cv.rms_out < cv_cur[a].rms_out * 0.999:
                        specs[a], cv_cur[a] = _with_tau(bare, variant, tau), cv
        taus = [t for s in specs.values() for t in (s.tau, s.rate_tau) if t is not None]
        eng.drop_lag_cache(taus)
        axes = tuple(c.axis for c in chosen)
        models, _, _ = _fit_models(eng, specs, axes)
        family_key = best_fam
        params = _params(eng, models, axes, family_key, specs)
        steps.append(
            make_step(
                step,
                best_fam,
                axes,
                {c.axis: c.variant for c in chosen},
                params,
                {c.axis: c.cut for c in chosen},
                {c.axis: c.p for c in chosen},
            )
        )
    # Final calibration with the chosen terms (core least squares).
    models, fixed, fit_notes = _fit_models(eng, specs)
    added = [
        f"{s.effect} on {','.join(s.axes)} ({'; '.join(s.variant.values())})" for s in steps[1:]
    ]
    improved = Calibration(
        method="diagnosed",
        units=base.units,
        t_ref_c=base.t_ref_c,
        window_c=base.window_c,
        temperature_range_c=(float(eng.temperature.min()), float(eng.temperature.max())),
        axes=models,
        not_identified=tuple(fixed),
        notes=(*base.notes, *fit_notes, *(f"diagnosis added {x}" for x in added)),
        sensor=base.sensor,
        serial=base.serial,
        references=dict(eng.references),
        options={
            **base.options,
            "method": "diagnosed",
            "diagnosis": {"effects": [s.effect for s in steps[1:]], "scheme": eng.scheme},
        },
        provenance=dict(base.provenance),
    )
    resid = {a: eng.residuals(a, specs[a].terms(a))[0] for a in AXES}
    structures = _structures(
        eng, resid, n_bins=n_bins, alpha=alpha_structure, min_structure_mg=min_structure_mg
    )
    options: dict[str, Any] = {
        "max_steps": max_steps,
        "t_ref_c": base.t_ref_c,
        "window_c": list(base.window_c),
        "folds": folds,
        "min_improvement": min_improvement,
        "alpha": alpha,
        "block_s": block_s,
        "max_order": max_order,
        "tau_range_s": list(tau_range_s),
        "families": list(families),
        "extras": usable_extras,
        "confound_r": confound_r,
        "n_bins": n_bins,
        "alpha_structure": alpha_structure,
        "min_structure_mg": min_structure_mg,
    }
    return Diagnosis(
        base=base,
        calibration=improved,
        steps=tuple(steps),
        candidates=pd.DataFrame(cand_rows),
        structures=tuple(structures),
        warnings=tuple(warn),
        folds=tuple(eng.fold_names),
        scheme=eng.scheme,
        options=options,
        _engine=eng,
    )
