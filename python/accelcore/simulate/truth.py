"""The true linear thermal model of a simulated sensor (:class:`SensorTruth`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from accelcore import datasheets, paper

__all__ = ["FloatArray", "SensorTruth", "axis3"]

FloatArray = npt.NDArray[np.float64]


def axis3(value: npt.ArrayLike, name: str) -> FloatArray:
    """Return ``value`` as a read-only finite array, one value per axis (scalars broadcast)."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        arr = np.full(3, float(arr))
    if arr.shape != (3,):
        raise ValueError(f"{name} must be a scalar or have one value per axis (3), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr}")
    arr = arr.copy()
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False, init=False)
class SensorTruth:
    """The true linear thermal model of one sensor, per axis (x, y, z).

    Parameters
    ----------
    units : str
        Output units, ``"V"`` or ``"LSB"``.
    zero_g_offset : array_like, shape (3,)
        Output at 0 g at the reference temperature, in ``units``.
    sensitivity_per_g : array_like, shape (3,)
        Sensitivity at the reference temperature, ``units`` per g.
    offset_tc_mg_per_c : array_like, shape (3,)
        Zero-g offset change vs temperature, mg/°C (scaled to ``units`` with the
        sensitivity at the reference temperature, as the paper does).
    sensitivity_tc_pct_per_c : array_like, shape (3,)
        Sensitivity change vs temperature, %/°C of the reference sensitivity.
    reference_temperature_c : float, optional
        Temperature of the reference values, °C; default 25.

    Notes
    -----
    Scalars are broadcast to the three axes; arrays are stored read-only.
    """

    units: str
    zero_g_offset: FloatArray
    sensitivity_per_g: FloatArray
    offset_tc_mg_per_c: FloatArray
    sensitivity_tc_pct_per_c: FloatArray
    reference_temperature_c: float

    def __init__(
        self,
        units: str,
        zero_g_offset: npt.ArrayLike,
        sensitivity_per_g: npt.ArrayLike,
        offset_tc_mg_per_c: npt.ArrayLike,
        sensitivity_tc_pct_per_c: npt.ArrayLike,
        reference_temperature_c: float = paper.REFERENCE_TEMPERATURE_C,
    ) -> None:
        if units not in ("V", "LSB"):
            raise ValueError(f"units must be 'V' or 'LSB', got {units!r}")
        object.__setattr__(self, "units", units)
        for name, value in (
            ("zero_g_offset", zero_g_offset),
            ("sensitivity_per_g", sensitivity_per_g),
            ("offset_tc_mg_per_c", offset_tc_mg_per_c),
            ("sensitivity_tc_pct_per_c", sensitivity_tc_pct_per_c),
        ):
            object.__setattr__(self, name, axis3(value, name))
        if np.any(self.sensitivity_per_g == 0.0):
            raise ValueError("sensitivity_per_g must be non-zero on every axis")
        t_ref = float(reference_temperature_c)
        if not math.isfinite(t_ref):
            raise ValueError("reference_temperature_c must be finite")
        object.__setattr__(self, "reference_temperature_c", t_ref)

    @classmethod
    def from_paper(cls, sensor: str) -> SensorTruth:
        """Return the paper's measured part (Tables 3-6) as the truth.

        Parameters
        ----------
        sensor : str
            ``"ADXL335"``, ``"ADXL327"``, ``"LIS344ALH"`` or ``"MPU-9255"``.

        Returns
        -------
        SensorTruth
            Offset and sensitivity at 25 °C from Table 3 (or 4), sensitivity
            tempco from Table 5, offset tempco from Table 6.
        """
        ref = datasheets.measured(sensor)
        return cls(
            units=ref.units,
            zero_g_offset=np.array(ref.zero_g_offset.as_tuple()),
            sensitivity_per_g=np.array(ref.sensitivity.as_tuple()),
            offset_tc_mg_per_c=np.array(ref.offset_tc_mg_per_c.as_tuple()),
            sensitivity_tc_pct_per_c=np.array(ref.sensitivity_tc_pct_per_c.as_tuple()),
            reference_temperature_c=ref.reference_temperature_c,
        )

    @property
    def offset_tc_per_c(self) -> FloatArray:
        """Zero-g offset slope, ``units`` per °C."""
        return paper.offset_tc_from_mg_per_c(self.offset_tc_mg_per_c, self.sensitivity_per_g)

    @property
    def sensitivity_tc_per_c(self) -> FloatArray:
        """Sensitivity slope, ``units`` per g per °C."""
        return paper.sensitivity_tc_from_pct_per_c(
            self.sensitivity_tc_pct_per_c, self.sensitivity_per_g
        )

    def zero_g_offset_at(self, temperature_c: npt.ArrayLike) -> FloatArray:
        """Zero-g offset at each temperature, shape ``(n, 3)``, ``units``."""
        t = np.asarray(temperature_c, dtype=np.float64).reshape(-1, 1)
        return paper.zero_g_offset_at(
            t,
            self.zero_g_offset,
            self.offset_tc_mg_per_c,
            self.sensitivity_per_g,
            self.reference_temperature_c,
        )

    def sensitivity_at(self, temperature_c: npt.ArrayLike) -> FloatArray:
        """Sensitivity at each temperature, shape ``(n, 3)``, ``units`` per g."""
        t = np.asarray(temperature_c, dtype=np.float64).reshape(-1, 1)
        return paper.sensitivity_at(
            t, self.sensitivity_per_g, self.sensitivity_tc_pct_per_c, self.reference_temperature_c
        )
