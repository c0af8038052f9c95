"""The chamber's temperature profile: a soak, then a linear ramp (and optionally back)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from accelcore.simulate.truth import FloatArray

__all__ = ["temperature_profile"]


def temperature_profile(
    time_s: npt.ArrayLike,
    *,
    t_start_c: float,
    t_end_c: float,
    soak_s: float,
    cool_back: bool = False,
) -> FloatArray:
    """Chamber temperature: a soak, then a linear ramp (and optionally back).

    Parameters
    ----------
    time_s : array_like
        Increasing sample times, s; the profile ends at the last one.
    t_start_c, t_end_c : float
        Soak temperature and ramp end temperature, °C.
    soak_s : float
        Soak duration at ``t_start_c``, s.
    cool_back : bool, optional
        If true, the time after the soak is split in half: ramp to ``t_end_c``,
        then back to ``t_start_c``.

    Returns
    -------
    ndarray
        Temperature at each time, °C.
    """
    t = np.asarray(time_s, dtype=np.float64)
    t0 = float(t[0]) + soak_s
    t1 = float(t[-1])
    span = t1 - t0
    if span <= 0.0:
        raise ValueError("the soak must end before the last sample")
    if cool_back:
        frac = np.clip((t - t0) / (span / 2.0), 0.0, 2.0)
        frac = np.where(frac <= 1.0, frac, 2.0 - frac)
    else:
        frac = np.clip((t - t0) / span, 0.0, 1.0)
    return t_start_c + (t_end_c - t_start_c) * frac
