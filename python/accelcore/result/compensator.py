"""Streaming compensation: raw output to acceleration in g (the 3×3 model solved in Rust)."""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from typing import TypeGuard

import numpy as np
from numpy.typing import ArrayLike, NDArray

from accelcore._accelcore import compensate as _compensate
from accelcore._accelcore import first_order_lag
from accelcore.errors import ParameterError, TemperatureRangeWarning
from accelcore.model import (
    Basis,
    Features,
    Hinge,
    LaggedTemperaturePower,
    TemperaturePower,
    TemperatureRate,
)

__all__ = ["Compensator", "continued_beyond_range", "needs_temperature"]

#: Most passes of the fixed point that solves a model with terms in the force (g_b^2).
MAX_FORCE_PASSES = 20

#: The force has settled when no sample moves by more than this between passes, g
#: (1e-12 g: a few ulps of 1 g, far below any sensor's resolution).
FORCE_TOLERANCE_G = 1e-12


def needs_temperature(basis: Basis) -> bool:
    """Tell whether a basis reads the temperature (``dT^k``, its lag, ``dTdt``, a hinge on them).

    Parameters
    ----------
    basis : Basis

    Returns
    -------
    bool
    """
    inner = basis.inner if isinstance(basis, Hinge) else basis
    return inner.temperature_order is not None or isinstance(inner, TemperatureRate)


def continued_beyond_range(
    basis: Basis,
) -> TypeGuard[TemperaturePower | LaggedTemperaturePower]:
    """Tell whether a basis continues along its tangent beyond the calibrated range.

    The temperature's powers of order 2 and more (curvature, lagged or not): a
    polynomial fitted over a range says little beyond it, and its high orders grow
    fastest there (a 4th/5th-order offset fitted over 15…35 °C was 47 mg off at 5 and
    55 °C, where the line alone was 7 mg off). Beyond the range's edge each such power
    takes its value and slope at the edge and goes on as a line, so the curvature
    continues as its tangent: a smooth (C1) extension that grows no faster than a
    line. (PX4 and ArduPilot hold their whole polynomial at its end value; held so,
    a true cubic fitted over −5…46 °C was 5.8 mg off up to 62 °C, continued 2.3, the
    line alone 5.9.) The linear terms and the hinges of a piecewise-linear function,
    lines beyond their last knot, extrapolate as they are.

    Parameters
    ----------
    basis : Basis

    Returns
    -------
    bool
    """
    return isinstance(basis, (TemperaturePower, LaggedTemperaturePower)) and basis.order >= 2


def _continued_power(
    x: NDArray[np.float64], lo: float, hi: float, t_ref_c: float, order: int
) -> NDArray[np.float64]:
    """``(x - t_ref_c)^order`` inside ``lo…hi``, its tangent at the edge beyond."""
    out = np.asarray((x - t_ref_c) ** order)
    for edge, beyond in ((hi, x > hi), (lo, x < lo)):
        if np.any(beyond):
            e = edge - t_ref_c
            out = np.where(beyond, e**order + order * e ** (order - 1) * (x - edge), out)
    return out


class _CarriedFeatures(Features):
    """Features of one chunk whose lag filters start from the previous chunk's state."""

    carried: dict[tuple[float, float | None], tuple[float, float, float]]

    def lagged_temperature_c(
        self, tau_s: float, cool_tau_s: float | None = None
    ) -> NDArray[np.float64]:
        key = (tau_s, cool_tau_s)
        if key not in self._lag_cache:
            time_s = self._need_time(f"lag({tau_s})")
            state = self.carried.get(key)
            if state is None:
                y = first_order_lag(time_s, self.temperature_c, tau_s, tau_cool_s=cool_tau_s)
            else:
                last_t, last_x, last_y = state
                t_ext = np.concatenate([[last_t], time_s])
                x_ext = np.concatenate([[last_x], self.temperature_c])
                y = first_order_lag(t_ext, x_ext, tau_s, last_y, tau_cool_s=cool_tau_s)[1:]
            self._lag_cache[key] = y
        return self._lag_cache[key]


