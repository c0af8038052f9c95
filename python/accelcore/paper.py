"""The equations of Sawicki & Walendziuk, as small functions.

Every function takes floats or array-likes (broadcast with NumPy) and returns a
``float`` for scalar input, else a float64 array.

- Eq. (2)-(3): :func:`acceleration_from_analog`, ``a = (V - V_0g) / S``.
- Eq. (6): :func:`acceleration_from_counts`, ``a = (A - A_0g) / S``.
- Eq. (4): :func:`norm_squared`, ``|a|^2 = a_x^2 + a_y^2 + a_z^2`` (1 g^2 at rest).
- Eq. (7)-(8): :func:`zero_g_offset_from_pair`, ``V_0g = (V_1 + V_2) / 2`` at ±1 g.
- Eq. (9)-(10): :func:`sensitivity_from_pair`, ``S = (V_2 - V_1) / (g_2 - g_1)``.
- Section 4: the temperature coefficients, "sensitivity change vs temperature"
  in %/°C and "zero-g offset change vs temperature" in mg/°C, and their
  conversions from the slopes of a line fit in output units per °C.
"""

from __future__ import annotations

from typing import Final, overload

import numpy as np
import numpy.typing as npt

__all__ = [
    "REFERENCE_TEMPERATURE_C",
    "acceleration_from_analog",
    "acceleration_from_counts",
    "norm_squared",
    "offset_change_mg",
    "offset_from_mg",
    "offset_tc_from_mg_per_c",
    "offset_tc_to_mg_per_c",
    "offset_to_mg",
    "sensitivity_at",
    "sensitivity_change_pct",
    "sensitivity_from_pair",
    "sensitivity_tc_from_pct_per_c",
    "sensitivity_tc_to_pct_per_c",
    "zero_g_offset_at",
    "zero_g_offset_from_pair",
]

REFERENCE_TEMPERATURE_C: Final = 25.0
"""Temperature (°C) at which datasheets specify offset and sensitivity."""

FloatArray = npt.NDArray[np.float64]


def _result(value: npt.ArrayLike) -> float | FloatArray:
    arr = np.asarray(value, dtype=np.float64)
    return float(arr) if arr.ndim == 0 else arr


def _f(value: npt.ArrayLike) -> FloatArray:
    return np.asarray(value, dtype=np.float64)


@overload
def acceleration_from_analog(
    output_v: float, zero_g_offset_v: float, sensitivity_v_per_g: float
) -> float: ...
@overload
def acceleration_from_analog(
    output_v: npt.ArrayLike, zero_g_offset_v: npt.ArrayLike, sensitivity_v_per_g: npt.ArrayLike
) -> FloatArray: ...
def acceleration_from_analog(
    output_v: npt.ArrayLike, zero_g_offset_v: npt.ArrayLike, sensitivity_v_per_g: npt.ArrayLike
) -> float | FloatArray:
    """Acceleration of an analog output, eq. (2)-(3).

    Parameters
    ----------
    output_v : float or array_like
        Output voltage, V.
    zero_g_offset_v : float or array_like
        Output at 0 g, V (eq. 2 subtracts it).
    sensitivity_v_per_g : float or array_like
        Sensitivity, V/g (eq. 3 divides by it).

    Returns
    -------
    float or ndarray
        Acceleration, g: ``(output_v - zero_g_offset_v) / sensitivity_v_per_g``.
    """
    return _result((_f(output_v) - _f(zero_g_offset_v)) / _f(sensitivity_v_per_g))


@overload
def acceleration_from_counts(
    counts: float, sensitivity_lsb_per_g: float, zero_g_offset_lsb: float = 0.0
) -> float: ...
@overload
def acceleration_from_counts(
    counts: npt.ArrayLike,
    sensitivity_lsb_per_g: npt.ArrayLike,
    zero_g_offset_lsb: npt.ArrayLike = 0.0,
) -> FloatArray: ...
def acceleration_from_counts(
    counts: npt.ArrayLike,
    sensitivity_lsb_per_g: npt.ArrayLike,
    zero_g_offset_lsb: npt.ArrayLike = 0.0,
) -> float | FloatArray:
    """Acceleration of a digital output, eq. (6).

    The paper divides raw counts by the datasheet sensitivity, with no offset
    (the MPU-9255 datasheet gives none); a calibrated offset may be subtracted.

    Parameters
    ----------
    counts : float or array_like
        Raw output, LSB.
    sensitivity_lsb_per_g : float or array_like
        Sensitivity, LSB/g (16384 for the MPU-9255 at AFS_SEL = 0).
    zero_g_offset_lsb : float or array_like, optional
        Output at 0 g, LSB. Default 0.

    Returns
    -------
    float or ndarray
        Acceleration, g.
    """
    return _result((_f(counts) - _f(zero_g_offset_lsb)) / _f(sensitivity_lsb_per_g))


