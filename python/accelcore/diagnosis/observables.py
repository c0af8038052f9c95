"""Observables of a session beside the calibration's error: rate of temperature, legs, residuals.

:func:`residuals` gives, per decimated sample, the error in mg against the gravity the
run's orientation implies, beside the observables (temperature, its rate, elapsed time,
branch, extra columns); :func:`rate_c_per_min` and :func:`leg_labels` are its pieces.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from accelcore.errors import InsufficientDataError, TemperatureRangeWarning
from accelcore.input.records import records
from accelcore.input.session import Session
from accelcore.result.calibration import Calibration

__all__ = ["MIN_LEG_S", "STEADY_C_PER_MIN", "leg_labels", "rate_c_per_min", "residuals"]

FloatArray = NDArray[np.float64]

_RATE_HALF_WINDOW_S = 60.0
#: Rate of temperature below which it counts as steady, °C/min.
STEADY_C_PER_MIN = 0.1


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


#: Legs shorter than this join a neighbour (:func:`leg_labels`), s.
MIN_LEG_S = 300.0


def leg_labels(
    time_s: FloatArray,
    temperature_c: FloatArray,
    *,
    steady_c_per_min: float = STEADY_C_PER_MIN,
    min_leg_s: float = MIN_LEG_S,
    rate: FloatArray | None = None,
) -> tuple[NDArray[np.int64], list[str]]:
    """Split a run into monotonic legs of its temperature cycle.

    Samples are heating or cooling by the sign of :func:`rate_c_per_min`
    (steady within ``steady_c_per_min``); contiguous stretches of one sign form
    a leg, steady stretches join the leg before them (or after, at the start),
    and legs shorter than ``min_leg_s`` join a neighbour.

    ``rate``: :func:`rate_c_per_min` of the run, when the caller has it.

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
    if rate is None:
        rate = rate_c_per_min(t, temperature_c)
    sign = _branch_sign(rate, steady_c_per_min)
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


def residuals(calibration: Calibration, session: Session) -> pd.DataFrame:
    """Error of a calibration on every decimated sample of a session, with the observables.

    Each run's raw output is compensated (:meth:`Calibration.compensate`, with
    time and extra columns), the gravity its orientation implies subtracted,
    and the result given in mg; ``err_norm_mg`` is ``|a| - 1 g`` in mg.
    Samples outside the calibrated temperature range are included (the model
    extrapolated, its curvature along its tangent at the range's edge, without the range warning)
    and flagged by ``in_range``.

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
    for i, run in enumerate(records(session)):
        if len(run) == 0:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TemperatureRangeWarning)
            acc = calibration.compensate(run.output, run.temperature_c, run.time_s, run.extras)
        err = (acc - run.gravity_g[None, :]) * 1000.0
        norm = (np.linalg.norm(acc, axis=1) - 1.0) * 1000.0
        rate = rate_c_per_min(run.time_s, run.temperature_c)
        sign = _branch_sign(rate, STEADY_C_PER_MIN)
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