class Compensator:
    """Streaming compensation: push consecutive chunks of one log, get acceleration in g.

    Made by :meth:`Calibration.compensator` from the calibration's coefficients:
    ``offset`` (3, k) and ``gain`` (9, k, row ``3·axis + source``) over ``bases`` (k).
    Time is measured from the first chunk's first sample; lag filters continue
    from the previous chunk's last sample, so the result does not depend on the
    chunking.

    Attributes
    ----------
    n_out_of_range : int
        Samples so far outside the calibrated temperature range (warned once); 0 for
        a model without temperature terms, which extrapolates nothing.
    n_rows : int
        Samples so far.
    """

    def __init__(
        self,
        bases: Sequence[Basis],
        offset: NDArray[np.float64],
        gain: NDArray[np.float64],
        *,
        references: Mapping[str, float],
        t_ref_c: float,
        temperature_range_c: tuple[float, float],
        warn_stacklevel: int = 3,
    ) -> None:
        self._bases = list(bases)
        self._offset, self._gain = offset, gain
        self._references = dict(references)
        self._t_ref_c = t_ref_c
        self._range_c = temperature_range_c
        # A model without temperature terms extrapolates nothing in temperature.
        self._reads_temperature = any(needs_temperature(b) for b in self._bases)
        self._t0: float | None = None
        self._carried: dict[tuple[float, float | None], tuple[float, float, float]] = {}
        self._warned = False
        self._stacklevel = warn_stacklevel
        self.n_out_of_range = 0
        self.n_rows = 0

    def push(
        self,
        raw: ArrayLike,
        temp_c: ArrayLike | None,
        time_s: ArrayLike | None = None,
        extras: Mapping[str, ArrayLike] | None = None,
    ) -> NDArray[np.float64]:
        """Compensate the next chunk; see :meth:`Calibration.compensate` for the arguments."""
        raw_a = np.ascontiguousarray(raw, dtype=np.float64)
        if raw_a.ndim != 2 or raw_a.shape[1] != 3:
            raise ParameterError(f"raw must have shape (n, 3), got {raw_a.shape}")
        if temp_c is None:
            needing = [b.name for b in self._bases if needs_temperature(b)]
            if needing:
                err = ParameterError(
                    f"temp_c is None, but the model has temperature terms ({', '.join(needing)}):"
                    " pass the logged temperature, °C"
                )
                err.parameter = "temp_c"
                raise err
            temp_c = np.full(raw_a.shape[0], np.nan)  # read by no term of this model
        temp = np.ascontiguousarray(temp_c, dtype=np.float64).reshape(-1)
        if temp.shape[0] != raw_a.shape[0]:
            raise ParameterError(f"temp_c has {temp.shape[0]} values for {raw_a.shape[0]} rows")
        self._check_range(temp)
        rel = None
        if time_s is not None:
            time_a = np.asarray(time_s, dtype=np.float64).reshape(-1)
            if time_a.shape[0] != temp.shape[0]:
                raise ParameterError(f"time_s has {time_a.shape[0]} values for {temp.shape[0]}")
            if self._t0 is None and time_a.size:
                self._t0 = float(time_a[0])
            rel = time_a - (self._t0 or 0.0)
        feats = _CarriedFeatures(
            temp,
            rel,
            {k: np.asarray(v, dtype=np.float64) for k, v in (extras or {}).items()},
            self._t_ref_c,
        )
        feats.carried = self._carried
        n = raw_a.shape[0]
        forced = [(j, b) for j, b in enumerate(self._bases) if b.needs_gravity]
        # Bases of the force itself (g_b^2) are first read at 0 g; the force solved
        # with them is then fed back until it settles (a fixed point: the terms are
        # small beside the sensitivity, so each pass shrinks the error by their ratio).
        # Each sample iterates until it settles itself, so chunks do not matter.
        feats.gravity_g = np.zeros((n, 3))
        if self._bases:
            basis = np.column_stack([self._column(b, feats) for b in self._bases])
        else:
            basis = np.zeros((n, 0))
        g = _compensate(raw_a, np.ascontiguousarray(basis), self._offset, self._gain)
        active = np.arange(n) if forced else np.zeros(0, dtype=np.intp)
        for _ in range(MAX_FORCE_PASSES):
            if active.size == 0:
                break
            rows = basis[active]
            for j, b in forced:
                rows[:, j] = b.at_gravity(g[active], active.size)
            g_next = _compensate(raw_a[active], rows, self._offset, self._gain)
            moved = np.max(np.abs(g_next - g[active]), axis=1)
            g[active] = g_next
            active = active[~(moved <= FORCE_TOLERANCE_G)]
        if n and rel is not None:
            for key, y in feats._lag_cache.items():
                self._carried[key] = (float(rel[-1]), float(temp[-1]), float(y[-1]))
        self.n_rows += n
        return g

    def _column(self, basis: Basis, feats: Features) -> NDArray[np.float64]:
        """One basis over the chunk; a curvature beyond the range along its tangent."""
        lo, hi = self._range_c
        if not (lo <= hi and continued_beyond_range(basis)):
            return basis.evaluate(feats, self._references)
        x = (
            feats.lagged_temperature_c(basis.tau_s, basis.cool_tau_s)
            if isinstance(basis, LaggedTemperaturePower)
            else feats.temperature_c
        )
        return _continued_power(x, lo, hi, feats.t_ref_c, basis.order)

    def _check_range(self, temp: NDArray[np.float64]) -> None:
        if not self._reads_temperature:
            return
        finite = temp[np.isfinite(temp)]
        if finite.size == 0:
            return
        lo, hi = self._range_c
        outside = int(np.count_nonzero((finite < lo) | (finite > hi)))
        self.n_out_of_range += outside
        if outside and not self._warned:
            self._warned = True
            warnings.warn(
                TemperatureRangeWarning(
                    f"{outside} of {finite.size} samples lie outside the calibrated range "
                    f"{lo:.2f}…{hi:.2f} °C (data spans {finite.min():.2f}…{finite.max():.2f} "
                    "°C); the model is extrapolated there, its curvature (powers of the "
                    "temperature of order 2 and more) along its tangent at the range's edge"
                ),
                stacklevel=self._stacklevel,
            )