@overload
def norm_squared(a_x_g: float, a_y_g: float, a_z_g: float) -> float: ...
@overload
def norm_squared(
    a_x_g: npt.ArrayLike, a_y_g: npt.ArrayLike, a_z_g: npt.ArrayLike
) -> FloatArray: ...
def norm_squared(
    a_x_g: npt.ArrayLike, a_y_g: npt.ArrayLike, a_z_g: npt.ArrayLike
) -> float | FloatArray:
    """Squared norm of the acceleration vector, eq. (4).

    A motionless, calibrated sensor gives 1 g².

    Parameters
    ----------
    a_x_g, a_y_g, a_z_g : float or array_like
        Components, g.

    Returns
    -------
    float or ndarray
        ``a_x² + a_y² + a_z²``, g².
    """
    x, y, z = _f(a_x_g), _f(a_y_g), _f(a_z_g)
    return _result(x * x + y * y + z * z)


@overload
def zero_g_offset_from_pair(
    output_pos: float, output_neg: float, g_pos: float = 1.0, g_neg: float = -1.0
) -> float: ...
@overload
def zero_g_offset_from_pair(
    output_pos: npt.ArrayLike,
    output_neg: npt.ArrayLike,
    g_pos: npt.ArrayLike = 1.0,
    g_neg: npt.ArrayLike = -1.0,
) -> FloatArray: ...
def zero_g_offset_from_pair(
    output_pos: npt.ArrayLike,
    output_neg: npt.ArrayLike,
    g_pos: npt.ArrayLike = 1.0,
    g_neg: npt.ArrayLike = -1.0,
) -> float | FloatArray:
    """Zero-g offset from two orientations, eq. (7)-(8).

    Parameters
    ----------
    output_pos, output_neg : float or array_like
        Outputs (V or LSB) with the axis at ``g_pos`` and ``g_neg``.
    g_pos, g_neg : float or array_like, optional
        The two accelerations along the axis, g; default +1 and -1.

    Returns
    -------
    float or ndarray
        Output at 0 g, in the outputs' unit: the intercept of the line through
        the two points, which at ±1 g is ``(output_pos + output_neg) / 2``.
    """
    v2, v1, g2, g1 = _f(output_pos), _f(output_neg), _f(g_pos), _f(g_neg)
    return _result((v1 * g2 - v2 * g1) / (g2 - g1))


@overload
def sensitivity_from_pair(
    output_pos: float, output_neg: float, g_pos: float = 1.0, g_neg: float = -1.0
) -> float: ...
@overload
def sensitivity_from_pair(
    output_pos: npt.ArrayLike,
    output_neg: npt.ArrayLike,
    g_pos: npt.ArrayLike = 1.0,
    g_neg: npt.ArrayLike = -1.0,
) -> FloatArray: ...
def sensitivity_from_pair(
    output_pos: npt.ArrayLike,
    output_neg: npt.ArrayLike,
    g_pos: npt.ArrayLike = 1.0,
    g_neg: npt.ArrayLike = -1.0,
) -> float | FloatArray:
    """Sensitivity from two orientations, eq. (9)-(10).

    Parameters
    ----------
    output_pos, output_neg : float or array_like
        Outputs (V or LSB) with the axis at ``g_pos`` and ``g_neg``.
    g_pos, g_neg : float or array_like, optional
        The two accelerations along the axis, g; default +1 and -1.

    Returns
    -------
    float or ndarray
        ``(output_pos - output_neg) / (g_pos - g_neg)``, output unit per g;
        ``(V_2 - V_1) / 2`` at ±1 g (eq. 10).
    """
    return _result((_f(output_pos) - _f(output_neg)) / (_f(g_pos) - _f(g_neg)))


