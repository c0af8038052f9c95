"""Reading and validating datasheet and measured-reference TOML (schema: package docstring)."""

from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Final

from accelcore.constants import AXES, UNITS
from accelcore.datasheets.limits import AxisLimits, AxisValues, DatasheetError, Limits, number
from accelcore.datasheets.sheet import PARAMETERS, Datasheet, MeasuredReference

__all__ = [
    "DATASHEET_SCHEMA",
    "MEASURED_SCHEMA",
    "normalize",
    "parse_datasheet",
    "parse_measured",
    "read_toml",
]

DATASHEET_SCHEMA: Final = "accelcore-datasheet/1"
"""Value of the ``schema`` key of a datasheet TOML file."""

MEASURED_SCHEMA: Final = "accelcore-measured/1"
"""Value of the ``schema`` key of a measured-reference TOML file."""

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


def normalize(name: str) -> str:
    """Return the lookup key of a part name: lower case, letters and digits only.

    Parameters
    ----------
    name : str
        A part name or alias (``"MPU-9255"``).

    Returns
    -------
    str
        The key (``"mpu9255"``).
    """
    return re.sub(r"[^0-9a-z]", "", str(name).lower())


def _parse_limits(value: object, where: str) -> Limits:
    if isinstance(value, Mapping):
        keys = set(value)
        if "plus_minus" in keys:
            if keys != {"plus_minus"}:
                raise DatasheetError(f"{where}: 'plus_minus' cannot be combined with {keys}")
            return Limits.symmetric(number(value["plus_minus"], f"{where}.plus_minus"))
        unknown = keys - {"min", "typ", "max"}
        if unknown:
            raise DatasheetError(
                f"{where}: unknown key(s) {sorted(unknown)}; expected min, typ, max or plus_minus"
            )
        if not keys:
            raise DatasheetError(f"{where}: empty limits table")
        try:
            return Limits(
                min=number(value["min"], f"{where}.min") if "min" in value else None,
                typ=number(value["typ"], f"{where}.typ") if "typ" in value else None,
                max=number(value["max"], f"{where}.max") if "max" in value else None,
            )
        except DatasheetError as exc:
            if str(exc).startswith(where):
                raise
            raise DatasheetError(f"{where}: {exc}") from None
    return Limits(typ=number(value, where))


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


def parse_datasheet(data: Mapping[str, Any], origin: str) -> Datasheet:
    """Validate one datasheet mapping and build the :class:`Datasheet`.

    Parameters
    ----------
    data : mapping
        Content of a file of schema :data:`DATASHEET_SCHEMA`.
    origin : str
        Where it was read (a path or ``"<mapping>"``), for error messages and
        :attr:`Datasheet.origin`.

    Returns
    -------
    Datasheet
        The validated datasheet.

    Raises
    ------
    DatasheetError
        If the content breaks the schema (unknown keys included).
    """
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
    if not normalize(name):
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
        supply = number(data["supply_v"], f"{origin}: supply_v")
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


def read_toml(path: Path) -> dict[str, Any]:
    """Read a TOML file.

    Parameters
    ----------
    path : pathlib.Path
        The file.

    Returns
    -------
    dict
        Its content.

    Raises
    ------
    DatasheetError
        If the file cannot be read or is not valid TOML.
    """
    try:
        with path.open("rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise DatasheetError(f"{path}: not valid TOML: {exc}") from None
    except OSError as exc:
        raise DatasheetError(f"{path}: cannot be read: {exc}") from None


def parse_measured(data: Mapping[str, Any], origin: str) -> dict[str, MeasuredReference]:
    """Validate a measured-reference mapping and build its parts.

    Parameters
    ----------
    data : mapping
        Content of a file of schema :data:`MEASURED_SCHEMA`.
    origin : str
        Where it was read, for error messages.

    Returns
    -------
    dict of str to MeasuredReference
        The parts, keyed by :func:`normalize` of their names.

    Raises
    ------
    DatasheetError
        If the content breaks the schema.
    """
    if data.get("schema") != MEASURED_SCHEMA:
        raise DatasheetError(f"{origin}: 'schema' must be {MEASURED_SCHEMA!r}")
    t_ref = number(data.get("reference_temperature_c", 25.0), f"{origin}: reference_temperature_c")
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
            values[key] = AxisValues(*(number(per_axis[a], f"{where}.{key}.{a}") for a in AXES))
        units = table.get("units")
        if units not in UNITS:
            raise DatasheetError(f"{where}.units: must be one of {UNITS}, got {units!r}")
        out[normalize(sensor)] = MeasuredReference(
            sensor=str(sensor), units=units, reference_temperature_c=t_ref, source=source, **values
        )
    return out
