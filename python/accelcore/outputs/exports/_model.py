"""Our model evaluated as the flight stacks see it, and its best cubic-offset approximation.

PX4 and ArduPilot compensate an accelerometer with one cubic polynomial of the
logged temperature per axis, subtracted from the reading in m/s². Our model can
hold more (sensitivity drift, cross-axis terms, thermal lag, dT/dt, drift, extra
columns), so an export is an approximation: per axis, the cubic that is closest in
the least-squares sense to our model's offset over the calibrated temperature
range. The model is evaluated along a thermal cycle (held at the range's lower end,
ramped up to its upper end and back at ``ramp_c_per_min``), so terms that depend on
the temperature's history (a lagged die, dT/dt) show up in the residual instead of
vanishing at steady state. The samples are equally spaced in temperature, so the fit
weighs the range uniformly.

The model is evaluated through :func:`accelcore.model.design_columns`, never by
reading basis names: any term the model room can evaluate is exported.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from accelcore.constants import AXES, STANDARD_GRAVITY
from accelcore.core import LeastSquares
from accelcore.errors import InsufficientDataError, ParameterError
from accelcore.model import Features, design_columns
from accelcore.result.calibration import Calibration

__all__ = [
    "CubicOffset",
    "CubicOffsetFit",
    "describe",
    "fit_cubic_offsets",
    "float32_text",
    "log_sensor",
    "model_at",
    "model_response",
]

FloatArray = NDArray[np.float64]

#: Samples per leg of the thermal cycle (up, then down).
CYCLE_SAMPLES = 401


class _ExtrasAtReference(Mapping[str, FloatArray]):
    """Every extra column held at its reference value, so its terms contribute nothing."""

    def __init__(self, references: Mapping[str, float], n: int) -> None:
        self._references = references
        self._n = n

    def __getitem__(self, name: str) -> FloatArray:
        return np.full(self._n, self._references.get(f"extra:{name}", 0.0))

    def __iter__(self) -> Iterator[str]:
        return iter(())

    def __len__(self) -> int:
        return 0


class _HeldFeatures(Features):
    """Features of temperatures each held long enough that every lag has settled."""

    def lagged_temperature_c(self, tau_s: float, cool_tau_s: float | None = None) -> FloatArray:
        return self.temperature_c


def local_gravity(cal: Calibration) -> float:
    """Return the m/s² of 1 g in the calibration: the session's local gravity, else standard."""
    value = cal.options.get("gravity_m_s2")
    return float(value) if isinstance(value, (int, float)) and value > 0 else STANDARD_GRAVITY


def model_response(cal: Calibration, features: Features) -> tuple[FloatArray, FloatArray]:
    """Offset and gain matrix of the model on each sample.

    Parameters
    ----------
    cal : Calibration
    features : Features
        The samples' observables.

    Returns
    -------
    offset : ndarray, shape (n, 3)
        Session units.
    gain : ndarray, shape (n, 3, 3)
        ``gain[i, a, b]``: output of axis ``a`` per g of gravity on axis ``b``, session units/g.

    Raises
    ------
    InsufficientDataError
        When an axis is missing or not calibrated.
    """
    n = len(features)
    offset = np.empty((n, 3))
    gain = np.empty((n, 3, 3))
    for a_i, a in enumerate(AXES):
        m = cal.axes.get(a)
        if m is None or not np.all(np.isfinite(m.coefficients)):
            raise InsufficientDataError(f"axis {a} is not calibrated; it cannot be exported")
        zero = design_columns(m.terms, features, np.zeros(3), cal.references) @ m.coefficients
        offset[:, a_i] = zero
        for b_i in range(3):
            unit = np.zeros(3)
            unit[b_i] = 1.0
            with_g = design_columns(m.terms, features, unit, cal.references) @ m.coefficients
            gain[:, a_i, b_i] = with_g - zero
    return offset, gain


def model_at(cal: Calibration, temperature_c: float) -> tuple[FloatArray, FloatArray]:
    """Offset (3,) and gain matrix (3, 3) with the temperature held at ``temperature_c``.

    Held means settled: lagged temperatures equal the logged one, dT/dt is 0, no time
    has elapsed and every extra column is at its reference value.
    """
    feats = _HeldFeatures(
        np.array([float(temperature_c)]),
        np.zeros(1),
        _ExtrasAtReference(cal.references, 1),
        cal.t_ref_c,
    )
    offset, gain = model_response(cal, feats)
    return offset[0], gain[0]


