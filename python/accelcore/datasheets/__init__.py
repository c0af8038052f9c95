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
"""

from __future__ import annotations

import math
import os
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, Final

from accelcore.constants import AXES, UNITS
from accelcore.errors import AccelcoreError

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

DATASHEET_SCHEMA: Final = "accelcore-datasheet/1"
"""Value of the ``schema`` key of a datasheet TOML file."""

MEASURED_SCHEMA: Final = "accelcore-measured/1"
"""Value of the ``schema`` key of a measured-reference TOML file."""

ENV_VAR: Final = "ACCELCORE_DATASHEETS"
"""Environment variable listing extra datasheet directories (``os.pathsep``-separated)."""


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

_DATA_DIR: Final = Path(__file__).resolve().parent
_TOP_LEVEL_KEYS: Final = frozenset(
    {
        "schema",
        "name",
        "units",
        "aliases",
        "manufacturer",
        "supply_v",
        "adc_bits",
        "source",
        "notes",
        "measurement_range_g",
        *PARAMETERS,
    }
)
_MEASURED_KEYS: Final = (
    "sensitivity",
    "zero_g_offset",
    "output_at_plus_1g",
    "output_at_minus_1g",
    "sensitivity_tc_pct_per_c",
    "offset_tc_mg_per_c",
)


class DatasheetError(AccelcoreError, ValueError):
    """A datasheet file or mapping breaks the schema, or a part is unknown."""


def _number(value: object, where: str) -> float:
    """Return ``value`` as a finite float, or raise :class:`DatasheetError`."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise DatasheetError(f"{where}: expected a number, got {value!r}")
    result = float(value)
    if not math.isfinite(result):
        raise DatasheetError(f"{where}: expected a finite number, got {value!r}")
    return result


@dataclass(frozen=True)
class Limits:
    """Minimum, typical and maximum of one datasheet parameter.

    Any of the three may be ``None`` (not given). A symmetric "±b" limit is
    ``Limits(min=-b, typ=None, max=b)`` (see :meth:`symmetric`).

    Parameters
    ----------
    min, typ, max : float or None
        The limits, in the parameter's unit; ``min <= typ <= max`` where given.
    """

    min: float | None = None
    typ: float | None = None
    max: float | None = None

    def __post_init__(self) -> None:
        for name in ("min", "typ", "max"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, _number(value, f"Limits.{name}"))
        given = [v for v in (self.min, self.typ, self.max) if v is not None]
        if given != sorted(given):
            raise DatasheetError(f"limits must satisfy min <= typ <= max, got {self}")

    @classmethod
    def symmetric(cls, bound: float) -> Limits:
        """Return the limits "±bound": ``|value| <= bound``.

        Parameters
        ----------
        bound : float
            Non-negative half-width.

        Returns
        -------
        Limits
            ``Limits(-bound, None, bound)``.
        """
        half = _number(bound, "plus_minus")
        if half < 0.0:
            raise DatasheetError(f"plus_minus must be >= 0, got {bound!r}")
        return cls(min=-half, typ=None, max=half)

    @property
    def has_bounds(self) -> bool:
        """Whether a minimum or a maximum is given (so a value can be checked)."""
        return self.min is not None or self.max is not None

    def contains(self, value: float) -> bool | None:
        """Check ``value`` against the minimum and maximum.

        Parameters
        ----------
        value : float
            The value to check, in the parameter's unit.

        Returns
        -------
        bool or None
            ``None`` when neither bound is given, else whether
            ``min <= value <= max`` (a missing bound does not constrain).
        """
        if not self.has_bounds:
            return None
        v = float(value)
        if math.isnan(v):
            return False
        return (self.min is None or v >= self.min) and (self.max is None or v <= self.max)


@dataclass(frozen=True)
class AxisLimits:
    """Per-axis :class:`Limits` of one parameter (``None`` where not given).

    Parameters
    ----------
    x, y, z : Limits or None
        Limits for each axis.
    """

    x: Limits | None = None
    y: Limits | None = None
    z: Limits | None = None

    def __getitem__(self, axis: str) -> Limits | None:
        """Return the limits of ``axis`` ("x", "y" or "z", any case)."""
        return getattr(self, _axis(axis))  # type: ignore[no-any-return]

    @property
    def is_empty(self) -> bool:
        """Whether no axis has limits."""
        return self.x is None and self.y is None and self.z is None


@dataclass(frozen=True)
class AxisValues:
    """One value per axis.

    Parameters
    ----------
    x, y, z : float
        The values.
    """

    x: float
    y: float
    z: float

    def __getitem__(self, axis: str) -> float:
        """Return the value of ``axis`` ("x", "y" or "z", any case)."""
        return float(getattr(self, _axis(axis)))

    def as_tuple(self) -> tuple[float, float, float]:
        """Return ``(x, y, z)``."""
        return (self.x, self.y, self.z)