@overload
def offset_to_mg(offset: float, sensitivity_per_g: float) -> float: ...
@overload
def offset_to_mg(offset: npt.ArrayLike, sensitivity_per_g: npt.ArrayLike) -> FloatArray: ...
def offset_to_mg(offset: npt.ArrayLike, sensitivity_per_g: npt.ArrayLike) -> float | FloatArray:
    """Express an offset (or an offset error or change) in mg.

    Parameters
    ----------
    offset : float or array_like
        Offset in output units (V or LSB), e.g. a zero-g offset of a digital
        part, or the deviation of an analog zero-g output from its nominal.
    sensitivity_per_g : float or array_like
        Sensitivity, output units per g.

    Returns
    -------
    float or ndarray
        ``offset / sensitivity_per_g * 1000``, mg.
    """
    return _result(_f(offset) / _f(sensitivity_per_g) * 1000.0)


@overload
def offset_from_mg(offset_mg: float, sensitivity_per_g: float) -> float: ...
@overload
def offset_from_mg(offset_mg: npt.ArrayLike, sensitivity_per_g: npt.ArrayLike) -> FloatArray: ...
def offset_from_mg(
    offset_mg: npt.ArrayLike, sensitivity_per_g: npt.ArrayLike
) -> float | FloatArray:
    """Inverse of :func:`offset_to_mg`: an offset in mg to output units.

    Parameters
    ----------
    offset_mg : float or array_like
        Offset, mg.
    sensitivity_per_g : float or array_like
        Sensitivity, output units per g.

    Returns
    -------
    float or ndarray
        ``offset_mg / 1000 * sensitivity_per_g``, output units.
    """
    return _result(_f(offset_mg) / 1000.0 * _f(sensitivity_per_g))


@overload
def offset_tc_to_mg_per_c(offset_slope_per_c: float, sensitivity_at_ref_per_g: float) -> float: ...
@overload
def offset_tc_to_mg_per_c(
    offset_slope_per_c: npt.ArrayLike, sensitivity_at_ref_per_g: npt.ArrayLike
) -> FloatArray: ...
def offset_tc_to_mg_per_c(
    offset_slope_per_c: npt.ArrayLike, sensitivity_at_ref_per_g: npt.ArrayLike
) -> float | FloatArray:
    """Zero-g offset change vs temperature in mg/°C from a fitted slope.

    As in the paper (Table 6), the offset is scaled to mg with the sensitivity
    at the reference temperature before taking the slope.

    Parameters
    ----------
    offset_slope_per_c : float or array_like
        Slope of zero-g offset vs temperature, output units (V or LSB) per °C.
    sensitivity_at_ref_per_g : float or array_like
        Sensitivity at the reference temperature (25 °C), output units per g.

    Returns
    -------
    float or ndarray
        ``offset_slope_per_c / sensitivity_at_ref_per_g * 1000``, mg/°C.
    """
    return _result(_f(offset_slope_per_c) / _f(sensitivity_at_ref_per_g) * 1000.0)


@overload
def offset_tc_from_mg_per_c(
    offset_tc_mg_per_c: float, sensitivity_at_ref_per_g: float
) -> float: ...
@overload
def offset_tc_from_mg_per_c(
    offset_tc_mg_per_c: npt.ArrayLike, sensitivity_at_ref_per_g: npt.ArrayLike
) -> FloatArray: ...
def offset_tc_from_mg_per_c(
    offset_tc_mg_per_c: npt.ArrayLike, sensitivity_at_ref_per_g: npt.ArrayLike
) -> float | FloatArray:
    """Inverse of :func:`offset_tc_to_mg_per_c`: mg/°C to output units per °C.

    Parameters
    ----------
    offset_tc_mg_per_c : float or array_like
        Zero-g offset change vs temperature, mg/°C.
    sensitivity_at_ref_per_g : float or array_like
        Sensitivity at the reference temperature, output units per g.

    Returns
    -------
    float or ndarray
        Offset slope, output units per °C.
    """
    return _result(_f(offset_tc_mg_per_c) / 1000.0 * _f(sensitivity_at_ref_per_g))