def thermal_cycle(lo_c: float, hi_c: float, ramp_c_per_min: float) -> tuple[FloatArray, FloatArray]:
    """Return temperature and time of a cycle lo → hi → lo at a constant rate, even in T."""
    up = np.linspace(lo_c, hi_c, CYCLE_SAMPLES, dtype=np.float64)
    temp: FloatArray = np.concatenate([up, up[::-1][1:]])
    step_s = (hi_c - lo_c) / (CYCLE_SAMPLES - 1) / ramp_c_per_min * 60.0
    time_s: FloatArray = np.arange(temp.size, dtype=np.float64) * step_s
    return temp, time_s


@dataclass(frozen=True)
class CubicOffset:
    """The cubic approximation of one axis' thermal offset.

    Attributes
    ----------
    axis : str
    coefficients_m_s2 : tuple of 4 float
        ``c0 … c3`` of ``c0 + c1·d + c2·d² + c3·d³``, ``d = T - t_ref_c``, in m/s²/°C^k.
    max_residual_mg, rms_residual_mg : float
        Largest and RMS difference between the cubic and our model over the cycle, mg.
    sensitivity_drift_mg_per_g : float
        Largest change of the axis' own sensitivity over the range, relative to
        T_ref, in mg per g of acceleration on the axis: what an offset-only format
        cannot carry (folding it in at one gravity, ``gravity_g``, corrects that
        attitude only).
    """

    axis: str
    coefficients_m_s2: tuple[float, float, float, float]
    max_residual_mg: float
    rms_residual_mg: float
    sensitivity_drift_mg_per_g: float


@dataclass(frozen=True)
class CubicOffsetFit:
    """Per-axis cubic approximations of the thermal offset, with what they lose.

    Attributes
    ----------
    t_ref_c : float
        Reference temperature of the polynomials, °C.
    range_c : tuple of float
        Temperature range approximated (the calibration's fitted range), °C.
    ramp_c_per_min : float
        Rate of the thermal cycle the model was evaluated on.
    gravity_g : tuple of float or None
        Gravity (g, sensor axes) whose sensitivity drift was folded into the offsets.
    relative : bool
        True when the polynomials give the offset's change from its value at
        ``t_ref_c`` (``c0`` is then 0 for a model that is exactly cubic).
    offset_at_t_ref_m_s2 : tuple of float
        The offset at ``t_ref_c``, m/s², per axis (left out of ``c0`` when ``relative``).
    axes : tuple of CubicOffset
    """

    t_ref_c: float
    range_c: tuple[float, float]
    ramp_c_per_min: float
    gravity_g: tuple[float, float, float] | None
    relative: bool
    offset_at_t_ref_m_s2: tuple[float, float, float]
    axes: tuple[CubicOffset, ...]

    @property
    def max_residual_mg(self) -> float:
        """Largest residual of any axis, mg."""
        return max(a.max_residual_mg for a in self.axes)

    @property
    def rms_residual_mg(self) -> float:
        """Largest per-axis RMS residual, mg."""
        return max(a.rms_residual_mg for a in self.axes)

    def lines(self) -> list[str]:
        """Plain-text lines: range, reference and per-axis residuals."""
        lo, hi = self.range_c
        out = [
            f"cubic offset about T_ref {self.t_ref_c:.2f} °C over {lo:.2f}…{hi:.2f} °C "
            f"(model evaluated on a cycle ramped at {self.ramp_c_per_min:g} °C/min)",
            "  axis  max residual  rms residual  sensitivity drift not carried",
        ]
        for a in self.axes:
            out.append(
                f"  {a.axis:<4}  {a.max_residual_mg:9.4f} mg  {a.rms_residual_mg:9.4f} mg"
                f"  {a.sensitivity_drift_mg_per_g:9.4f} mg/g"
            )
        if self.gravity_g is not None:
            g = ", ".join(f"{v:g}" for v in self.gravity_g)
            out.append(f"  sensitivity drift folded into the offset at gravity ({g}) g")
        return out