def _axis(axis: str) -> str:
    name = str(axis).lower()
    if name not in AXES:
        raise ValueError(f"axis must be one of 'x', 'y', 'z', got {axis!r}")
    return name


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


# --------------------------------------------------------------------------- parsing


def _normalize(name: str) -> str:
    return re.sub(r"[^0-9a-z]", "", str(name).lower())


def _parse_limits(value: object, where: str) -> Limits:
    if isinstance(value, Mapping):
        keys = set(value)
        if "plus_minus" in keys:
            if keys != {"plus_minus"}:
                raise DatasheetError(f"{where}: 'plus_minus' cannot be combined with {keys}")
            return Limits.symmetric(_number(value["plus_minus"], f"{where}.plus_minus"))
        unknown = keys - {"min", "typ", "max"}
        if unknown:
            raise DatasheetError(
                f"{where}: unknown key(s) {sorted(unknown)}; expected min, typ, max or plus_minus"
            )
        if not keys:
            raise DatasheetError(f"{where}: empty limits table")
        try:
            return Limits(
                min=_number(value["min"], f"{where}.min") if "min" in value else None,
                typ=_number(value["typ"], f"{where}.typ") if "typ" in value else None,
                max=_number(value["max"], f"{where}.max") if "max" in value else None,
            )
        except DatasheetError as exc:
            if str(exc).startswith(where):
                raise
            raise DatasheetError(f"{where}: {exc}") from None
    return Limits(typ=_number(value, where))


def _parse_axis_limits(value: object, where: str) -> AxisLimits:
    if not isinstance(value, Mapping):
        raise DatasheetError(f"{where}: expected a table of axis groups (e.g. xyz = ...)")
    per_axis: dict[str, Limits] = {}
    for group, limits in value.items():
        group_name = str(group).lower()
        if not group_name or any(c not in AXES for c in group_name):
            raise DatasheetError(
                f"{where}: axis group {group!r} must be made of the letters x, y, z"
            )
        parsed = _parse_limits(limits, f"{where}.{group}")
        for axis in group_name:
            if axis in per_axis:
                raise DatasheetError(f"{where}: axis {axis!r} is given more than once")
            per_axis[axis] = parsed
    return AxisLimits(**per_axis)