@overload
def sensitivity_tc_to_pct_per_c(
    sensitivity_slope_per_c: float, sensitivity_at_ref_per_g: float
) -> float: ...
@overload
def sensitivity_tc_to_pct_per_c(
    sensitivity_slope_per_c: npt.ArrayLike, sensitivity_at_ref_per_g: npt.ArrayLike
) -> FloatArray: ...
def sensitivity_tc_to_pct_per_c(
    sensitivity_slope_per_c: npt.ArrayLike, sensitivity_at_ref_per_g: npt.ArrayLike
) -> float | FloatArray:
    """Sensitivity change vs temperature in %/°C from a fitted slope.

    Parameters
    ----------
    sensitivity_slope_per_c : float or array_like
        Slope of sensitivity vs temperature, output units per g per °C.
    sensitivity_at_ref_per_g : float or array_like
        Sensitivity at the reference temperature (25 °C), output units per g.

    Returns
    -------
    float or ndarray
        ``sensitivity_slope_per_c / sensitivity_at_ref_per_g * 100``, %/°C.
    """
    return _result(_f(sensitivity_slope_per_c) / _f(sensitivity_at_ref_per_g) * 100.0)


@overload
def sensitivity_tc_from_pct_per_c(
    sensitivity_tc_pct_per_c: float, sensitivity_at_ref_per_g: float
) -> float: ...
@overload
def sensitivity_tc_from_pct_per_c(
    sensitivity_tc_pct_per_c: npt.ArrayLike, sensitivity_at_ref_per_g: npt.ArrayLike
) -> FloatArray: ...
def sensitivity_tc_from_pct_per_c(
    sensitivity_tc_pct_per_c: npt.ArrayLike, sensitivity_at_ref_per_g: npt.ArrayLike
) -> float | FloatArray:
    """Inverse of :func:`sensitivity_tc_to_pct_per_c`: %/°C to units per g per °C.

    Parameters
    ----------
    sensitivity_tc_pct_per_c : float or array_like
        Sensitivity change vs temperature, %/°C.
    sensitivity_at_ref_per_g : float or array_like
        Sensitivity at the reference temperature, output units per g.

    Returns
    -------
    float or ndarray
        Sensitivity slope, output units per g per °C.
    """
    return _result(_f(sensitivity_tc_pct_per_c) / 100.0 * _f(sensitivity_at_ref_per_g))


@overload
def sensitivity_change_pct(
    sensitivity_tc_pct_per_c: float, temperature_from_c: float, temperature_to_c: float
) -> float: ...
@overload
def sensitivity_change_pct(
    sensitivity_tc_pct_per_c: npt.ArrayLike,
    temperature_from_c: npt.ArrayLike,
    temperature_to_c: npt.ArrayLike,
) -> FloatArray: ...
def sensitivity_change_pct(
    sensitivity_tc_pct_per_c: npt.ArrayLike,
    temperature_from_c: npt.ArrayLike,
    temperature_to_c: npt.ArrayLike,
) -> float | FloatArray:
    """Relative sensitivity change over a temperature step, % (paper, section 4).

    Parameters
    ----------
    sensitivity_tc_pct_per_c : float or array_like
        Sensitivity change vs temperature, %/°C.
    temperature_from_c, temperature_to_c : float or array_like
        Start and end temperatures, °C.

    Returns
    -------
    float or ndarray
        ``tc * (temperature_to_c - temperature_from_c)``, % (0.01 %/°C from
        25 °C to 60 °C gives 0.35 %).
    """
    return _result(_f(sensitivity_tc_pct_per_c) * (_f(temperature_to_c) - _f(temperature_from_c)))


@overload
def offset_change_mg(
    offset_tc_mg_per_c: float, temperature_from_c: float, temperature_to_c: float
) -> float: ...
@overload
def offset_change_mg(
    offset_tc_mg_per_c: npt.ArrayLike,
    temperature_from_c: npt.ArrayLike,
    temperature_to_c: npt.ArrayLike,
) -> FloatArray: ...
def offset_change_mg(
    offset_tc_mg_per_c: npt.ArrayLike,
    temperature_from_c: npt.ArrayLike,
    temperature_to_c: npt.ArrayLike,
) -> float | FloatArray:
    """Zero-g offset change over a temperature step, mg (paper, section 4).

    Parameters
    ----------
    offset_tc_mg_per_c : float or array_like
        Zero-g offset change vs temperature, mg/°C.
    temperature_from_c, temperature_to_c : float or array_like
        Start and end temperatures, °C.

    Returns
    -------
    float or ndarray
        ``tc * (temperature_to_c - temperature_from_c)``, mg (1 mg/°C from 25 °C
        to 60 °C gives 35 mg).
    """
    return _result(_f(offset_tc_mg_per_c) * (_f(temperature_to_c) - _f(temperature_from_c)))