def fit_cubic_offsets(
    cal: Calibration,
    *,
    t_ref_c: float,
    ramp_c_per_min: float,
    gravity_g: Sequence[float] | None,
    relative: bool,
) -> CubicOffsetFit:
    """Least-squares cubic in ``T - t_ref_c`` of each axis' offset in m/s² over the range.

    The offset of axis ``a`` is ``g0 / S_a · (o_a(T) + Σ_b (G_ab(T) - G_ab(T0)) · g_b)``:
    our zero-g offset (session units) converted to m/s² by the axis' own sensitivity
    ``S_a`` at our reference ``T0`` (g0 = standard gravity), plus, when ``gravity_g`` is
    given, the sensitivity drift the reading shows under that gravity.

    Raises
    ------
    ParameterError
        Without a finite temperature range, or with a non-positive ramp rate.
    """
    lo, hi = (float(v) for v in cal.temperature_range_c)
    if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
        raise ParameterError(
            f"the calibration's temperature range {lo}…{hi} °C is not a finite interval: "
            "a temperature polynomial cannot be fitted"
        )
    if not ramp_c_per_min > 0:
        raise ParameterError(f"ramp_c_per_min must be > 0, got {ramp_c_per_min}")
    g = np.zeros(3) if gravity_g is None else np.asarray(gravity_g, dtype=np.float64)
    if g.shape != (3,) or not np.all(np.isfinite(g)):
        raise ParameterError(f"gravity_g must be three finite numbers, got {gravity_g!r}")

    _, gain_0 = model_at(cal, cal.t_ref_c)
    sens = np.diag(gain_0).copy()
    if not np.all(sens != 0):
        raise InsufficientDataError("a sensitivity at T_ref is zero: offsets cannot be scaled")
    g0 = local_gravity(cal)
    scale = g0 / sens

    def offset_m_s2(offset: FloatArray, gain: FloatArray) -> FloatArray:
        return scale * (offset + (gain - gain_0) @ g)

    temp, time_s = thermal_cycle(lo, hi, ramp_c_per_min)
    feats = Features(temp, time_s, _ExtrasAtReference(cal.references, temp.size), cal.t_ref_c)
    off, gain = model_response(cal, feats)
    target = offset_m_s2(off, gain)
    off_r, gain_r = model_at(cal, t_ref_c)
    at_ref = offset_m_s2(off_r, gain_r)
    if relative:
        target = target - at_ref

    half = max(abs(lo - t_ref_c), abs(hi - t_ref_c))
    d = (temp - t_ref_c) / half
    design = np.column_stack([np.ones_like(d), d, d**2, d**3])
    drift = np.max(np.abs(gain[:, [0, 1, 2], [0, 1, 2]] - np.diag(gain_0)), axis=0) / np.abs(sens)
    axes = []
    for a_i, a in enumerate(AXES):
        lsq = LeastSquares(4, column_names=["1", "dT", "dT^2", "dT^3"])
        lsq.push(design, target[:, a_i])
        scaled = lsq.finish().coefficients
        resid_mg = (design @ scaled - target[:, a_i]) / g0 * 1000.0
        c = scaled / half ** np.arange(4)
        axes.append(
            CubicOffset(
                axis=a,
                coefficients_m_s2=(float(c[0]), float(c[1]), float(c[2]), float(c[3])),
                max_residual_mg=float(np.max(np.abs(resid_mg))),
                rms_residual_mg=float(np.sqrt(np.mean(resid_mg**2))),
                sensitivity_drift_mg_per_g=float(drift[a_i] * 1000.0),
            )
        )
    return CubicOffsetFit(
        t_ref_c=float(t_ref_c),
        range_c=(lo, hi),
        ramp_c_per_min=float(ramp_c_per_min),
        gravity_g=None if gravity_g is None else (float(g[0]), float(g[1]), float(g[2])),
        relative=relative,
        offset_at_t_ref_m_s2=(float(at_ref[0]), float(at_ref[1]), float(at_ref[2])),
        axes=tuple(axes),
    )


def float32_text(value: float) -> str:
    """Shortest decimal text that reads back as the same 32-bit float (what the stacks store).

    Positional for ordinary magnitudes (``50``, ``0.002``), scientific for tiny or huge ones.
    """
    x = np.float32(value)
    if not np.isfinite(x):
        raise ParameterError(f"{value!r} is not a finite 32-bit float")
    if x == 0 or 1e-4 <= abs(x) < 1e7:
        return np.format_float_positional(x, unique=True, trim="-")
    return np.format_float_scientific(x, unique=True, trim="-")


def describe(cal: Calibration) -> str:
    """Which calibration this is, in a few words (for file comments and summaries)."""
    who = cal.sensor or "unknown sensor"
    if cal.serial:
        who += f" #{cal.serial}"
    return f"{who} ({cal.method} calibration, units {cal.units})"


def log_sensor(cal: Calibration) -> dict[str, int]:
    """Return the logged sensor's identity in its flight stack, as the provenance keeps it.

    ``px4_device_id``, ``px4_instance``, ``ardupilot_imu``
    (:attr:`accelcore.input.session.Session.log_sensor`); entries that are not whole
    numbers are left out (a hand-edited file).
    """
    found = cal.provenance.get("log_sensor")
    if not isinstance(found, Mapping):
        return {}
    return {
        str(k): int(v) for k, v in found.items() if isinstance(v, int) and not isinstance(v, bool)
    }