def _string(value: object, where: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise DatasheetError(f"{where}: expected a non-empty string, got {value!r}")
    return value


def _string_tuple(value: object, where: str) -> tuple[str, ...]:
    if isinstance(value, str):
        return (value,)
    if not isinstance(value, list):
        raise DatasheetError(f"{where}: expected a list of strings, got {value!r}")
    return tuple(_string(v, f"{where}[{i}]") for i, v in enumerate(value))


def _parse_datasheet(data: Mapping[str, Any], origin: str) -> Datasheet:
    """Validate one datasheet mapping and build the :class:`Datasheet`."""
    if not isinstance(data, Mapping):
        raise DatasheetError(f"{origin}: a datasheet must be a table, got {type(data).__name__}")
    unknown = set(data) - _TOP_LEVEL_KEYS
    if unknown:
        raise DatasheetError(
            f"{origin}: unknown key(s) {sorted(unknown)}; allowed: {sorted(_TOP_LEVEL_KEYS)}"
        )
    schema = data.get("schema")
    if schema != DATASHEET_SCHEMA:
        raise DatasheetError(f"{origin}: 'schema' must be {DATASHEET_SCHEMA!r}, got {schema!r}")
    for required in ("name", "units", "sensitivity"):
        if required not in data:
            raise DatasheetError(f"{origin}: missing required key {required!r}")
    name = _string(data["name"], f"{origin}: name")
    if not _normalize(name):
        raise DatasheetError(f"{origin}: name {name!r} has no letters or digits")
    units = data["units"]
    if units not in UNITS:
        raise DatasheetError(f"{origin}: units must be one of {UNITS}, got {units!r}")
    kwargs: dict[str, Any] = {}
    for parameter in PARAMETERS:
        if parameter in data:
            kwargs[parameter] = _parse_axis_limits(data[parameter], f"{origin}: {parameter}")
    if kwargs["sensitivity"].is_empty:
        raise DatasheetError(f"{origin}: 'sensitivity' gives no axis")
    if "measurement_range_g" in data:
        rng = _parse_limits(data["measurement_range_g"], f"{origin}: measurement_range_g")
        if any(v is not None and v <= 0 for v in (rng.min, rng.typ, rng.max)):
            raise DatasheetError(f"{origin}: measurement_range_g must be positive (± full scale)")
        kwargs["measurement_range_g"] = rng
    if "supply_v" in data:
        supply = _number(data["supply_v"], f"{origin}: supply_v")
        if supply <= 0:
            raise DatasheetError(f"{origin}: supply_v must be > 0, got {supply}")
        kwargs["supply_v"] = supply
    if "adc_bits" in data:
        bits = data["adc_bits"]
        if isinstance(bits, bool) or not isinstance(bits, int) or not 2 <= bits <= 32:
            raise DatasheetError(f"{origin}: adc_bits must be an integer in 2..32, got {bits!r}")
        kwargs["adc_bits"] = bits
    for key in ("manufacturer", "source"):
        if key in data:
            kwargs[key] = _string(data[key], f"{origin}: {key}")
    if "aliases" in data:
        kwargs["aliases"] = _string_tuple(data["aliases"], f"{origin}: aliases")
    if "notes" in data:
        kwargs["notes"] = _string_tuple(data["notes"], f"{origin}: notes")
    return Datasheet(name=name, units=units, origin=origin, **kwargs)


def _read_toml(path: Path) -> dict[str, Any]:
    try:
        with path.open("rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise DatasheetError(f"{path}: not valid TOML: {exc}") from None
    except OSError as exc:
        raise DatasheetError(f"{path}: cannot be read: {exc}") from None


def _keys(ds: Datasheet) -> list[str]:
    return list(dict.fromkeys(_normalize(n) for n in (ds.name, *ds.aliases) if _normalize(n)))


def _index(parts: list[Datasheet], what: str) -> dict[str, Datasheet]:
    """Map every normalised name and alias to its part, refusing duplicates."""
    out: dict[str, Datasheet] = {}
    for ds in parts:
        for key in _keys(ds):
            other = out.get(key)
            if other is not None and other is not ds:
                raise DatasheetError(
                    f"{what}: the name {key!r} is used by both {other.origin} and {ds.origin}"
                )
            out[key] = ds
    return out


def _read_dir(directory: Path, what: str) -> dict[str, Datasheet]:
    parts = []
    for path in sorted(directory.glob("*.toml")):
        data = _read_toml(path)
        if data.get("schema") == MEASURED_SCHEMA:
            continue
        parts.append(_parse_datasheet(data, str(path)))
    return _index(parts, what)


# --------------------------------------------------------------------------- registry

_builtin: dict[str, Datasheet] | None = None
_env: tuple[str, dict[str, Datasheet]] | None = None
_registered: dict[str, Datasheet] = {}
_measured: dict[str, MeasuredReference] | None = None


def _builtin_parts() -> dict[str, Datasheet]:
    global _builtin
    if _builtin is None:
        parts = _read_dir(_DATA_DIR, "built-in datasheets")
        _builtin = {k: _with_origin(v, "builtin") for k, v in parts.items()}
    return _builtin


def _with_origin(ds: Datasheet, origin: str) -> Datasheet:
    values = {f.name: getattr(ds, f.name) for f in fields(ds)}
    values["origin"] = origin
    return Datasheet(**values)


def _env_parts() -> dict[str, Datasheet]:
    global _env
    value = os.environ.get(ENV_VAR, "")
    if _env is not None and _env[0] == value:
        return _env[1]
    merged: dict[str, Datasheet] = {}
    for entry in value.split(os.pathsep):
        if not entry.strip():
            continue
        directory = Path(entry).expanduser()
        if not directory.is_dir():
            raise DatasheetError(f"{ENV_VAR} lists {entry!r}, which is not a directory")
        for key, ds in _read_dir(directory, f"{ENV_VAR} directory {entry!r}").items():
            merged.setdefault(key, ds)  # the first directory wins, as in PATH
    _env = (value, merged)
    return merged


def _lookup(key: str) -> Datasheet | None:
    for source in (_registered, _env_parts(), _builtin_parts()):
        if key in source:
            return source[key]
    return None


def load(name: str) -> Datasheet:
    """Return the datasheet of a part.

    Parameters
    ----------
    name : str
        Part name or alias, case-insensitive, punctuation ignored
        (``"mpu9255"`` finds ``"MPU-9255"``).

    Returns
    -------
    Datasheet
        From :func:`register`, else from ``ACCELCORE_DATASHEETS``, else built in.

    Raises
    ------
    DatasheetError
        If no part of that name is known, or a datasheet file is invalid.
    """
    ds = _lookup(_normalize(name))
    if ds is None:
        raise DatasheetError(f"unknown sensor {name!r}; known parts: {', '.join(names())}")
    return ds


def names() -> list[str]:
    """Return the canonical names of every known part, sorted.

    Returns
    -------
    list of str
        Built-in, ``ACCELCORE_DATASHEETS`` and registered parts.
    """
    seen: dict[str, str] = {}
    for source in (_registered, _env_parts(), _builtin_parts()):
        for ds in source.values():
            key = _normalize(ds.name)
            if key not in seen and _lookup(key) is ds:
                seen[key] = ds.name
    return sorted(seen.values(), key=str.lower)


def register(
    source: str | os.PathLike[str] | Mapping[str, Any], *, replace: bool = False
) -> Datasheet:
    """Add a part from a TOML file or a mapping of the datasheet schema.

    Parameters
    ----------
    source : str, path-like or mapping
        Path of a ``.toml`` file, or its content as a mapping.
    replace : bool, optional
        Allow the part to shadow an existing part of the same name or alias.

    Returns
    -------
    Datasheet
        The validated datasheet, now returned by :func:`load`.

    Raises
    ------
    DatasheetError
        If the content breaks the schema, or a name is taken and not ``replace``.
    """
    if isinstance(source, Mapping):
        ds = _parse_datasheet(source, "<mapping>")
    else:
        path = Path(source)
        ds = _parse_datasheet(_read_toml(path), str(path))
    keys = _keys(ds)
    if not replace:
        for key in keys:
            existing = _lookup(key)
            if existing is not None:
                raise DatasheetError(
                    f"a part named {existing.name!r} ({existing.origin}) already answers to "
                    f"{key!r}; pass replace=True to shadow it"
                )
    for key in keys:
        _registered[key] = ds
    return ds


def unregister(name: str) -> None:
    """Remove a part added with :func:`register` (all its names).

    Parameters
    ----------
    name : str
        Any of its names.

    Raises
    ------
    DatasheetError
        If no registered part has that name.
    """
    ds = _registered.get(_normalize(name))
    if ds is None:
        raise DatasheetError(f"no part named {name!r} was registered")
    for key in [k for k, v in _registered.items() if v is ds]:
        del _registered[key]


def reload() -> None:
    """Forget cached files: built-in data and ``ACCELCORE_DATASHEETS`` are read again."""
    global _builtin, _env, _measured
    _builtin = None
    _env = None
    _measured = None


# --------------------------------------------------------------------------- measured


def _parse_measured(data: Mapping[str, Any], origin: str) -> dict[str, MeasuredReference]:
    if data.get("schema") != MEASURED_SCHEMA:
        raise DatasheetError(f"{origin}: 'schema' must be {MEASURED_SCHEMA!r}")
    t_ref = _number(data.get("reference_temperature_c", 25.0), f"{origin}: reference_temperature_c")
    source = str(data.get("source", ""))
    parts = data.get("parts")
    if not isinstance(parts, Mapping) or not parts:
        raise DatasheetError(f"{origin}: missing [parts.<name>] tables")
    out: dict[str, MeasuredReference] = {}
    for sensor, table in parts.items():
        where = f"{origin}: parts.{sensor}"
        if not isinstance(table, Mapping):
            raise DatasheetError(f"{where}: expected a table")
        unknown = set(table) - {"units", *_MEASURED_KEYS}
        if unknown:
            raise DatasheetError(f"{where}: unknown key(s) {sorted(unknown)}")
        values: dict[str, AxisValues] = {}
        for key in _MEASURED_KEYS:
            per_axis = table.get(key)
            if not isinstance(per_axis, Mapping) or set(per_axis) != set(AXES):
                raise DatasheetError(f"{where}.{key}: expected {{ x = .., y = .., z = .. }}")
            values[key] = AxisValues(*(_number(per_axis[a], f"{where}.{key}.{a}") for a in AXES))
        units = table.get("units")
        if units not in UNITS:
            raise DatasheetError(f"{where}.units: must be one of {UNITS}, got {units!r}")
        out[_normalize(sensor)] = MeasuredReference(
            sensor=str(sensor), units=units, reference_temperature_c=t_ref, source=source, **values
        )
    return out


def _measured_parts() -> dict[str, MeasuredReference]:
    global _measured
    if _measured is None:
        merged: dict[str, MeasuredReference] = {}
        for path in sorted(_DATA_DIR.glob("*.toml")):
            data = _read_toml(path)
            if data.get("schema") == MEASURED_SCHEMA:
                merged.update(_parse_measured(data, str(path)))
        _measured = merged
    return _measured


def measured(name: str) -> MeasuredReference:
    """Return the paper's measured parameters of a part (Tables 3-6).

    Parameters
    ----------
    name : str
        Part name, matched as in :func:`load`.

    Returns
    -------
    MeasuredReference
        Sensitivity, zero-g offset and ±1 g outputs at 25 °C, and the two
        temperature coefficients, per axis, as printed in the paper.

    Raises
    ------
    DatasheetError
        If the paper did not measure that part.
    """
    ref = _measured_parts().get(_normalize(name))
    if ref is None:
        raise DatasheetError(
            f"no measured reference for {name!r}; available: {', '.join(measured_names())}"
        )
    return ref


def measured_names() -> list[str]:
    """Return the names of the parts with a measured reference, sorted."""
    return sorted((m.sensor for m in _measured_parts().values()), key=str.lower)
