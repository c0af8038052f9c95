"""A part's datasheet (:class:`Datasheet`) and the paper's measured values of a part."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Final

from accelcore.constants import AXES
from accelcore.datasheets.limits import AxisLimits, AxisValues, Limits

__all__ = ["PARAMETERS", "Datasheet", "MeasuredReference"]

PARAMETERS: Final = (
    "sensitivity",
    "zero_g_offset",
    "output_at_plus_1g",
    "output_at_minus_1g",
    "zero_g_tolerance_mg",
    "sensitivity_tc_pct_per_c",
    "offset_tc_mg_per_c",
    "noise_density_ug_per_sqrt_hz",
)
"""Per-axis parameters of a :class:`Datasheet`, the names :meth:`Datasheet.in_spec` takes."""


@dataclass(frozen=True)
class Datasheet:
    """A part's datasheet: limits at 25 °C and temperature coefficients.

    Parameters
    ----------
    name : str
        Canonical part name, e.g. ``"MPU-9255"``.
    units : str
        Output units: ``"V"``, ``"LSB"``, ``"g"`` or ``"m/s2"``.
    sensitivity : AxisLimits
        Sensitivity, in ``units`` per g.
    zero_g_offset : AxisLimits
        Output at 0 g, in ``units``.
    output_at_plus_1g, output_at_minus_1g : AxisLimits
        Output with the axis at +1 g and -1 g, in ``units``.
    zero_g_tolerance_mg : AxisLimits
        Initial zero-g tolerance in mg (digital parts).
    sensitivity_tc_pct_per_c : AxisLimits
        Sensitivity change vs temperature, %/°C relative to 25 °C.
    offset_tc_mg_per_c : AxisLimits
        Zero-g offset change vs temperature, mg/°C.
    noise_density_ug_per_sqrt_hz : AxisLimits
        Output noise density, µg/√Hz.
    measurement_range_g : Limits or None
        Full scale, ± g.
    supply_v : float or None
        Supply voltage the limits hold at.
    adc_bits : int or None
        ADC word length of a digital part.
    aliases : tuple of str
        Further names the part is found by.
    manufacturer, source : str or None
        Provenance.
    notes : tuple of str
        Transcription notes.
    origin : str
        Where the datasheet was read from (``"builtin"``, a path, or ``"<mapping>"``).
    """

    name: str
    units: str
    sensitivity: AxisLimits
    zero_g_offset: AxisLimits = field(default_factory=AxisLimits)
    output_at_plus_1g: AxisLimits = field(default_factory=AxisLimits)
    output_at_minus_1g: AxisLimits = field(default_factory=AxisLimits)
    zero_g_tolerance_mg: AxisLimits = field(default_factory=AxisLimits)
    sensitivity_tc_pct_per_c: AxisLimits = field(default_factory=AxisLimits)
    offset_tc_mg_per_c: AxisLimits = field(default_factory=AxisLimits)
    noise_density_ug_per_sqrt_hz: AxisLimits = field(default_factory=AxisLimits)
    measurement_range_g: Limits | None = None
    supply_v: float | None = None
    adc_bits: int | None = None
    aliases: tuple[str, ...] = ()
    manufacturer: str | None = None
    source: str | None = None
    notes: tuple[str, ...] = ()
    origin: str = "<mapping>"

    def limits(self, parameter: str, axis: str) -> Limits | None:
        """Return the limits of ``parameter`` on ``axis``.

        Parameters
        ----------
        parameter : str
            One of :data:`PARAMETERS`.
        axis : str
            ``"x"``, ``"y"`` or ``"z"``.

        Returns
        -------
        Limits or None
            ``None`` when the datasheet does not give the parameter for that axis.
        """
        if parameter not in PARAMETERS:
            raise ValueError(f"unknown parameter {parameter!r}; expected one of {PARAMETERS}")
        per_axis: AxisLimits = getattr(self, parameter)
        return per_axis[axis]

    def in_spec(self, parameter: str, axis: str, value: float) -> bool | None:
        """Check a measured value against the datasheet.

        Parameters
        ----------
        parameter : str
            One of :data:`PARAMETERS`, e.g. ``"sensitivity"`` (in ``units``/g) or
            ``"offset_tc_mg_per_c"``.
        axis : str
            ``"x"``, ``"y"`` or ``"z"``.
        value : float
            The measured value, in the parameter's unit.

        Returns
        -------
        bool or None
            ``None`` when the datasheet gives no minimum or maximum for it (e.g.
            the MPU-9255 zero-g offset in LSB, or a typical-only value); else
            whether ``min <= value <= max``. A "±b" limit means ``|value| <= b``.
        """
        lim = self.limits(parameter, axis)
        return None if lim is None else lim.contains(value)

    def typical(self, parameter: str) -> tuple[float | None, float | None, float | None]:
        """Return the typical value of ``parameter`` per axis ``(x, y, z)``."""
        out = [self.limits(parameter, a) for a in AXES]
        return (
            out[0].typ if out[0] else None,
            out[1].typ if out[1] else None,
            out[2].typ if out[2] else None,
        )


@dataclass(frozen=True)
class MeasuredReference:
    """The paper's measured parameters of one part (Tables 3-6).

    Parameters
    ----------
    sensor : str
        Part name.
    units : str
        Output units (``"V"`` or ``"LSB"``).
    sensitivity : AxisValues
        Sensitivity at the reference temperature, ``units`` per g.
    zero_g_offset : AxisValues
        Output at 0 g at the reference temperature, ``units``.
    output_at_plus_1g, output_at_minus_1g : AxisValues
        Output at +1 g and -1 g at the reference temperature, ``units``.
    sensitivity_tc_pct_per_c : AxisValues
        Sensitivity change vs temperature, %/°C (Table 5).
    offset_tc_mg_per_c : AxisValues
        Zero-g offset change vs temperature, mg/°C (Table 6).
    reference_temperature_c : float
        Temperature of the 25 °C values.
    source : str
        Citation.
    """

    sensor: str
    units: str
    sensitivity: AxisValues
    zero_g_offset: AxisValues
    output_at_plus_1g: AxisValues
    output_at_minus_1g: AxisValues
    sensitivity_tc_pct_per_c: AxisValues
    offset_tc_mg_per_c: AxisValues
    reference_temperature_c: float = 25.0
    source: str = ""