@overload
def sensitivity_at(
    temperature_c: float,
    sensitivity_at_ref_per_g: float,
    sensitivity_tc_pct_per_c: float,
    reference_temperature_c: float = REFERENCE_TEMPERATURE_C,
) -> float: ...
@overload
def sensitivity_at(
    temperature_c: npt.ArrayLike,
    sensitivity_at_ref_per_g: npt.ArrayLike,
    sensitivity_tc_pct_per_c: npt.ArrayLike,
    reference_temperature_c: npt.ArrayLike = REFERENCE_TEMPERATURE_C,
) -> FloatArray: ...
def sensitivity_at(
    temperature_c: npt.ArrayLike,
    sensitivity_at_ref_per_g: npt.ArrayLike,
    sensitivity_tc_pct_per_c: npt.ArrayLike,
    reference_temperature_c: npt.ArrayLike = REFERENCE_TEMPERATURE_C,
) -> float | FloatArray:
    """Sensitivity at a temperature under a linear tempco.

    Parameters
    ----------
    temperature_c : float or array_like
        Temperature, °C.
    sensitivity_at_ref_per_g : float or array_like
        Sensitivity at the reference temperature, output units per g.
    sensitivity_tc_pct_per_c : float or array_like
        Sensitivity change vs temperature, %/°C.
    reference_temperature_c : float or array_like, optional
        Reference temperature, °C; default 25.

    Returns
    -------
    float or ndarray
        ``S_ref * (1 + tc / 100 * (T - T_ref))``, output units per g
        (0.305 V/g at +0.01 %/°C gives 0.3061 V/g at 60 °C).
    """
    dt = _f(temperature_c) - _f(reference_temperature_c)
    return _result(_f(sensitivity_at_ref_per_g) * (1.0 + _f(sensitivity_tc_pct_per_c) / 100.0 * dt))


@overload
def zero_g_offset_at(
    temperature_c: float,
    zero_g_offset_at_ref: float,
    offset_tc_mg_per_c: float,
    sensitivity_at_ref_per_g: float,
    reference_temperature_c: float = REFERENCE_TEMPERATURE_C,
) -> float: ...
@overload
def zero_g_offset_at(
    temperature_c: npt.ArrayLike,
    zero_g_offset_at_ref: npt.ArrayLike,
    offset_tc_mg_per_c: npt.ArrayLike,
    sensitivity_at_ref_per_g: npt.ArrayLike,
    reference_temperature_c: npt.ArrayLike = REFERENCE_TEMPERATURE_C,
) -> FloatArray: ...
def zero_g_offset_at(
    temperature_c: npt.ArrayLike,
    zero_g_offset_at_ref: npt.ArrayLike,
    offset_tc_mg_per_c: npt.ArrayLike,
    sensitivity_at_ref_per_g: npt.ArrayLike,
    reference_temperature_c: npt.ArrayLike = REFERENCE_TEMPERATURE_C,
) -> float | FloatArray:
    """Zero-g offset at a temperature under a linear tempco given in mg/°C.

    Parameters
    ----------
    temperature_c : float or array_like
        Temperature, °C.
    zero_g_offset_at_ref : float or array_like
        Zero-g offset at the reference temperature, output units.
    offset_tc_mg_per_c : float or array_like
        Zero-g offset change vs temperature, mg/°C.
    sensitivity_at_ref_per_g : float or array_like
        Sensitivity at the reference temperature (scales mg to output units).
    reference_temperature_c : float or array_like, optional
        Reference temperature, °C; default 25.

    Returns
    -------
    float or ndarray
        ``offset_ref + tc / 1000 * S_ref * (T - T_ref)``, output units.
    """
    dt = _f(temperature_c) - _f(reference_temperature_c)
    slope = _f(offset_tc_mg_per_c) / 1000.0 * _f(sensitivity_at_ref_per_g)
    return _result(_f(zero_g_offset_at_ref) + slope * dt)
