"""Datasheet library: manufacturers' limits for MEMS accelerometers.

The library ships the four parts of Sawicki & Walendziuk (ADXL335, ADXL327,
LIS344ALH, MPU-9255) as TOML package data, transcribed from the paper's
Tables 1-6, and the paper's *measured* values (Tables 3-6) as a separate
reference data set (:func:`measured`).

>>> from accelcore import datasheets
>>> ds = datasheets.load("adxl335")
>>> ds.sensitivity["z"]
Limits(min=0.27, typ=0.3, max=0.33)
>>> ds.in_spec("offset_tc_mg_per_c", "z", -3.602)
False

Adding parts
------------
Write a TOML file of the schema below and either call :func:`register` with its
path (or with the same content as a mapping), or put it in a directory listed in
the environment variable ``ACCELCORE_DATASHEETS`` (directories separated by
``os.pathsep``; every ``*.toml`` in them is read). Parts from
``ACCELCORE_DATASHEETS`` shadow built-in parts of the same name; :func:`register`
refuses to shadow an existing part unless ``replace=True``. Names are matched
case-insensitively, ignoring anything but letters and digits (``"mpu9255"``,
``"MPU-9255"`` and ``"Mpu 9255"`` are the same part).

.. code-block:: toml

    schema = "accelcore-datasheet/1"   # required, exact
    name = "ADXL335"                   # required
    units = "V"                        # required: "V", "LSB", "g" or "m/s2"
    aliases = ["ADXL-335"]             # optional, further names
    manufacturer = "Analog Devices"    # optional
    supply_v = 3.0                     # optional: supply the limits hold at
    adc_bits = 16                      # optional: word length of a digital part
    source = "data sheet Rev. B"       # optional
    notes = ["..."]                    # optional, free text
    measurement_range_g = { min = 3.0, typ = 3.6 }   # optional, +/- full scale

    # Per-axis parameters: a table whose keys are axis groups ("xyz", "xy", "z",
    # ...; each axis at most once) and whose values are limits: a table of
    # min/typ/max (any subset), a bare number (the typical value), or
    # { plus_minus = b } for a symmetric "+/-b" limit (|value| <= b).
    [sensitivity]                      # required, output units per g
    xyz = { min = 0.270, typ = 0.300, max = 0.330 }
    [zero_g_offset]                    # output units at 0 g
    xy = { min = 1.35, typ = 1.5, max = 1.65 }
    z = { min = 1.2, typ = 1.5, max = 1.8 }
    [output_at_plus_1g]                # output units at +1 g
    [output_at_minus_1g]               # output units at -1 g
    [zero_g_tolerance_mg]              # initial zero-g tolerance, mg
    [sensitivity_tc_pct_per_c]         # sensitivity change vs temperature, %/°C
    xyz = { plus_minus = 0.01 }
    [offset_tc_mg_per_c]               # zero-g offset change vs temperature, mg/°C
    xyz = { plus_minus = 1.0 }
    [noise_density_ug_per_sqrt_hz]     # noise density, µg/sqrt(Hz)
    xyz = 150.0

Unknown keys are errors (they are usually typos). Every schema violation raises
:class:`DatasheetError`, a :class:`ValueError`, naming the file and the key.

Modules: :mod:`~accelcore.datasheets.limits` (:class:`Limits`, :class:`AxisLimits`,
:class:`AxisValues`, :class:`DatasheetError`), :mod:`~accelcore.datasheets.sheet`
(:class:`Datasheet`, :class:`MeasuredReference`, :data:`PARAMETERS`),
:mod:`~accelcore.datasheets.parsing` (the TOML schema checked) and
:mod:`~accelcore.datasheets.registry` (:func:`load`, :func:`register`, ... and
their caches). Foundation: imports only :mod:`accelcore.constants` and
:mod:`accelcore.errors`.
"""

from __future__ import annotations

from accelcore.constants import AXES, UNITS
from accelcore.datasheets.limits import AxisLimits, AxisValues, DatasheetError, Limits
from accelcore.datasheets.parsing import DATASHEET_SCHEMA, MEASURED_SCHEMA
from accelcore.datasheets.registry import (
    ENV_VAR,
    load,
    measured,
    measured_names,
    names,
    register,
    reload,
    unregister,
)
from accelcore.datasheets.sheet import PARAMETERS, Datasheet, MeasuredReference

__all__ = [
    "AXES",
    "DATASHEET_SCHEMA",
    "ENV_VAR",
    "MEASURED_SCHEMA",
    "PARAMETERS",
    "UNITS",
    "AxisLimits",
    "AxisValues",
    "Datasheet",
    "DatasheetError",
    "Limits",
    "MeasuredReference",
    "load",
    "measured",
    "measured_names",
    "names",
    "register",
    "reload",
    "unregister",
]
